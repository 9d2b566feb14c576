#!/usr/bin/env node
/**
 * Time from navigation start until a campaign page is interactive: the RMSE plot is drawn by
 * Plotly with every iteration's points and the page answers input (the log-axis toggle).
 * Cold browser profile (nothing cached). Prints {"seconds": ..., "points": ...}.
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
  await page.goto(`${baseUrl}/campaigns/${args["campaign-id"]}`, { waitUntil: "commit" });
  const handle = await page.waitForFunction(
    (n) => {
      const el = document.querySelector("[data-testid=rmse-plot]");
      if (!el || el.getAttribute("data-rendered") !== "true" || Number(el.getAttribute("data-points")) < n) return false;
      if (!el.querySelector(".main-svg .scatterlayer .trace")) return false;
      return performance.now();
    },
    expected,
    { timeout: 30_000, polling: "raf" },
  );
  const drawnMs = await handle.jsonValue();
  // interactive: the log toggle re-renders the plot right away
  const toggleStart = await page.evaluate(() => performance.now());
  await page.getByLabel("log axis").click();
  await page.waitForFunction(() => document.querySelector("[data-testid=rmse-plot]")?.getAttribute("data-log-y") === "false", null, { polling: "raf" });
  const toggled = await page.evaluate(() => performance.now());
  const points = Number(await page.getByTestId("rmse-plot").getAttribute("data-points"));
  console.log(JSON.stringify({ seconds: drawnMs / 1000, toggle_seconds: (toggled - toggleStart) / 1000, points }));
} finally {
  await close();
}
