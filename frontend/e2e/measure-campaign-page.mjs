#!/usr/bin/env node
/**
 * Time from navigation start until a campaign page is interactive: the RMSE plot is drawn by
 * Plotly with every iteration's points and the page answers input (the log-axis toggle).
 * Fresh browser profile; with --warm the page is visited once first (HTTP and V8 code caches
 * warm, as for a returning user) and the second visit is timed. Prints {"seconds": ..., "points": ...}.
 *
 *   node e2e/measure-campaign-page.mjs --base-url URL --token TOKEN --campaign-id 1 --points 400
 */
import { openBrowser, parseArgs } from "./browser.mjs";

const args = parseArgs(process.argv.slice(2));
const baseUrl = String(args["base-url"]).replace(/\/$/, "");
const expected = Number(args.points ?? 1);
const { context, close } = await openBrowser();
try {
  const page = context.pages()[0] ?? (await context.newPage());
  // put the token in place on a page of the same origin that loads nothing else
  await page.route(`${baseUrl}/__blank`, (route) => route.fulfill({ body: "<!doctype html><title>blank</title>", contentType: "text/html" }));
  await page.goto(`${baseUrl}/__blank`);
  await page.evaluate((t) => localStorage.setItem("alcove.token", t), String(args.token));
  if (args.warm) {
    await page.goto(`${baseUrl}/campaigns/${args["campaign-id"]}`);
    await page.locator("[data-testid=rmse-plot][data-rendered=true]").waitFor({ timeout: 60_000 });
    await page.goto(`${baseUrl}/__blank`);
  }
  await page.goto(`${baseUrl}/campaigns/${args["campaign-id"]}`, { waitUntil: "commit" });
  const handle = await page
    .waitForFunction(
    (n) => {
      const el = document.querySelector("[data-testid=rmse-plot]");
      if (!el || el.getAttribute("data-rendered") !== "true" || Number(el.getAttribute("data-points")) < n) return false;
      if (!el.querySelector(".main-svg .scatterlayer .trace")) return false;
      return performance.now();
    },
    expected,
    { timeout: 30_000, polling: "raf" },
  )
    .catch(async (err) => {
      const plot = await page.locator("[data-testid=rmse-plot]").evaluate((el) => el.outerHTML.slice(0, 300)).catch(() => "no rmse plot");
      await page.screenshot({ path: "measure-failure.png" }).catch(() => {});
      throw new Error(`${err.message}\nurl: ${page.url()}\nplot: ${plot}\nbody: ${(await page.locator("body").innerText()).slice(0, 500)}`);
    });
  const drawnMs = Number(await handle.jsonValue());
  // interactive: the log toggle re-renders the plot right away
  const toggleStart = await page.evaluate(() => performance.now());
  await page.getByLabel("log axis").click();
  await page.waitForFunction(() => document.querySelector("[data-testid=rmse-plot]")?.getAttribute("data-log-y") === "false", null, { polling: "raf" });
  const toggled = await page.evaluate(() => performance.now());
  const points = Number(await page.getByTestId("rmse-plot").getAttribute("data-points"));
  if (args.verbose) {
    const entries = await page.evaluate(() =>
      performance.getEntriesByType("resource").map((/** @type {PerformanceResourceTiming} */ e) => `${e.startTime.toFixed(0).padStart(6)} +${e.duration.toFixed(0).padStart(5)} ms ${e.transferSize ?? ""} ${e.name.replace(location.origin, "")}`),
    );
    console.error(entries.join("\n"));
    const marks = await page.evaluate(() => performance.getEntriesByType("mark").map((m) => `${m.startTime.toFixed(0).padStart(6)} ${m.name}`));
    console.error(marks.join("\n"));
  }
  console.log(JSON.stringify({ seconds: drawnMs / 1000, toggle_seconds: (toggled - toggleStart) / 1000, points }));
} finally {
  await close();
}
