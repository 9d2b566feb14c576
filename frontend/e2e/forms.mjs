#!/usr/bin/env node
/**
 * Number fields keep exactly what the user types, in a real browser against a running
 * `alcove up`: into a field of each form and table kind (the task's model form, its phases
 * table, its chain tables of links and joints, the oracle's parameter form, the new-campaign
 * form and the fork dialog) the values 0.0005, 0.3001, 0.0025, 1e-4, 1e308 and -0.005 are typed
 * key by key. After every key the field shows exactly the keys typed so far; then either the
 * form names the value's problem at that field (out of the field's range), or it is saved and
 * the server stores exactly that number (read back through the API). Text that is no number
 * is named at its field too. The new-campaign form is checked while typing: a blank name, text
 * in a number field, a value below its bound, a strategy the chosen surrogate's ensemble cannot
 * run and no stopping rule at all are named together before anything is created (the last two
 * by the API's POST /campaigns/check), each once at its field or section; each fix takes its
 * problem away, and the fixed form creates the campaign.
 *
 *   node e2e/forms.mjs --base-url http://127.0.0.1:8765 --email admin@alcove.local --password secret --artifacts ../test-artifacts
 */
import { mkdirSync } from "node:fs";
import { resolve } from "node:path";
import { apiClient, openBrowser, parseArgs, signInByToken, waitFor } from "./browser.mjs";

const args = parseArgs(process.argv.slice(2));
const baseUrl = String(args["base-url"] ?? "http://127.0.0.1:8000").replace(/\/$/, "");
const email = String(args.email ?? "admin@alcove.local");
const password = String(args.password ?? "alcove-admin");
const artifacts = resolve(String(args.artifacts ?? "test-artifacts"));
mkdirSync(artifacts, { recursive: true });
const t0 = Date.now();
const step = (name) => console.log(`[forms ${((Date.now() - t0) / 1000).toFixed(1)} s] ${name}`);
const TYPED = ["0.0005", "0.3001", "0.0025", "1e-4", "1e308", "-0.005"];

const { context, close } = await openBrowser();
const page = context.pages()[0] ?? (await context.newPage());
const pageErrors = [];
page.on("pageerror", (e) => pageErrors.push(String(e)));

let token;
const api = apiClient(page, baseUrl, () => token);

/** Empty the field, then type `text` one key at a time: after each key the field holds exactly the keys typed so far. */
async function typeKeyByKey(field, text, where) {
  await field.click();
  await field.press("ControlOrMeta+a");
  await field.press("Backspace");
  if ((await field.inputValue()) !== "") throw new Error(`${where}: the field is not empty after clearing it: "${await field.inputValue()}"`);
  for (let i = 0; i < text.length; i++) {
    await page.keyboard.type(text[i]);
    const shown = await field.inputValue();
    if (shown !== text.slice(0, i + 1)) throw new Error(`${where}: typing "${text}" key by key, the field shows "${shown}" after "${text.slice(0, i + 1)}"`);
  }
}

/** The form's answer to the typed value: the problem named at the field, or none (the form may save it). */
async function fieldVerdict(field, container, { inline }) {
  if (inline) await page.locator("[data-testid=check-state]:not(:has-text('checking'))").waitFor();
  if ((await field.getAttribute("aria-invalid")) === "true") {
    const message = (await container.locator(".field-error").allTextContents()).join(" | ");
    if (!message) throw new Error("a field marked invalid shows no message");
    return { refused: message };
  }
  return { refused: null };
}

/** The field's container (its cell or its labelled block), where its messages are shown. */
const cellOf = (field) => field.locator("xpath=ancestor::*[self::td or contains(concat(' ', @class, ' '), ' field ')][1]");

const results = [];
const failures = [];
/** One typed value's check; a failure is recorded and the run goes on to the next value and form. */
async function check(form, value, fn) {
  try {
    await fn();
  } catch (err) {
    failures.push(`${form} ${value}: ${err.message.split("\n")[0]}`);
    step(`  ${value}: FAILED: ${err.message.split("\n")[0]}`);
  }
}
function record(form, value, verdict, stored) {
  const line = verdict.refused ? `${value}: refused at the field (${verdict.refused})` : `${value}: stored ${stored}`;
  results.push(`${form} ${line}`);
  step(`  ${line}`);
}

try {
  step("sign in; a source campaign for the fork dialog (one iteration, through the API)");
  token = await signInByToken(page, baseUrl, email, password);
  const stamp = Date.now().toString(36);
  const preset = (await api("GET", "/tasks/presets"))[0];
  const spec = structuredClone(preset.spec);
  for (const ph of spec.phases) ph.intervals = 10;
  const task = await api("POST", "/tasks", { name: `forms task ${stamp}`, description: "", spec });
  const oracle = await api("POST", "/oracles", { name: `forms oracle ${stamp}`, description: "", type: "aux-penalty", params: {} });
  const surrogate = await api("POST", "/surrogate-configs", { name: `forms surrogate ${stamp}`, spec: { max_epochs: 60, ensemble_size: 2 } });
  // the task and oracle the editors change: a campaign's would be kept as they are (saving makes a new version)
  const editedTask = await api("POST", "/tasks", { name: `forms edited task ${stamp}`, description: "", spec });
  const editedOracle = await api("POST", "/oracles", { name: `forms edited oracle ${stamp}`, description: "", type: "aux-penalty", params: {} });
  const source = await api("POST", "/campaigns", {
    name: `forms source ${stamp}`,
    task_id: task.id,
    oracle_id: oracle.id,
    surrogate_config_id: surrogate.id,
    start: true,
    preliminary: { samples: 300 },
    settings: { validation_motions: 0 },
    stopping: { max_iterations: 1 },
  });

  // ---------------------------------------------------------------- task editor
  const storedTask = async () => (await api("GET", `/tasks/${editedTask.id}`)).spec;
  const taskFields = [
    { form: "task model form (headrest_offset)", label: /^headrest_offset/, read: (s) => s.model.headrest_offset, chain: false },
    { form: "phases table (phase 1 w_T)", label: "phase 1 w_T", read: (s) => s.phases[0].w_T, chain: false },
    { form: "chain links table (link 1 mass)", label: "link 1 mass [kg]", read: (s) => s.model.chain.links[0].mass, chain: true },
    { form: "chain joints table (joint 1 q0)", label: "joint 1 q0 (start) [rad]", read: (s) => s.model.chain.joints[0].q0, chain: true },
  ];
  await page.goto(`${baseUrl}/tasks/${editedTask.id}`);
  await page.getByLabel("phase 1 w_T").waitFor();
  for (const f of taskFields) {
    if (f.chain && !(await page.getByTestId("chain-links").count())) {
      step("the task's model becomes the 2-DOF chain preset (saved), for the chain tables");
      await page.getByLabel("preset", { exact: true }).selectOption("head-neck-2dof");
      await page.getByTestId("chain-links").waitFor();
      await page.locator("[data-testid=check-state][data-count='0']:not(:has-text('checking'))").waitFor();
      await page.getByRole("button", { name: "Save", exact: true }).click();
      await waitFor(async () => (await storedTask()).model.preset === "head-neck-2dof", "the chain model to be saved");
    }
    step(`${f.form}: ${TYPED.join(", ")} typed key by key`);
    const field = page.getByLabel(f.label).first();
    const original = await field.inputValue();
    for (const value of TYPED) await check(f.form, value, async () => {
      await typeKeyByKey(field, value, f.form);
      const verdict = await fieldVerdict(field, cellOf(field), { inline: true });
      let stored = null;
      if (!verdict.refused) {
        const count = Number(await page.getByTestId("check-state").getAttribute("data-count"));
        if (count) throw new Error(`${f.form} ${value}: the field is valid but the form has ${count} problems: ${(await page.locator("[data-error-path]").allTextContents()).join(" | ")}`);
        await page.getByRole("button", { name: "Save", exact: true }).click();
        stored = await waitFor(async () => (f.read(await storedTask()) === Number(value) ? String(f.read(await storedTask())) : null), `${f.form}: the server to store ${value}`, 15_000).catch(async (err) => {
          throw new Error(`${err.message}; stored: ${f.read(await storedTask())}`);
        });
        if ((await field.inputValue()) !== value) throw new Error(`${f.form}: after saving ${value} the field shows "${await field.inputValue()}"`);
      }
      record(f.form, value, verdict, stored);
    });
    await field.fill(original);
    await page.locator("[data-testid=check-state][data-count='0']:not(:has-text('checking'))").waitFor();
  }
  step("text that is no number is named at its field (phases table), and kept");
  for (const text of ["abc", "1e", "--5"]) await check("phases table (phase 1 w_T)", text, async () => {
    const field = page.getByLabel("phase 1 w_T");
    await typeKeyByKey(field, text, "phase 1 w_T");
    const verdict = await fieldVerdict(field, cellOf(field), { inline: true });
    if (!verdict.refused?.includes("must be a number")) throw new Error(`"${text}" in phase 1 w_T: the field says ${verdict.refused}`);
  });
  await page.getByLabel("phase 1 w_T").fill("0");

  // ---------------------------------------------------------------- oracle editor
  step(`oracle parameter form (p_ref): ${TYPED.join(", ")} typed key by key`);
  await page.goto(`${baseUrl}/oracles/${editedOracle.id}`);
  const pRef = page.getByLabel(/^p_ref/);
  await pRef.waitFor();
  for (const value of TYPED) await check("oracle form (p_ref)", value, async () => {
    await typeKeyByKey(pRef, value, "oracle p_ref");
    const verdict = await fieldVerdict(pRef, cellOf(pRef), { inline: true });
    let stored = null;
    if (!verdict.refused) {
      await page.getByRole("button", { name: "Save", exact: true }).click();
      stored = await waitFor(async () => {
        const v = (await api("GET", `/oracles/${editedOracle.id}`)).params.p_ref;
        return v === Number(value) ? String(v) : null;
      }, `the server to store p_ref = ${value}`, 15_000);
      if ((await pRef.inputValue()) !== value) throw new Error(`oracle p_ref: after saving ${value} the field shows "${await pRef.inputValue()}"`);
    }
    record("oracle form (p_ref)", value, verdict, stored);
  });

  // ---------------------------------------------------------------- new campaign
  step(`new-campaign form (run settings: replay_dt): ${TYPED.join(", ")} typed key by key`);
  const newCampaignReplayDt = async () => {
    await page.goto(`${baseUrl}/campaigns/new`);
    const field = page.getByRole("region", { name: "Run settings" }).getByLabel(/^replay_dt/);
    await field.waitFor();
    return field;
  };
  for (const value of TYPED) await check("new-campaign form (replay_dt)", value, async () => {
    const field = await newCampaignReplayDt();
    await page.getByLabel("Name", { exact: true }).fill(`forms new ${value} ${stamp}`);
    await page.getByLabel("Task", { exact: true }).selectOption(String(task.id));
    await page.getByLabel("Oracle", { exact: true }).selectOption(String(oracle.id));
    await page.getByLabel("Start right away").uncheck();
    await typeKeyByKey(field, value, "new campaign replay_dt");
    const verdict = await fieldVerdict(field, cellOf(field), { inline: false });
    let stored = null;
    if (!verdict.refused) {
      await page.getByRole("button", { name: "Create campaign" }).click();
      await page.waitForURL((u) => /\/campaigns\/\d+$/.test(u.pathname));
      const id = Number(/\/campaigns\/(\d+)/.exec(page.url())[1]);
      stored = (await api("GET", `/campaigns/${id}`)).config.settings.replay_dt;
      if (stored !== Number(value)) throw new Error(`new campaign: replay_dt typed ${value}, the server stores ${stored}`);
    } else if (await page.getByTestId("form-errors").count()) {
      throw new Error(`new campaign ${value}: a problem is listed above the form: ${await page.getByTestId("form-errors").innerText()}`);
    }
    record("new-campaign form (replay_dt)", value, verdict, stored);
  });
  step("text that is no number is named at the new-campaign form's field, not above the form");
  for (const text of ["abc", "1e", "--5"]) await check("new-campaign form (replay_dt)", text, async () => {
    const field = await newCampaignReplayDt();
    await typeKeyByKey(field, text, "new campaign replay_dt");
    const verdict = await fieldVerdict(field, cellOf(field), { inline: false });
    if (!verdict.refused?.includes("must be a number")) throw new Error(`"${text}" in replay_dt: ${verdict.refused}`);
    await page.getByLabel("Name", { exact: true }).fill(`forms bad ${stamp}`);
    await page.getByRole("button", { name: "Create campaign" }).click();
    if (await page.getByTestId("form-errors").count()) throw new Error(`"${text}": a problem is listed above the form: ${await page.getByTestId("form-errors").innerText()}`);
    if (!/\/campaigns\/new$/.test(new URL(page.url()).pathname)) throw new Error(`"${text}" in replay_dt was sent: ${page.url()}`);
  });

  // ---------------------------------------------------------------- new campaign: checked while typing
  step("new-campaign form: problems of every kind named while typing (no create), all at once, each at its field");
  const single = await api("POST", "/surrogate-configs", { name: `forms single ${stamp}`, spec: { ensemble_size: 1, max_epochs: 60 } });
  const campaignPosts = { check: 0, create: 0 };
  const countPosts = (r) => {
    const path = new URL(r.url()).pathname;
    if (r.method() === "POST" && path === "/api/v1/campaigns/check") campaignPosts.check += 1;
    if (r.method() === "POST" && path === "/api/v1/campaigns") campaignPosts.create += 1;
  };
  page.on("request", countPosts);
  try {
    await page.goto(`${baseUrl}/campaigns/new`);
    const region = (name) => page.getByRole("region", { name });
    const badge = page.getByTestId("check-state");
    const settled = async () => {
      await page.locator("[data-testid=check-state]:not(:has-text('checking'))").waitFor();
      return Number(await badge.getAttribute("data-count"));
    };
    const fields = {
      name: page.getByLabel("Name", { exact: true }),
      strategy: page.getByTestId("exploration").getByLabel("Strategy"),
      replayDt: region("Run settings").getByLabel(/^replay_dt/),
      samples: region(/^Preliminary data/).getByLabel(/^samples/),
      maxIterations: region("Stopping rules").getByLabel(/^max_iterations/),
    };
    await fields.replayDt.waitFor();
    if ((await settled()) < 1 || (await fields.name.getAttribute("aria-invalid")) !== "true") throw new Error(`a blank new campaign is shown as ${await badge.innerText()}`);
    await page.getByLabel("Task", { exact: true }).selectOption(String(task.id));
    await page.getByLabel("Oracle", { exact: true }).selectOption(String(oracle.id));
    await page.getByLabel("Surrogate configuration", { exact: true }).selectOption(String(single.id));
    await page.getByLabel("Start right away").uncheck();
    await fields.strategy.selectOption("ensemble-disagreement");
    await typeKeyByKey(fields.maxIterations, "", "max_iterations");
    await typeKeyByKey(fields.replayDt, "abc", "replay_dt");
    await typeKeyByKey(fields.samples, "1", "samples");
    // the form's own checks (name, replay_dt, samples) and the API's (the strategy against the surrogate's ensemble, no stopping rule), at once
    const expected = [
      { path: "name", at: fields.name, words: "must not be empty" },
      { path: "settings.replay_dt", at: fields.replayDt, words: "must be a number" },
      { path: "preliminary.samples", at: fields.samples, words: "must be at least 2" },
      { path: "settings.strategy", at: fields.strategy, words: "needs a surrogate ensemble of at least 2 members" },
      { path: "stopping", at: region("Stopping rules"), words: "at least one stopping rule is needed" },
    ];
    const count = await settled();
    const shown = await page.locator("[data-error-path]").evaluateAll((els) => els.map((e) => [e.getAttribute("data-error-path"), e.textContent, e.getAttribute("title")]));
    const where = shown.map(([path, text]) => `${path}: ${text}`).join(" | ");
    if (count !== expected.length || shown.length !== expected.length) throw new Error(`${count} problems counted, ${shown.length} shown (${where}); expected ${expected.length}`);
    for (const { path, at, words } of expected) {
      const container = path === "stopping" ? at : cellOf(at);
      const message = container.locator(`[data-error-path="${path}"]`);
      if ((await message.count()) !== 1) throw new Error(`the problem at ${path} is not shown at its field: ${where}`);
      if (!(await message.innerText()).includes(words)) throw new Error(`${path} says "${await message.innerText()}", not "${words}"`);
      if (path !== "stopping" && (await at.getAttribute("aria-invalid")) !== "true") throw new Error(`${path} is not marked invalid`);
    }
    const broken = shown.filter(([, , title]) => /› :|^: /.test(title ?? ""));
    if (broken.length) throw new Error(`broken labels: ${broken.map(([, , t]) => t).join(" | ")}`);
    if (await page.getByTestId("form-errors").count()) throw new Error(`problems listed above the form: ${await page.getByTestId("form-errors").innerText()}`);
    if (!campaignPosts.check || campaignPosts.create) throw new Error(`while typing: ${campaignPosts.check} check requests, ${campaignPosts.create} creates`);
    step(`  ${count} problems while typing, each at its field: ${where}`);
    // each fix takes exactly its problem away
    const fixes = [
      { path: "name", fix: () => fields.name.fill(`forms live ${stamp}`) },
      { path: "settings.replay_dt", fix: () => typeKeyByKey(fields.replayDt, "0.0025", "replay_dt") },
      { path: "preliminary.samples", fix: () => typeKeyByKey(fields.samples, "300", "samples") },
      { path: "stopping", fix: () => typeKeyByKey(fields.maxIterations, "1", "max_iterations") },
      { path: "settings.strategy", fix: () => fields.strategy.selectOption("random-scenarios") },
    ];
    for (const [i, { path, fix }] of fixes.entries()) {
      await fix();
      const left = await settled();
      if (left !== expected.length - i - 1 || (await page.locator(`[data-error-path="${path}"]`).count())) throw new Error(`after fixing ${path}: ${left} problems: ${(await page.locator("[data-error-path]").allTextContents()).join(" | ")}`);
    }
    if ((await badge.innerText()) !== "valid") throw new Error(`the fixed form says ${await badge.innerText()}`);
    await page.getByRole("button", { name: "Create campaign" }).click();
    await page.waitForURL((u) => /\/campaigns\/\d+$/.test(u.pathname));
    const created = await api("GET", `/campaigns/${/\/campaigns\/(\d+)/.exec(page.url())[1]}`);
    if (created.config.settings.strategy !== "random-scenarios" || created.config.preliminary.samples !== 300) throw new Error(`created with ${JSON.stringify(created.config.settings.strategy)}, ${created.config.preliminary.samples} samples`);
    step(`  fixed one by one (5, 4, 3, 2, 1, valid) and created; ${campaignPosts.check} check requests, 1 create`);
  } finally {
    page.off("request", countPosts);
  }

  // ---------------------------------------------------------------- fork dialog
  step("fork dialog (stopping rules: target_force_rmse): waiting for the source campaign's iteration");
  await waitFor(async () => ["completed", "failed", "cancelled"].includes((await api("GET", `/campaigns/${source.id}`)).campaign.status), "the source campaign to end", 240_000, 1000);
  const sourceStatus = (await api("GET", `/campaigns/${source.id}`)).campaign.status;
  if (sourceStatus !== "completed") throw new Error(`the source campaign ended ${sourceStatus}`);
  step(`  ${TYPED.join(", ")} typed key by key`);
  for (const value of TYPED) await check("fork dialog (target_force_rmse)", value, async () => {
    await page.goto(`${baseUrl}/campaigns/${source.id}`);
    const forkButton = page.getByRole("button", { name: "Fork…" });
    await waitFor(() => forkButton.isEnabled(), "the Fork… button (the source's iterations loaded)");
    await forkButton.click();
    const dialog = page.getByRole("dialog");
    const field = dialog.getByLabel(/^target_force_rmse/);
    await field.waitFor();
    await dialog.getByLabel("Start right away").uncheck();
    await typeKeyByKey(field, value, "fork target_force_rmse");
    const verdict = await fieldVerdict(field, cellOf(field), { inline: false });
    let stored = null;
    if (!verdict.refused) {
      await dialog.getByRole("button", { name: "Fork", exact: true }).click();
      await page.waitForURL((u) => /\/campaigns\/\d+$/.test(u.pathname) && !u.pathname.endsWith(`/${source.id}`));
      const id = Number(/\/campaigns\/(\d+)/.exec(page.url())[1]);
      stored = (await api("GET", `/campaigns/${id}`)).config.stopping.target_force_rmse;
      if (stored !== Number(value)) throw new Error(`fork: target_force_rmse typed ${value}, the server stores ${stored}`);
    }
    record("fork dialog (target_force_rmse)", value, verdict, stored);
  });

  if (failures.length) throw new Error(`${failures.length} typed values failed:\n  ${failures.join("\n  ")}`);
  const saved = results.filter((r) => r.includes("stored")).length;
  if (saved < 12) throw new Error(`only ${saved} values were saved; the checks of the stored value did not run enough`);
  if (pageErrors.length) throw new Error(`page errors: ${pageErrors.join(" | ")}`);
  step(`all form checks passed: ${results.length} values typed, ${saved} stored exactly, the rest refused at their field`);
} catch (err) {
  await page.screenshot({ path: resolve(artifacts, "forms-failure.png"), fullPage: true }).catch(() => {});
  console.error(`[forms] FAILED at ${page.url()}: ${err?.stack ?? err}`);
  process.exitCode = 1;
} finally {
  await close();
}
