#!/usr/bin/env node
/**
 * Accessibility and small screens, in a real browser against a running `alcove up`:
 *
 *  - axe-core (the dev dependency, injected into the page) finds no violation on the campaigns
 *    list, a finished campaign's page (its plots drawn), the task editor (new and saved), the
 *    oracle editor and the new-campaign form;
 *  - every page has a title of its own;
 *  - at phone width (390 px) the campaigns list and a campaign's page (status, plots, tables)
 *    fit the screen: nothing scrolls sideways, the navigation is reachable.
 *
 *   node e2e/a11y.mjs --base-url http://127.0.0.1:8765 --email admin@alcove.local --password secret --artifacts ../test-artifacts
 */
import { mkdirSync, readFileSync } from "node:fs";
import { createRequire } from "node:module";
import { resolve } from "node:path";
import { apiClient, openBrowser, openTab, parseArgs, signInByToken, waitFor } from "./browser.mjs";

const require = createRequire(import.meta.url);
const AXE_SOURCE = readFileSync(require.resolve("axe-core/axe.min.js"), "utf8");
const args = parseArgs(process.argv.slice(2));
const baseUrl = String(args["base-url"] ?? "http://127.0.0.1:8000").replace(/\/$/, "");
const email = String(args.email ?? "admin@alcove.local");
const password = String(args.password ?? "alcove-admin");
const artifacts = resolve(String(args.artifacts ?? "test-artifacts"));
mkdirSync(artifacts, { recursive: true });
const t0 = Date.now();
const step = (name) => console.log(`[a11y ${((Date.now() - t0) / 1000).toFixed(1)} s] ${name}`);

const { context, close } = await openBrowser();
const page = context.pages()[0] ?? (await context.newPage());
const pageErrors = [];
page.on("pageerror", (e) => pageErrors.push(String(e)));

let token;
const api = apiClient(page, baseUrl, () => token);

/** axe-core's violations of the page as it is now, one line each (rule, impact, the first nodes). */
async function violations() {
  // evaluated through the DevTools protocol: the page's Content-Security-Policy (script-src 'self') stays as it is
  if (!(await page.evaluate(() => "axe" in window))) await page.evaluate(AXE_SOURCE);
  const result = await page.evaluate(async () => {
    // @ts-expect-error axe is injected above
    const r = await window.axe.run(document, { resultTypes: ["violations"] });
    return r.violations.map((v) => ({ id: v.id, impact: v.impact, help: v.help, nodes: v.nodes.map((n) => `${n.target.join(" ")}: ${n.failureSummary?.split("\n").slice(1, 2).join(" ").trim()}`) }));
  });
  return result.map((v) => `${v.id} (${v.impact}): ${v.help} — ${v.nodes.length} node(s): ${v.nodes.slice(0, 3).join(" | ")}`);
}

const titles = new Map();
const problems = [];
async function check(name, url, ready) {
  await page.goto(url);
  await ready();
  const found = await violations();
  const title = await page.title();
  titles.set(name, title);
  step(`  ${name}: ${found.length} violation(s), title "${title}"`);
  for (const v of found) {
    step(`    ${v}`);
    problems.push(`${name}: ${v}`);
  }
}

try {
  step("sign in; a finished campaign of two iterations (through the API)");
  token = await signInByToken(page, baseUrl, email, password);
  const stamp = Date.now().toString(36);
  const preset = (await api("GET", "/tasks/presets"))[0];
  const spec = structuredClone(preset.spec);
  for (const ph of spec.phases) ph.intervals = 10;
  const task = await api("POST", "/tasks", { name: `a11y task ${stamp}`, description: "", spec });
  const oracle = await api("POST", "/oracles", { name: `a11y oracle ${stamp}`, description: "", type: "aux-penalty", params: {} });
  const surrogate = await api("POST", "/surrogate-configs", { name: `a11y surrogate ${stamp}`, spec: { max_epochs: 60, ensemble_size: 2 } });
  const campaign = await api("POST", "/campaigns", {
    name: `a11y campaign ${stamp}`,
    task_id: task.id,
    oracle_id: oracle.id,
    surrogate_config_id: surrogate.id,
    start: true,
    preliminary: { samples: 300 },
    settings: { validation_motions: 0 },
    stopping: { max_iterations: 2 },
  });
  await waitFor(async () => ["completed", "failed", "cancelled"].includes((await api("GET", `/campaigns/${campaign.id}`)).campaign.status), "the campaign to end", 300_000, 1000);
  const status = (await api("GET", `/campaigns/${campaign.id}`)).campaign.status;
  if (status !== "completed") throw new Error(`the campaign ended ${status}`);

  step("axe-core on the main pages");
  await check("campaigns list", `${baseUrl}/campaigns`, () => page.locator(`tr[data-campaign-id="${campaign.id}"]`).waitFor());
  await check("campaign page", `${baseUrl}/campaigns/${campaign.id}`, async () => {
    await page.locator("[data-testid=rmse-plot][data-rendered=true]").waitFor();
    await page.locator("[data-testid=force-plot][data-rendered=true]").waitFor();
  });
  await check("new task", `${baseUrl}/tasks/new`, () => page.locator("[data-testid=check-state]:not(:has-text('checking'))").waitFor());
  await check("saved task", `${baseUrl}/tasks/${task.id}`, () => page.locator("[data-testid=check-state][data-count='0']:not(:has-text('checking'))").waitFor());
  await check("new oracle", `${baseUrl}/oracles/new`, () => page.locator("[data-testid=check-state]:not(:has-text('checking'))").waitFor());
  await check("saved oracle", `${baseUrl}/oracles/${oracle.id}`, () => page.locator("[data-testid=check-state][data-count='0']:not(:has-text('checking'))").waitFor());
  await check("new campaign", `${baseUrl}/campaigns/new`, () => page.getByRole("region", { name: "Run settings" }).waitFor());
  const other = await api("POST", "/campaigns", { name: `a11y draft ${stamp}`, task_id: task.id, oracle_id: oracle.id, start: false });
  await check("compare", `${baseUrl}/compare?ids=${campaign.id},${other.id}`, () => page.locator("[data-testid^=compare-][data-rendered=true]").first().waitFor());
  await check("API tokens", `${baseUrl}/tokens`, () => page.getByRole("heading", { name: "API tokens" }).waitFor());

  step("every page has a title of its own");
  const seen = new Map();
  for (const [name, title] of titles) {
    if (!title || title === "alcove") problems.push(`${name}: no title of its own ("${title}")`);
    if (seen.has(title)) problems.push(`${name} and ${seen.get(title)} share the title "${title}"`);
    seen.set(title, name);
  }

  step("phone width (390 px): reading a campaign needs no sideways scroll");
  await page.setViewportSize({ width: 390, height: 844 });
  const phonePages = [
    { name: "campaigns list", url: `${baseUrl}/campaigns`, ready: () => page.locator(`[data-campaign-id="${campaign.id}"]`).first().waitFor() },
    { name: "campaign page", url: `${baseUrl}/campaigns/${campaign.id}`, ready: () => page.locator("[data-testid=rmse-plot][data-rendered=true]").waitFor() },
  ];
  for (const { name, url, ready } of phonePages) {
    await page.goto(url);
    await ready();
    const tabs = name === "campaign page" ? ["Forces & moments", "Trajectory", "Jobs", "Pool & models"] : [null];
    for (const tab of tabs) {
      if (tab) await openTab(page, tab);
      const { scroll, view, wide } = await page.evaluate(() => ({
        scroll: document.documentElement.scrollWidth,
        view: document.documentElement.clientWidth,
        // the widest elements sticking out of the screen, to say what to fix
        wide: [...document.querySelectorAll("body *")]
          .filter((e) => e.getBoundingClientRect().right > document.documentElement.clientWidth + 1 && !e.closest("[data-scroll-x]"))
          .slice(0, 5)
          .map((e) => `${e.tagName.toLowerCase()}${e.id ? `#${e.id}` : ""}${e.className && typeof e.className === "string" ? `.${e.className.split(" ")[0]}` : ""} (${Math.round(e.getBoundingClientRect().right)} px)`),
      }));
      const where = tab ? `${name} (${tab})` : name;
      step(`  ${where}: page ${scroll} px wide in a ${view} px screen`);
      if (scroll > view) problems.push(`${where} at 390 px scrolls sideways: ${scroll} px wide; sticking out: ${wide.join(", ")}`);
    }
    const nav = page.getByRole("navigation", { name: "Main" });
    for (const link of ["Campaigns", "Compare", "Tasks", "Oracles"]) {
      const box = await nav.getByRole("link", { name: link }).boundingBox();
      if (!box || box.x < 0 || box.x + box.width > 391) problems.push(`${name} at 390 px: the navigation link ${link} is off screen (${JSON.stringify(box)})`);
    }
    await page.screenshot({ path: resolve(artifacts, `phone-${name.replace(/ /g, "-")}.png`), fullPage: true });
  }

  if (pageErrors.length) problems.push(`page errors: ${pageErrors.join(" | ")}`);
  if (problems.length) throw new Error(`${problems.length} problem(s):\n  ${problems.join("\n  ")}`);
  step("all accessibility checks passed: no axe-core violation, a title per page, phone width readable");
} catch (err) {
  await page.screenshot({ path: resolve(artifacts, "a11y-failure.png"), fullPage: true }).catch(() => {});
  console.error(`[a11y] FAILED at ${page.url()}: ${err?.stack ?? err}`);
  process.exitCode = 1;
} finally {
  await close();
}
