/** Debian's Chromium driven by playwright-core (never a downloaded browser), fresh profile each run. */
import { chromium } from "playwright-core";
import { mkdtempSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";

export const CHROMIUM = process.env.ALCOVE_CHROMIUM ?? "/usr/bin/chromium";
const ARGS = [
  "--headless",
  "--no-sandbox",
  "--disable-gpu",
  "--disable-quic",
  "--no-first-run",
  "--disable-background-networking",
  "--disable-component-update",
  "--disable-sync",
];

export async function openBrowser({ width = 1280, height = 900 } = {}) {
  const profile = mkdtempSync(join(tmpdir(), "alcove-chromium-"));
  const context = await chromium.launchPersistentContext(profile, {
    executablePath: CHROMIUM,
    headless: true,
    args: ARGS,
    viewport: { width, height },
    acceptDownloads: true,
  });
  return {
    context,
    async close() {
      await context.close();
      rmSync(profile, { recursive: true, force: true });
    },
  };
}

export function parseArgs(argv) {
  const out = {};
  for (let i = 0; i < argv.length; i++) {
    const a = argv[i];
    if (a.startsWith("--")) {
      const key = a.slice(2);
      const next = argv[i + 1];
      if (next === undefined || next.startsWith("--")) out[key] = true;
      else {
        out[key] = next;
        i++;
      }
    }
  }
  return out;
}

/** Sign in through the API and put the token where the app keeps it (skips the form). */
export async function signInByToken(page, baseUrl, email, password) {
  const r = await page.request.post(`${baseUrl}/api/v1/auth/login`, { data: { email, password } });
  if (!r.ok()) throw new Error(`login failed: ${r.status()} ${await r.text()}`);
  const { access_token } = await r.json();
  await page.goto(`${baseUrl}/signin`);
  await page.evaluate((t) => localStorage.setItem("alcove.token", t), access_token);
  return access_token;
}

/**
 * Click a tab of the campaign page and wait for the state the click causes: the tab selected
 * and its panel shown (the page writes the tab to the URL; the next step must not race that).
 */
export async function openTab(page, name) {
  const tab = page.getByRole("tab", { name, exact: true });
  await tab.click();
  await page.getByRole("tab", { name, exact: true, selected: true }).waitFor();
  const panel = await tab.getAttribute("aria-controls");
  if (panel) await page.locator(`#${panel}`).waitFor();
}

export const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

/** Poll ``fn`` until it returns something truthy; an error it throws counts as not yet. */
export async function waitFor(fn, what, timeout = 30_000, interval = 250) {
  const deadline = Date.now() + timeout;
  let last;
  while (Date.now() < deadline) {
    try {
      last = await fn();
      if (last) return last;
    } catch (err) {
      last = err;
    }
    await sleep(interval);
  }
  throw new Error(`timed out waiting for ${what} (last: ${last})`);
}

/** ``api(method, path, body)`` on ``baseUrl``/api/v1 with the bearer token ``token()`` returns at the call. */
export function apiClient(page, baseUrl, token) {
  return async (method, path, body) => {
    const r = await page.request.fetch(`${baseUrl}/api/v1${path}`, { method, data: body, headers: { Authorization: `Bearer ${token()}` } });
    if (!r.ok()) throw new Error(`${method} ${path}: ${r.status()} ${await r.text()}`);
    return r.status() === 204 ? null : r.json();
  };
}
