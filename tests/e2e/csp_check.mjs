#!/usr/bin/env node
/**
 * The Content-Security-Policy does not break the pages: in Debian's Chromium (driven by
 * playwright-core from frontend/node_modules), open the campaign list, a campaign page (its
 * plotly charts rendered, one exported as PNG through the modebar's camera) and the API docs
 * (Swagger UI rendering the operations), and collect every CSP violation the browser reports
 * (`securitypolicyviolation` events and "Refused to ..." console messages).
 *
 *   node tests/e2e/csp_check.mjs --base-url URL --email E --password P --campaign ID --name NAME
 *
 * Prints one JSON line {violations, console_errors, steps}; exit code 0 = no violation and
 * every page did what it should.
 */
import { createRequire } from "node:module";
import { mkdtempSync, rmSync, statSync } from "node:fs";
import { tmpdir } from "node:os";
import { join, resolve } from "node:path";
import { fileURLToPath } from "node:url";

const here = fileURLToPath(new URL(".", import.meta.url));
const require = createRequire(resolve(here, "../../frontend/package.json"));
const { chromium } = require("playwright-core");

const args = {};
for (let i = 2; i < process.argv.length; i += 2) args[process.argv[i].replace(/^--/, "")] = process.argv[i + 1];
const base = args["base-url"].replace(/\/$/, "");

const violations = [];
const consoleErrors = [];
const steps = [];

const profile = mkdtempSync(join(tmpdir(), "alcove-csp-"));
const context = await chromium.launchPersistentContext(profile, {
  executablePath: process.env.ALCOVE_CHROMIUM ?? "/usr/bin/chromium",
  headless: true,
  args: ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking"],
  viewport: { width: 1280, height: 900 },
  acceptDownloads: true,
});
await context.addInitScript(() => {
  document.addEventListener("securitypolicyviolation", (e) => {
    // reported to the test through the console (survives navigations)
    console.error(`CSP-VIOLATION ${e.effectiveDirective} blocked=${e.blockedURI} source=${e.sourceFile}:${e.lineNumber}`);
  });
});
const page = context.pages()[0] ?? (await context.newPage());
page.on("console", (msg) => {
  const text = msg.text();
  if (/CSP-VIOLATION|Content Security Policy|Refused to/i.test(text)) violations.push(`${page.url()}: ${text}`);
  else if (msg.type() === "error") consoleErrors.push(`${page.url()}: ${text}`);
});
page.on("pageerror", (err) => consoleErrors.push(`${page.url()}: ${err.message}`));

let failed = null;
try {
  const login = await page.request.post(`${base}/api/v1/auth/login`, {
    data: { email: args.email, password: args.password },
  });
  if (!login.ok()) throw new Error(`login failed: ${login.status()}`);
  const { access_token } = await login.json();
  await page.goto(`${base}/signin`);
  await page.evaluate((t) => localStorage.setItem("alcove.token", t), access_token);

  await page.goto(`${base}/campaigns`);
  await page.getByText(args.name).first().waitFor({ timeout: 30_000 });
  steps.push("campaign list");

  await page.goto(`${base}/campaigns/${args.campaign}`);
  const plot = page.locator('.plot[data-rendered="true"]').first();
  await plot.waitFor({ timeout: 60_000 });
  steps.push(`campaign page: ${await page.locator('.plot[data-rendered="true"]').count()} charts rendered`);

  await plot.hover();
  const camera = plot.locator('.modebar-btn[data-title^="Download plot"]');
  const [download] = await Promise.all([page.waitForEvent("download", { timeout: 30_000 }), camera.click()]);
  const saved = join(profile, download.suggestedFilename());
  await download.saveAs(saved);
  const size = statSync(saved).size;
  if (!download.suggestedFilename().endsWith(".png") || size < 1000) throw new Error(`bad PNG export (${size} B)`);
  steps.push(`PNG export: ${download.suggestedFilename()}, ${size} B`);

  await page.goto(`${base}/api/v1/docs`);
  await page.locator(".swagger-ui .opblock").first().waitFor({ timeout: 60_000 });
  steps.push(`API docs: ${await page.locator(".swagger-ui .opblock").count()} operations shown`);
  await page.waitForTimeout(500); // late reports (images, styles) arrive asynchronously
} catch (err) {
  failed = String(err && err.stack ? err.stack : err);
} finally {
  await context.close();
  rmSync(profile, { recursive: true, force: true });
}
console.log(JSON.stringify({ violations, console_errors: consoleErrors, steps, failed }));
process.exit(failed || violations.length ? 1 : 0);
