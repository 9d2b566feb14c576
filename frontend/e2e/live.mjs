#!/usr/bin/env node
/**
 * End-to-end checks of the live channel, forms, forks and privacy against a running
 * `alcove up` (API + real worker), in one browser session:
 *
 *  - the campaign list shows a campaign created and started through the REST API while it is
 *    open, and its status as it changes, without a reload (list stream);
 *  - short campaigns (2-3 iterations, aux-penalty oracle) end repeatedly while their page is
 *    open: every time, the RMSE plot shows every iteration the server has, the header's latest
 *    RMSE is the plot's last iteration, and the page was live (stream) without polling;
 *  - clicking a point of the RMSE plot opens that iteration on the forces tab (k in the URL);
 *  - overlaying all iterations colours them on one scale with one colorbar, and the force plot
 *    keeps its size (no legend entry per iteration);
 *  - a fork made with the dialog (defaults continue the campaign) never shows k / N with k > N
 *    and its RMSE plot shows the inherited iterations greyed;
 *  - a bad form submit: one message per problem at its field, the count agrees, no uncaught
 *    page error or console error;
 *  - the task editor's chain model (2-DOF preset): tables of links and joints, the drawing
 *    follows an edit, the API's error shows at its cell (model.chain.joints.1.q0);
 *  - no request of the page goes to another origin (list, campaign page, every tab, a plot's
 *    PNG download from its toolbar).
 *
 *   node e2e/live.mjs --base-url http://127.0.0.1:8765 --email admin@alcove.local --password secret --artifacts ../test-artifacts
 */
import { mkdirSync } from "node:fs";
import { resolve } from "node:path";
import { apiClient, openBrowser, openTab, parseArgs, signInByToken, sleep, waitFor } from "./browser.mjs";

const args = parseArgs(process.argv.slice(2));
const baseUrl = String(args["base-url"] ?? "http://127.0.0.1:8000").replace(/\/$/, "");
const origin = new URL(baseUrl).origin;
const email = String(args.email ?? "admin@alcove.local");
const password = String(args.password ?? "alcove-admin");
const artifacts = resolve(String(args.artifacts ?? "test-artifacts"));
const endings = Number(args.endings ?? 5);
mkdirSync(artifacts, { recursive: true });
const t0 = Date.now();
const step = (name) => console.log(`[live ${((Date.now() - t0) / 1000).toFixed(1)} s] ${name}`);
const TERMINAL = ["completed", "failed", "cancelled"];

const { context, close } = await openBrowser();
const page = context.pages()[0] ?? (await context.newPage());

// every request the page makes: none may leave the server's origin
const foreign = [];
page.on("request", (r) => {
  const u = new URL(r.url());
  if (u.protocol === "data:" || u.protocol === "blob:") return;
  if (u.origin !== origin) foreign.push(`${r.method()} ${r.url()}`);
});
const pageErrors = [];
page.on("pageerror", (e) => pageErrors.push(String(e)));
const consoleErrors = [];
page.on("console", (m) => m.type() === "error" && consoleErrors.push(m.text()));
// the page's requests per path (to check that nothing polls while the stream is up)
const requests = [];
page.on("request", (r) => requests.push({ t: Date.now(), method: r.method(), url: new URL(r.url()) }));

let token;
const api = apiClient(page, baseUrl, () => token);
const serverIterations = async (id) => (await api("GET", `/campaigns/${id}/metrics`)).map((m) => m.iteration_index).join(",");

try {
  step("sign in; a task (10 intervals per phase) and an aux-penalty oracle through the API");
  token = await signInByToken(page, baseUrl, email, password);
  // a quiet worker: campaigns other tests left running are cancelled
  for (const c of await api("GET", "/campaigns?limit=500"))
    if (["queued", "running", "pausing", "paused", "draft"].includes(c.status)) await api("POST", `/campaigns/${c.id}/cancel`).catch(() => null);
  const stamp = Date.now().toString(36);
  const preset = (await api("GET", "/tasks/presets"))[0];
  const spec = structuredClone(preset.spec);
  for (const ph of spec.phases) ph.intervals = 10;
  const task = await api("POST", "/tasks", { name: `live task ${stamp}`, description: "", spec });
  const oracle = await api("POST", "/oracles", { name: `live oracle ${stamp}`, description: "", type: "aux-penalty", params: {} });
  // short campaigns: an ensemble of 2 with short training and no held-out suite (run.mjs covers the suite)
  const surrogate = await api("POST", "/surrogate-configs", { name: `live surrogate ${stamp}`, spec: { max_epochs: 60, ensemble_size: 2 } });
  const newCampaign = (name, iterations, start = true) =>
    api("POST", "/campaigns", {
      name,
      task_id: task.id,
      oracle_id: oracle.id,
      surrogate_config_id: surrogate.id,
      start,
      preliminary: { samples: 300 },
      settings: { validation_motions: 0 },
      stopping: { max_iterations: iterations },
    });

  step("campaign list: a campaign created and started through the API appears, and its status follows, without reload");
  if (!args["skip-list"]) {
  await page.goto(`${baseUrl}/campaigns`);
  await page.getByRole("heading", { name: "Campaigns" }).waitFor();
  await page.locator("[data-testid=live-state][data-state=live]").waitFor({ timeout: 15_000 });
  let navigations = 0;
  page.on("framenavigated", (f) => f === page.mainFrame() && navigations++);
  const elsewhere = await newCampaign(`from the API ${stamp}`, 2, false);
  const row = page.locator(`tr[data-campaign-id="${elsewhere.id}"]`);
  await row.waitFor({ timeout: 10_000 });
  step(`  appeared as ${await row.getAttribute("data-status")}`);
  await api("POST", `/campaigns/${elsewhere.id}/start`);
  await page.locator(`tr[data-campaign-id="${elsewhere.id}"]:is([data-status=queued],[data-status=running],[data-status=completed])`).waitFor({ timeout: 15_000 });
  await page.locator(`tr[data-campaign-id="${elsewhere.id}"][data-status=completed]`).waitFor({ timeout: 90_000 });
  if (navigations) throw new Error(`the list page navigated ${navigations} times`);
  step("  started, ran and completed on the open list");
  }

  step(`${endings} short campaigns end while their page is open: the plot shows every iteration the server has`);
  const ended = [];
  for (let i = 0; i < endings; i++) {
    const n = 2 + (i % 2);
    const c = await newCampaign(`ending ${i + 1} ${stamp}`, n);
    const since = Date.now();
    await page.goto(`${baseUrl}/campaigns/${c.id}`);
    const states = new Set();
    await waitFor(
      async () => {
        const { state, status } = await page.evaluate(() => ({
          state: document.querySelector("[data-testid=live-state]")?.getAttribute("data-state") ?? null,
          status: document.querySelector("h1 + .badge")?.textContent?.trim() ?? null,
        }));
        states.add(state);
        return TERMINAL.includes(status) ? status : null;
      },
      `campaign ${c.id} to end`,
      120_000,
    );
    const endedAt = Date.now();
    const expected = await serverIterations(c.id);
    // correct by construction: the last iteration's metrics follow the terminal status at once
    await waitFor(async () => (await page.getByTestId("rmse-plot").getAttribute("data-iterations")) === expected, `plot of campaign ${c.id} to show iterations ${expected}`, 8_000, 100).catch(async (err) => {
      throw new Error(`${err.message}; plot has ${await page.getByTestId("rmse-plot").getAttribute("data-iterations")}`);
    });
    const lag = Date.now() - endedAt;
    const header = await page.getByTestId("latest-force-rmse").getAttribute("data-iteration");
    if (header !== expected.split(",").pop()) throw new Error(`header shows iteration ${header}, plot ${expected}`);
    if (!states.has("live")) throw new Error(`campaign ${c.id}: the page never had the live stream (${[...states]})`);
    const metricsRequests = requests.filter((r) => r.t >= since && r.url.pathname === `/api/v1/campaigns/${c.id}/metrics`).length;
    // one initial fetch, one per evaluated iteration, a few retries at most: no polling
    if (metricsRequests > n + 4) throw new Error(`campaign ${c.id}: ${metricsRequests} metrics requests for ${n} iterations (polling?)`);
    ended.push(c.id);
    step(`  campaign ${c.id}: iterations ${expected} on the plot ${lag} ms after the end; ${metricsRequests} metrics requests`);
  }
  const last = ended[ended.length - 1];

  step("click a point of the RMSE plot: that iteration opens on the forces tab");
  await page.goto(`${baseUrl}/campaigns/${last}?tab=jobs`);
  await page.locator("[data-testid=rmse-plot][data-rendered=true]").waitFor();
  const firstPoint = page.locator("[data-testid=rmse-plot] .scatterlayer .trace").first().locator(".points path").first();
  const box = await firstPoint.boundingBox();
  if (!box) throw new Error("no point drawn on the RMSE plot");
  const kClicked = Number((await page.getByTestId("rmse-plot").getAttribute("data-iterations")).split(",")[0]);
  await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
  await page.mouse.down();
  await page.mouse.up();
  await page.locator(`[data-testid=forces-panel][data-iteration="${kClicked}"]`).waitFor({ timeout: 10_000 });
  const url = new URL(page.url());
  if (url.searchParams.get("k") !== String(kClicked)) throw new Error(`URL after the click: ${url.search}`);
  await page.getByTestId("iteration-value").filter({ hasText: `k = ${kClicked}` }).waitFor();
  step(`  k=${kClicked} in the URL, forces panel shows iteration ${kClicked}`);

  step("overlay all iterations: one colour scale and colorbar, the plot keeps its size");
  await page.locator("[data-testid=force-plot][data-rendered=true]").waitFor();
  const area = async () => (await page.locator("[data-testid=force-plot] .nsewdrag").first().boundingBox())?.height ?? 0;
  const single = await area();
  await page.getByRole("group", { name: "Quick choices" }).getByRole("button", { name: /^all/ }).click();
  const n = (await page.getByTestId("rmse-plot").getAttribute("data-iterations")).split(",").filter((k) => Number(k) > 0).length;
  await waitFor(async () => Number(await page.getByTestId("force-plot").getAttribute("data-traces")) === n * 2 * 2 + 1, `${n} iterations overlaid`);
  await page.locator("[data-testid=force-plot] .colorbar").first().waitFor();
  await sleep(300);
  const overlaid = await area();
  const legend = await page.locator("[data-testid=force-plot] .legend .traces").count();
  if (overlaid < single - 2 || overlaid < 200) throw new Error(`force plot area ${single} px -> ${overlaid} px with the overlay`);
  if (legend > 2) throw new Error(`${legend} legend entries with the overlay`);
  step(`  plot area ${single.toFixed(0)} -> ${overlaid.toFixed(0)} px, ${legend} legend entries, 1 colorbar`);

  step("every tab, a plot's PNG download from its toolbar");
  for (const tab of ["Trajectory", "Jobs", "Pool & models", "Forces & moments"]) {
    await openTab(page, tab);
  }
  await page.getByTestId("rmse-plot").hover();
  const cloud = await page.locator("[data-testid=rmse-plot] .modebar-btn[data-attr*=cloud i], [data-testid=rmse-plot] .modebar-btn[data-title*=cloud i], [data-testid=rmse-plot] .modebar-btn[data-title*=Studio]").count();
  if (cloud) throw new Error(`${cloud} cloud / Chart Studio buttons in the plot toolbar`);
  const [png] = await Promise.all([page.waitForEvent("download", { timeout: 15_000 }), page.locator("[data-testid=rmse-plot] .modebar-btn[data-title*=PNG i], [data-testid=rmse-plot] .modebar-btn[data-title*=png i]").first().click()]);
  step(`  downloaded ${png.suggestedFilename()}`);

  step("fork with the dialog: defaults continue the campaign, progress never k / N with k > N, inherited iterations grey");
  await page.getByRole("button", { name: "Fork…" }).click();
  const dialog = page.getByRole("dialog");
  const lastK = Number((await page.getByTestId("rmse-plot").getAttribute("data-iterations")).split(",").pop());
  const kDefault = Number(await dialog.getByLabel("Fork after iteration k").inputValue());
  const further = Number(await dialog.getByLabel("Further iterations").inputValue());
  await waitFor(async () => Number(await dialog.getByLabel("max_iterations", { exact: true }).inputValue()) === kDefault + further, "max_iterations = k + further");
  if (kDefault !== lastK || further < 1) throw new Error(`fork defaults: k=${kDefault} (latest ${lastK}), further=${further}`);
  step(`  defaults: fork after ${kDefault}, ${further} further iterations (max_iterations ${kDefault + further})`);
  await dialog.getByLabel("Further iterations").fill("2");
  await dialog.getByRole("button", { name: "Fork", exact: true }).click();
  await page.waitForURL((u) => /\/campaigns\/\d+$/.test(u.pathname) && !u.pathname.endsWith(`/${last}`));
  const forkId = Number(/\/campaigns\/(\d+)/.exec(page.url())[1]);
  const seen = new Set();
  const overshoot = [];
  await waitFor(
    async () => {
      const { text, status } = await page.evaluate(() => ({
        text: document.querySelector("[data-testid=iteration-progress]")?.textContent?.trim() ?? "",
        status: document.querySelector("h1 + .badge")?.textContent?.trim() ?? null,
      }));
      seen.add(text);
      const m = /^(\d+) \/ (\d+)/.exec(text);
      if (m && Number(m[1]) > Number(m[2])) overshoot.push(text);
      return TERMINAL.includes(status) ? status : null;
    },
    "the fork to end",
    120_000,
    150,
  );
  if (overshoot.length) throw new Error(`progress showed k / N with k > N: ${overshoot.join(" | ")}`);
  const forkExpected = (await api("GET", `/campaigns/${forkId}/metrics`)).map((m) => m.iteration_index).join(",");
  await waitFor(async () => (await page.getByTestId("rmse-plot").getAttribute("data-iterations")) === forkExpected, `the fork's own iterations ${forkExpected}`, 8_000);
  const inheritedOnPlot = await page.getByTestId("rmse-plot").getAttribute("data-inherited");
  const serverInherited = (await api("GET", `/campaigns/${forkId}/metrics?inherited=true`)).filter((m) => m.inherited).map((m) => m.iteration_index).join(",");
  if (!serverInherited && !args["allow-no-inherited"]) throw new Error("the server sends no inherited rows for the fork (GET /metrics?inherited=true)");
  if (inheritedOnPlot !== serverInherited) throw new Error(`fork plot: inherited iterations ${inheritedOnPlot}, the server has ${serverInherited}`);
  step(`  fork ${forkId}: own iterations ${forkExpected}, inherited ${inheritedOnPlot} (grey); progress shown: ${[...seen].join(" | ")}`);
  await page.screenshot({ path: resolve(artifacts, "fork-page.png"), fullPage: true });

  step("a bad form submit: one message per problem at its field, the count agrees, no uncaught error");
  await page.goto(`${baseUrl}/tasks/new`);
  await page.getByLabel("phase 1 duration [s]").waitFor();
  const errorsBefore = pageErrors.length;
  const consoleBefore = consoleErrors.length;
  await page.getByLabel("Name", { exact: true }).fill(`bad task ${stamp}`);
  await page.getByLabel("phase 1 intervals").fill("2.5");
  await page.getByLabel("phase 1 q min [rad]").fill("0.1, abc");
  await page.getByLabel("phase 1 q min [rad]").blur();
  await page.getByLabel(/^gravity/).fill("1e308");
  await page.getByRole("button", { name: "Create task" }).click();
  // the refused save's answer: a message at each bad field, then no check still running
  for (const p of ["phases.0.intervals", "phases.0.q_min.1", "model.gravity"]) await page.locator(`[data-error-path='${p}']`).first().waitFor({ timeout: 15_000 });
  await page.locator("[data-testid=check-state]:not(:has-text('checking'))").waitFor();
  const paths = await page.locator("[data-error-path]").evaluateAll((els) => els.map((e) => e.getAttribute("data-error-path")));
  const count = Number(await page.getByTestId("check-state").getAttribute("data-count"));
  const texts = await page.locator("[data-error-path]").allTextContents();
  if (new Set(paths).size !== paths.length) throw new Error(`a problem is shown twice: ${paths}`);
  if (count !== paths.length) throw new Error(`the badge counts ${count}, ${paths.length} messages shown: ${texts.join(" | ")}`);
  for (const p of ["phases.0.intervals", "phases.0.q_min.1", "model.gravity"]) if (!paths.includes(p)) throw new Error(`no message at ${p}: ${paths}`);
  if ((await page.getByLabel("phase 1 q min [rad]").getAttribute("aria-invalid")) !== "true") throw new Error("the list field is not marked");
  if ((await page.locator("body").innerText()).match(/spec\.phases|Input should/)) throw new Error("raw paths or pydantic messages are shown");
  if (page.url().match(/\/tasks\/\d+$/)) throw new Error("the bad task was saved");
  const newPageErrors = pageErrors.slice(errorsBefore);
  // the browser logs every 4xx answer ("Failed to load resource: ... 422"): that is the network, not the page
  const newConsole = consoleErrors.slice(consoleBefore).filter((e) => !/Failed to load resource: the server responded with a status of 4\d\d/.test(e));
  if (newPageErrors.length || newConsole.length) throw new Error(`errors during the bad submit: ${[...newPageErrors, ...newConsole].join(" | ")}`);
  step(`  ${paths.length} problems, each once: ${texts.join(" | ")}`);
  await page.screenshot({ path: resolve(artifacts, "task-form-errors.png"), fullPage: true });

  step("the model as a chain: the 2-DOF preset's links and joints, a drawing that follows, the API's error at its cell");
  await page.getByLabel("preset", { exact: true }).selectOption("head-neck-2dof");
  await page.getByTestId("chain-links").waitFor();
  const modelDrawing = page.getByTestId("model-drawing");
  await page.locator("[data-testid=model-drawing][data-links='2']").waitFor();
  if ((await page.getByLabel(/^gravity/).count()) !== 1) throw new Error(`${await page.getByLabel(/^gravity/).count()} gravity fields for a chain model`);
  const gapBefore = Number(await modelDrawing.getAttribute("data-gap-mm"));
  await page.getByLabel("joint 2 q0 (start) [rad]").fill("0.5");
  await page.locator("[data-testid=chain-joints] [data-error-path='model.chain.joints.1.q0']").waitFor({ timeout: 10_000 });
  const q0Message = await page.locator("[data-error-path='model.chain.joints.1.q0']").innerText();
  const drawnQ = await modelDrawing.getAttribute("data-q");
  if (!drawnQ?.endsWith(",0.5000")) throw new Error(`the drawing shows q = ${drawnQ} after joint 2's q0 became 0.5`);
  const gapAfter = Number(await modelDrawing.getAttribute("data-gap-mm"));
  if (!(gapAfter < gapBefore)) throw new Error(`tilting the head back did not bring it closer: gap ${gapBefore} -> ${gapAfter} mm`);
  const chainPaths = await page.locator("[data-error-path]").evaluateAll((els) => els.map((e) => e.getAttribute("data-error-path")));
  if (new Set(chainPaths).size !== chainPaths.length) throw new Error(`a problem is shown twice: ${chainPaths}`);
  await page.getByLabel("joint 2 q0 (start) [rad]").fill("0.1");
  await page.locator("[data-error-path='model.chain.joints.1.q0']").waitFor({ state: "detached", timeout: 10_000 });
  step(`  q0 = 0.5 rad: "${q0Message}"; the head ${gapBefore} -> ${gapAfter} mm from the headrest`);
  await page.screenshot({ path: resolve(artifacts, "task-chain-editor.png"), fullPage: true });

  step("no request went to another host");
  if (foreign.length) throw new Error(`requests to other hosts: ${foreign.join(" | ")}`);
  if (pageErrors.length) throw new Error(`page errors: ${pageErrors.join(" | ")}`);
  step(`all live checks passed (${requests.length} requests, all to ${origin})`);
} catch (err) {
  await page.screenshot({ path: resolve(artifacts, "live-failure.png"), fullPage: true }).catch(() => {});
  console.error(`[live] FAILED at ${page.url()}: ${err?.stack ?? err}`);
  process.exitCode = 1;
} finally {
  await close();
}
