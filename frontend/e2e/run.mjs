#!/usr/bin/env node
/**
 * End-to-end check of the web UI against a running `alcove up` (API + real worker):
 * sign in, API token, create a task and an oracle, create and start a campaign, watch the
 * RMSE plot gain points from >= 2 iterations, open an iteration's force plot, pause and
 * resume, download a model (built by the worker first); the editors' previews ("solve once", "test on a sample
 * trajectory") run by the worker. Polling is checked on the network: every metrics poll after the
 * first asks `?after=k` and gets only iterations after k. Screenshots (the campaign page and
 * the tour of docs/quickstart.md and docs/ui.md) go into the artifacts folder and, with
 * --docs-images DIR, into DIR as well (the docs' images come from this run).
 *
 *   node e2e/run.mjs --base-url http://127.0.0.1:8765 --email admin@alcove.local \
 *        --password secret --artifacts ../test-artifacts [--docs-images ../docs/images]
 *
 * Checks chart data (data-points / data-traces of the plot wrapper, Plotly's SVG) and
 * visible text, never pixels. Exit code 0 = all steps passed.
 */
import { copyFileSync, mkdirSync, statSync } from "node:fs";
import { resolve } from "node:path";
import { openBrowser, openTab, parseArgs, waitFor } from "./browser.mjs";

const args = parseArgs(process.argv.slice(2));
const baseUrl = String(args["base-url"] ?? "http://127.0.0.1:8000").replace(/\/$/, "");
const email = String(args.email ?? "admin@alcove.local");
const password = String(args.password ?? "alcove-admin");
const artifacts = resolve(String(args.artifacts ?? "test-artifacts"));
const campaignTimeout = Number(args["campaign-timeout"] ?? 240) * 1000;
mkdirSync(artifacts, { recursive: true });
const docsImages = args["docs-images"] ? resolve(String(args["docs-images"])) : null;
if (docsImages) mkdirSync(docsImages, { recursive: true });

/** Screenshot into the artifacts folder and, when asked, the docs' image folder. */
async function screenshot(page, name, { fullPage = false } = {}) {
  const path = resolve(artifacts, name);
  await page.screenshot({ path, fullPage, animations: "disabled" });
  if (docsImages) copyFileSync(path, resolve(docsImages, name));
  return path;
}

const stopAfter = args["stop-after"] ? String(args["stop-after"]) : null;
class StopEarly extends Error {}
function checkpoint(name) {
  if (stopAfter === name) throw new StopEarly(name);
}
const t0 = Date.now();
function step(name) {
  console.log(`[e2e ${((Date.now() - t0) / 1000).toFixed(1)} s] ${name}`);
}

async function plotPoints(page, testId) {
  return Number((await page.getByTestId(testId).getAttribute("data-points")) ?? 0);
}

/** Set a slider (input type=range) as a user's drag does: the value, then an input event. */
async function setRange(locator, value) {
  await locator.evaluate((el, v) => {
    Object.getOwnPropertyDescriptor(HTMLInputElement.prototype, "value").set.call(el, String(v));
    el.dispatchEvent(new Event("input", { bubbles: true }));
  }, value);
}

async function selectByText(select, text, timeout = 15_000) {
  // the options arrive with the list query: wait for them
  const deadline = Date.now() + timeout;
  let options = [];
  while (Date.now() < deadline) {
    options = await select.locator("option").allTextContents();
    const label = options.find((o) => o.includes(text));
    if (label) return select.selectOption({ label });
    await new Promise((r) => setTimeout(r, 200));
  }
  throw new Error(`no option containing "${text}" in [${options.join(" | ")}]`);
}

const { context, close } = await openBrowser();
const page = context.pages()[0] ?? (await context.newPage());
const consoleErrors = [];
page.on("console", (m) => m.type() === "error" && consoleErrors.push(m.text()));
page.on("pageerror", (e) => consoleErrors.push(String(e)));
const stamp = Date.now().toString(36);

// Every answer to a metrics poll: the `after` it asked with and the iterations it got.
const metricPolls = [];
page.on("response", (r) => {
  const url = new URL(r.url());
  const match = /^\/api\/v1\/campaigns\/(\d+)\/metrics$/.exec(url.pathname);
  if (!match || r.request().method() !== "GET" || !r.ok()) return;
  const after = url.searchParams.get("after");
  metricPolls.push(
    r.json().then(
      (rows) => ({ campaign: match[1], after: after === null ? null : Number(after), iterations: rows.map((m) => m.iteration_index) }),
      () => null,
    ),
  );
});

try {
  step("sign in");
  await page.goto(`${baseUrl}/`);
  await page.getByLabel("Email").fill(email);
  await page.getByLabel("Password").fill(password);
  await page.getByRole("button", { name: "Sign in" }).click();
  await page.getByRole("heading", { name: "Campaigns" }).waitFor();

  step("API token: create, shown once, revoke");
  await page.getByRole("button", { name: /Account|admin/ }).click();
  await page.getByRole("menuitem", { name: "API tokens" }).click();
  await page.getByLabel("Name").fill(`e2e-${stamp}`);
  await page.getByRole("button", { name: "Create token" }).click();
  const secret = (await page.getByTestId("new-token").textContent())?.trim() ?? "";
  if (secret.length < 20) throw new Error(`token not shown: "${secret}"`);
  await page.getByRole("button", { name: "Done" }).click();
  page.once("dialog", (d) => d.accept());
  await page.getByRole("row", { name: new RegExp(`e2e-${stamp}`) }).getByRole("button", { name: "Revoke" }).click();
  await page.getByRole("row", { name: new RegExp(`e2e-${stamp}`) }).getByText("revoked").waitFor();

  step("create a task from the preset, few intervals");
  await page.getByRole("link", { name: "Tasks" }).click();
  await page.getByRole("link", { name: "New task" }).click();
  await page.getByLabel("Name", { exact: true }).fill(`e2e task ${stamp}`);
  const intervalInputs = page.getByLabel(/^phase \d+ intervals$/);
  const nPhases = await intervalInputs.count();
  for (let m = 0; m < nPhases; m++) await intervalInputs.nth(m).fill("10");
  // an invalid duration shows an inline message from the API's check endpoint
  await page.getByLabel("phase 1 duration [s]").fill("-1");
  await page.getByTestId("check-state").filter({ hasText: "problem" }).waitFor({ timeout: 15_000 });
  const durationError = await page.locator("[data-testid=phases-table] .field-error").first().textContent();
  if (!durationError) throw new Error("no inline error for a negative phase duration");
  await page.getByLabel("phase 1 duration [s]").fill("0.2");
  await page.getByTestId("check-state").filter({ hasText: "valid" }).waitFor({ timeout: 15_000 });
  await page.getByRole("button", { name: "Create task" }).click();
  await page.waitForURL(/\/tasks\/\d+$/);
  await page.getByTestId("phases-table").waitFor();

  step("share the task with an address no account has: the words do not tell");
  const invitee = `nobody-${stamp}@example.org`;
  await page.getByLabel("Share with").fill(invitee);
  await page.getByRole("button", { name: "Share", exact: true }).click();
  await page.getByRole("status").filter({ hasText: `Shared with ${invitee}. If no account uses this address yet` }).waitFor();
  await page.getByText(`${invitee} (view)`).waitFor();

  step("solve the task once (preview run by the worker)");
  await page.getByTestId("check-state").filter({ hasText: "valid" }).waitFor({ timeout: 15_000 });
  await page.getByRole("button", { name: "Solve once" }).click();
  await page.locator("[data-testid=preview-panel][data-status=succeeded], [data-testid=preview-panel][data-status=failed]").waitFor({ timeout: 120_000 });
  if ((await page.getByTestId("preview-panel").getAttribute("data-status")) !== "succeeded")
    throw new Error(`solve-once preview failed: ${await page.getByTestId("preview-panel").innerText()}`);
  await waitFor(async () => (await plotPoints(page, "preview-torque")) > 0, "torque of the solve-once preview");
  await page.locator("[data-testid=preview-torque] .main-svg").first().waitFor();
  step(`  ${(await page.getByTestId("solve-summary").innerText()).trim().replace(/\s+/g, " ")}`);
  // solved on the task's own grid (10 per phase, set above), not a preview default
  const grid = (await page.getByTestId("solve-grid").innerText()).trim();
  if (!grid.includes(Array(nPhases).fill("10").join(" + ")) || !grid.includes("the task's own grid")) throw new Error(`solve-once grid: ${grid}`);
  step("play the solution back: the 1-DOF chain moves into the cushion, the force arrow and the plots' cursor follow");
  const previewT = await page.evaluate(() => /** @type {any} */ (document.querySelector("[data-testid=preview-angle]")).data[0].x);
  const drawingQ = () => page.getByTestId("preview-player-drawing").getAttribute("data-q");
  const q0 = await drawingQ();
  const modelGap = Number(await page.getByTestId("model-drawing").getAttribute("data-gap-mm"));
  if (!(modelGap > 0)) throw new Error(`the model drawing's gap at the initial pose: ${modelGap} mm`);
  // the slider to the sample with the largest contact force: the head is in the cushion, the arrow drawn
  const fx = await page.evaluate(() => /** @type {any} */ (document.querySelector("[data-testid=preview-force]")).data[0].y);
  const peak = fx.reduce((best, v, i) => (v > fx[best] ? i : best), 0);
  if (!(fx[peak] > 0)) throw new Error("the solve-once preview has no contact force");
  await setRange(page.getByTestId("preview-player").getByLabel("Time"), String(peak));
  await waitFor(async () => (await page.getByTestId("preview-force").getAttribute("data-cursor")) === String(previewT[peak]), "the force plot's cursor at the slider's time", 5000, 100);
  for (const plot of ["preview-angle", "preview-torque"])
    if ((await page.getByTestId(plot).getAttribute("data-cursor")) !== String(previewT[peak])) throw new Error(`${plot}: no cursor at t = ${previewT[peak]}`);
  // Plotly drew the cursor: a line shape at the slider's time
  await page.locator("[data-testid=preview-force] .shapelayer path").first().waitFor();
  const atPeak = await page.getByTestId("preview-player-drawing").evaluate((svg) => ({ gap: Number(svg.getAttribute("data-gap-mm")), force: Number(svg.getAttribute("data-force")), arrow: Boolean(svg.querySelector("[data-part=force]")), q: svg.getAttribute("data-q") }));
  if (!atPeak.arrow || !(atPeak.gap < 0) || !(atPeak.force > 0) || atPeak.q === q0) throw new Error(`the picture at the force peak: ${JSON.stringify(atPeak)}`);
  step(`  at t = ${previewT[peak].toFixed(3)} s: pressed in ${(-atPeak.gap).toFixed(1)} mm, arrow ${atPeak.force} N (start: ${modelGap} mm clear)`);
  // playback from the start at real time moves the picture and the cursor
  await setRange(page.getByTestId("preview-player").getByLabel("Time"), "0");
  await page.getByTestId("preview-player").getByLabel("speed").selectOption("1");
  await page.getByTestId("preview-player-play").click();
  const cursors = new Set();
  await waitFor(
    async () => {
      cursors.add(await page.getByTestId("preview-force").getAttribute("data-cursor"));
      return (await page.getByTestId("preview-player").getAttribute("data-playing")) === "false";
    },
    "the playback to end",
    15_000,
    100,
  );
  const lastIndex = Number(await page.getByTestId("preview-player").getAttribute("data-index"));
  if (lastIndex !== previewT.length - 1 || cursors.size < 3) throw new Error(`playback ended at sample ${lastIndex} of ${previewT.length}, cursor seen at ${cursors.size} times`);
  step(`  played to the end: the cursor moved through ${cursors.size} times`);
  await setRange(page.getByTestId("preview-player").getByLabel("Time"), String(peak));
  await screenshot(page, "task-editor.png", { fullPage: true });

  step("scenario ranges: a preview of 5 draws within the range (not saved)");
  await page.getByRole("button", { name: "Add range" }).click();
  await page.getByTestId("check-state").filter({ hasText: "valid" }).waitFor({ timeout: 15_000 });
  await page.getByRole("button", { name: "Preview scenarios" }).click();
  const scenarioRows = page.getByTestId("scenario-preview").locator("tbody tr");
  await waitFor(async () => (await scenarioRows.count()) === 5, "5 previewed scenarios");
  for (const text of await scenarioRows.allInnerTexts()) {
    const value = Number(text.trim().split(/\s+/)[1]);
    if (!(value >= 0.15 && value <= 0.3)) throw new Error(`previewed scenario outside its range: ${text}`);
  }
  await page.getByTestId("scenario-ranges").screenshot({ path: resolve(artifacts, "scenario-ranges.png") });
  checkpoint("task");

  step("create an aux-penalty oracle (leaving the task's unsaved range asks first)");
  // the question blocks the page until answered: the handler answers it while the click is still running
  let asked = null;
  page.once("dialog", (d) => {
    asked = `${d.type()}: ${d.message()}`;
    void d.accept();
  });
  await page.getByRole("link", { name: "Oracles" }).click();
  await page.getByRole("link", { name: "New oracle" }).click();
  if (!asked || !/^confirm: .*unsaved edits/.test(asked)) throw new Error(`leaving the edited task asked: ${asked}`);
  await page.getByLabel("Name", { exact: true }).fill(`e2e oracle ${stamp}`);
  await page.getByLabel("Type").selectOption("aux-penalty");
  await page.getByRole("button", { name: "Create oracle" }).click();
  await page.waitForURL(/\/oracles\/\d+$/);
  const oracleUrl = page.url();

  step("test the oracle on a sample trajectory (preview run by the worker)");
  await page.getByRole("button", { name: "Test on a sample trajectory" }).click();
  await page.locator("[data-testid=preview-panel][data-status=succeeded], [data-testid=preview-panel][data-status=failed]").waitFor({ timeout: 120_000 });
  if ((await page.getByTestId("preview-panel").getAttribute("data-status")) !== "succeeded")
    throw new Error(`oracle preview failed: ${await page.getByTestId("preview-panel").innerText()}`);
  await waitFor(async () => (await plotPoints(page, "oracle-test-plot")) > 0, "force of the oracle preview");
  await page.locator("[data-testid=oracle-test-plot] .main-svg").first().waitFor();
  await screenshot(page, "oracle-editor.png", { fullPage: true });
  checkpoint("oracle");

  step("create and start a campaign");
  await page.getByRole("link", { name: "Campaigns" }).click();
  await page.getByRole("link", { name: "New campaign" }).click();
  await page.getByLabel("Name", { exact: true }).fill(`e2e campaign ${stamp}`);
  await selectByText(page.getByLabel("Task", { exact: true }), `e2e task ${stamp}`);
  await selectByText(page.getByLabel("Oracle", { exact: true }), `e2e oracle ${stamp}`);
  // settings forms are generated from the API's schemas; labels are the field names
  await page.getByLabel("samples", { exact: true }).fill(String(args.samples ?? 300));
  await page.getByLabel("max_iterations", { exact: true }).fill(String(args.iterations ?? 40));
  await screenshot(page, "new-campaign.png");
  await page.getByRole("button", { name: "Create campaign" }).click();
  await page.waitForURL(/\/campaigns\/\d+/);
  const campaignUrl = page.url();
  // beside it, a small batch campaign through the API (the candidates tab is opened at the end):
  // ensemble-disagreement, C = 3 candidates of the scenario preset, q = 2 picks, one iteration
  const token = await page.evaluate(() => localStorage.getItem("alcove.token"));
  const api = async (method, path, body) => {
    const r = await page.request.fetch(`${baseUrl}/api/v1${path}`, { method, data: body, headers: { Authorization: `Bearer ${token}` } });
    if (!r.ok()) throw new Error(`${method} ${path}: ${r.status()} ${await r.text()}`);
    return r.json();
  };
  const scenarioPreset = (await api("GET", "/tasks/presets")).find((p) => p.key === "head-headrest-scenarios");
  const batchTask = await api("POST", "/tasks", { name: `e2e scenarios ${stamp}`, description: "", spec: scenarioPreset.spec });
  // float64 training and the paper's shared force net: the scenario (two of three candidates reach the headrest
  // and are picked) was set up with them
  const batchSurrogate = await api("POST", "/surrogate-configs", {
    name: `e2e ensemble ${stamp}`,
    spec: { max_epochs: 40, ensemble_size: 2, dtype: "float64", normal_force: "shared" },
  });
  const batchCampaign = await api("POST", "/campaigns", {
    name: `e2e batch ${stamp}`,
    task_id: batchTask.id,
    oracle_id: Number(/\/oracles\/(\d+)/.exec(oracleUrl)[1]),
    surrogate_config_id: batchSurrogate.id,
    start: true,
    preliminary: { samples: 200 },
    settings: { validation_motions: 0, ocp_intervals: 20, replay_dt: 0.01, strategy: "ensemble-disagreement", batch: 2, candidates: 3, min_distance: 0 },
    stopping: { max_iterations: 1 },
  });
  checkpoint("campaign");

  step("watch the RMSE plot gain points from >= 2 iterations");
  await waitFor(
    async () => {
      const text = (await page.getByTestId("rmse-count").textContent()) ?? "";
      return Number.parseInt(text, 10) >= 2 ? text : null;
    },
    "metrics of 2 iterations",
    campaignTimeout,
    1000,
  );
  // Plotly drew them: the RMSE plot's SVG has markers
  await page.locator("[data-testid=rmse-plot] .main-svg").first().waitFor();
  const rmsePoints = await plotPoints(page, "rmse-plot");
  if (rmsePoints < 4) throw new Error(`RMSE plot has ${rmsePoints} points, expected >= 4 (force + moment of 2 iterations)`);
  // the log axis' labels are whole values at 1-2-3-5-7 per decade (no bare minor digits)
  const yLabels = await page.locator("[data-testid=rmse-plot] .ytick text").allTextContents();
  const clean = /^([12357](\.0*)?|0\.0*[12357]|[12357]0*|([12357]×)?10[⁻⁰¹²³⁴⁵⁶⁷⁸⁹]+)$/;
  if (!yLabels.length || !yLabels.every((l) => clean.test(l.trim()))) throw new Error(`RMSE log axis labels: ${JSON.stringify(yLabels)}`);
  step(`  RMSE log axis labels: ${yLabels.join(" ")}`);

  step("the held-out validation suite: replayed by the oracle worker, each model version evaluated, dashed beside the RMSE");
  await waitFor(
    async () => {
      const ks = ((await page.getByTestId("rmse-plot").getAttribute("data-validation")) ?? "").split(",").filter(Boolean);
      return ks.length >= 1 ? ks : null;
    },
    "the generalisation error of a model version on the plot (live, no reload)",
    campaignTimeout,
    1000,
  );
  const suiteText = (await page.getByTestId("validation-suite").innerText()).trim();
  const suiteMatch = /held-out suite: complete, (\d+)\/(\d+) motions/.exec(suiteText);
  if (!suiteMatch || suiteMatch[1] !== suiteMatch[2]) throw new Error(`validation suite line: ${suiteText}`);
  step(`  ${suiteText}`);

  step("polling transfers only new iterations");
  const campaignId = /\/campaigns\/(\d+)/.exec(campaignUrl)[1];
  const polls = (await Promise.all(metricPolls)).filter((p) => p && p.campaign === campaignId);
  if (polls.length < 2) throw new Error(`expected several metrics polls, saw ${polls.length}`);
  const seen = new Set();
  for (const [i, p] of polls.entries()) {
    if (i > 0 && seen.size && p.after === null) throw new Error(`metrics poll ${i} asked for the whole series again`);
    const stale = p.iterations.filter((k) => (p.after !== null && k <= p.after) || seen.has(k));
    if (stale.length) throw new Error(`metrics poll ${i} (after=${p.after}) transferred known iterations ${stale}`);
    p.iterations.forEach((k) => seen.add(k));
  }
  const empty = polls.filter((p) => !p.iterations.length).length;
  step(`  ${polls.length} metrics polls, ${seen.size} iterations transferred once each, ${empty} polls empty`);

  step("pause and resume");
  await page.getByRole("button", { name: "Pause" }).click();
  await page.locator(".badge").filter({ hasText: /^(pausing|paused)$/ }).first().waitFor({ timeout: 20_000 });
  await page.locator(".badge").filter({ hasText: /^paused$/ }).first().waitFor({ timeout: 120_000 });
  await page.getByRole("button", { name: "Resume" }).click();
  await page.locator(".badge").filter({ hasText: /^(queued|running|completed)$/ }).first().waitFor({ timeout: 20_000 });

  step("open an iteration's force plot");
  await openTab(page, "Forces & moments");
  const slider = page.getByLabel("Iteration", { exact: true });
  await slider.focus();
  await page.keyboard.press("Home");
  await page.getByTestId("iteration-value").filter({ hasText: "k = 1" }).waitFor();
  await waitFor(async () => (await plotPoints(page, "force-plot")) > 0, "force curves of iteration 1");
  await page.locator("[data-testid=force-plot] .main-svg").first().waitFor();
  const forceTraces = Number(await page.getByTestId("force-plot").getAttribute("data-traces"));
  if (forceTraces < 2) throw new Error(`force plot has ${forceTraces} traces, expected oracle and surrogate`);

  step("the ensemble's mean +- 2 std band against the oracle; the motion played back with the force plot's cursor");
  await page.locator("[data-testid=force-plot][data-band='2std'][data-rendered=true]").waitFor({ timeout: 10_000 });
  const band = await page.evaluate(() => {
    const el = /** @type {any} */ (document.querySelector("[data-testid=force-plot]"));
    const upper = el.data.find((tr) => tr.fill === "tonexty");
    const lower = el.data[el.data.indexOf(upper) - 1];
    const mean = el.data.find((tr) => /surrogate \(ensemble mean\)/.test(tr.name));
    const width = upper.y.map((v, i) => v - lower.y[i]);
    const centred = upper.y.every((v, i) => Math.abs((v + lower.y[i]) / 2 - mean.y[i]) <= 1e-9 * (1 + Math.abs(mean.y[i])));
    return { fills: el.querySelectorAll(".fills path, path.js-fill").length, maxWidth: Math.max(...width), minWidth: Math.min(...width), centred, name: upper.name };
  });
  if (!band.centred || !(band.maxWidth > 0) || band.minWidth < 0 || !band.fills) throw new Error(`force band: ${JSON.stringify(band)}`);
  step(`  ${band.name}: width up to ${band.maxWidth.toFixed(2)} N, centred on the mean, ${band.fills} filled area(s) drawn`);
  const calibration = (await page.getByTestId("calibration-plot").getAttribute("data-iterations")) ?? "";
  if (!calibration.split(",").filter(Boolean).length) throw new Error("no iteration on the calibration plot");
  step(`  calibration plotted for iterations ${calibration}; header: ${(await page.getByTestId("latest-calibration").innerText()).trim()}`);
  const player = page.getByTestId("iteration-player");
  await player.waitFor({ timeout: 15_000 });
  const curveT = await page.evaluate(() => /** @type {any} */ (document.querySelector("[data-testid=force-plot]")).data.find((tr) => / oracle$/.test(tr.name)).x);
  const mid = Math.floor(curveT.length * 0.6);
  await setRange(player.getByLabel("Time"), String(mid));
  await waitFor(async () => (await page.getByTestId("force-plot").getAttribute("data-cursor")) === String(curveT[mid]) && (await page.getByTestId("moment-plot").getAttribute("data-cursor")) === String(curveT[mid]), "the cursor on the force and moment plots", 5000, 100);
  if ((await page.getByTestId("iteration-player-time-value").innerText()).trim() !== `t = ${curveT[mid].toFixed(3)} s`) throw new Error("the player's time and the slider disagree");

  step("trajectory: the whole OCP solution, every phase shaded, the replayed part marked");
  await openTab(page, "Trajectory");
  await waitFor(async () => (await plotPoints(page, "angle-plot")) > 0, "joint angle curve");
  await waitFor(async () => (await plotPoints(page, "torque-plot")) > 0, "joint torque curve of iteration 1");
  const phasesShown = Number(await page.getByTestId("trajectory-panel").getAttribute("data-phases"));
  if (phasesShown !== nPhases) throw new Error(`trajectory shows ${phasesShown} phases, the task has ${nPhases}`);
  await page.locator("[data-testid=torque-plot] .main-svg").first().waitFor();
  for (const plot of ["angle-plot", "torque-plot"]) {
    await page.locator(`[data-testid=${plot}][data-rendered=true]`).waitFor();
    // Plotly drew a shaded rectangle per phase (below the traces) and the labelled "replayed" bracket
    const drawn = await page.evaluate((id) => {
      const el = /** @type {HTMLElement & {data: {x: ArrayLike<number>}[]}} */ (document.querySelector(`[data-testid=${id}]`));
      const rects = el.querySelectorAll(".layer-below .shapelayer path").length;
      const texts = [...el.querySelectorAll(".annotation-text, .shapelayer text")].map((t) => t.textContent);
      const xs = el.data.flatMap((tr) => Array.from(tr.x));
      return { rects, texts, tMax: Math.max(...xs) };
    }, plot);
    if (drawn.rects < nPhases) throw new Error(`${plot}: ${drawn.rects} shaded phases drawn, expected ${nPhases}`);
    step(`  ${plot}: ${drawn.rects} shaded phases, labels ${JSON.stringify(drawn.texts)}, t up to ${drawn.tMax.toFixed(3)} s`);
    if (!drawn.texts.includes("replayed by the oracle")) throw new Error(`${plot}: no "replayed by the oracle" mark (${JSON.stringify(drawn.texts)})`);
    // both phases: the curve goes past the first phase (0.2 s, set above) to the end of the task
    if (!(drawn.tMax > 0.2 + 1e-6)) throw new Error(`${plot}: the curve ends at t = ${drawn.tMax} s, inside the first phase`);
  }
  // the whole solution played back: the slider moves the cursor on the angle and torque plots
  const trajectoryT = await page.evaluate(() => /** @type {any} */ (document.querySelector("[data-testid=angle-plot]")).data[0].x);
  await page.getByTestId("trajectory-player").waitFor({ timeout: 15_000 });
  const late = trajectoryT.length - 1;
  await setRange(page.getByTestId("trajectory-player").getByLabel("Time"), String(late));
  await waitFor(async () => (await page.getByTestId("angle-plot").getAttribute("data-cursor")) === String(trajectoryT[late]) && (await page.getByTestId("torque-plot").getAttribute("data-cursor")) === String(trajectoryT[late]), "the cursor at the end of the whole solution", 5000, 100);
  const solver = await page.getByTestId("solver-summary").innerText();
  if (!/Solve_Succeeded|Solved_To_Acceptable_Level/.test(solver)) throw new Error(`solver summary: ${solver}`);
  await screenshot(page, "campaign-trajectory.png", { fullPage: true });

  step("download a model");
  await openTab(page, "Pool & models");
  await page.getByTestId("model-table").waitFor({ timeout: 30_000 });
  // the zip is built by the worker first (202, the button follows the build): it may wait for a free worker process
  const [download] = await Promise.all([page.waitForEvent("download", { timeout: 120_000 }), page.getByTestId("model-table").getByRole("button", { name: "Artifact" }).first().click()]);
  const modelPath = resolve(artifacts, download.suggestedFilename());
  await download.saveAs(modelPath);
  const size = statSync(modelPath).size;
  if (size < 100) throw new Error(`downloaded model is ${size} bytes`);

  step("a batch campaign's candidates tab: every candidate ranked with why, the picks' forces in the ensemble's band");
  await page.goto(`${baseUrl}/campaigns/${batchCampaign.id}?tab=candidates&k=1`);
  const candidateRows = page.getByTestId("candidates-table").locator("tbody tr");
  await waitFor(async () => (await page.locator("[data-testid=candidates-table] tbody tr[data-picked=true]").count()) === 2, "2 picks of 3 candidates", campaignTimeout);
  const whys = await candidateRows.evaluateAll((rows) => rows.map((r) => r.dataset.why));
  if (whys.length !== 3 || whys[0] !== "picked-top" || whys[1] !== "picked-far") throw new Error(`candidates' why: ${whys}`);
  await page.locator("[data-testid=pick-forces][data-band=true][data-rendered=true]").nth(1).waitFor({ timeout: 30_000 });
  step(`  candidates by rank: ${whys.join(", ")}`);
  await page.screenshot({ path: resolve(artifacts, "campaign-candidates.png"), fullPage: true, animations: "disabled" });
  // click, then wait for what the click causes (the plot's axis), then the radio shows the choice
  const oracleCalls = page.getByTestId("x-axis").getByLabel("oracle calls");
  await oracleCalls.click();
  await page.locator("[data-testid=rmse-plot][data-xaxis=oracle]").waitFor();
  if (!(await oracleCalls.isChecked())) throw new Error("the plot shows oracle calls, the x-axis radio does not");
  // one component's RMSE: the friction force fz, in the loop, in contact and on the held-out suite
  await page.getByTestId("rmse-quantity").selectOption("fz");
  await page.locator("[data-testid=rmse-plot][data-quantity=fz]").waitFor();
  await waitFor(async () => Number(await page.getByTestId("rmse-plot").getAttribute("data-traces")) >= 2, "the fz RMSE traces");
  if ((await page.getByTestId("rmse-quantity").inputValue()) !== "fz") throw new Error("the plot shows fz, the select does not");
  if (!new URL(page.url()).searchParams.get("rmse")) throw new Error(`the component is not in the URL: ${page.url()}`);

  step("screenshots of the campaign page and the campaigns list");
  await page.goto(campaignUrl.split("?")[0] + "?tab=forces");
  await page.locator("[data-testid=rmse-plot] .main-svg").first().waitFor();
  await page.locator("[data-testid=force-plot] .main-svg").first().waitFor();
  await screenshot(page, "campaign-page.png", { fullPage: true });
  await page.getByRole("link", { name: "Campaigns" }).click();
  await page.getByTestId("campaigns-table").waitFor();
  await screenshot(page, "campaigns-list.png");

  // The browser logs every non-2xx answer; 503 "database busy, retry" (SQLite contention with
  // the worker) is retried by the UI, so it is reported but not a failure.
  const busy = consoleErrors.filter((e) => /status of 503/.test(e));
  if (busy.length) step(`note: ${busy.length} request(s) answered 503 and were retried`);
  const relevant = consoleErrors.filter((e) => !/favicon|status of 401|status of 503/.test(e));
  if (relevant.length) throw new Error(`console errors: ${relevant.join(" | ")}`);
  step("all steps passed");
} catch (err) {
  if (err instanceof StopEarly) {
    step(`stopped after ${err.message} (--stop-after)`);
    await close();
    process.exit(0);
  }
  await page.screenshot({ path: resolve(artifacts, "e2e-failure.png"), fullPage: true }).catch(() => {});
  console.error(`[e2e] FAILED at ${page.url()}: ${err?.stack ?? err}`);
  process.exitCode = 1;
} finally {
  await close();
}
