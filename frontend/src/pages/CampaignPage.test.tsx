import { describe, expect, it } from "vitest";
import { screen, waitFor, within } from "@testing-library/react";
import userEvent from "@testing-library/user-event";
import { CampaignPage } from "./CampaignPage";
import { mockApi, renderPage } from "../test/utils";
import type { CampaignDetail, IterationCurves } from "../api/hooks";
import type { MetricPoint } from "../lib/metrics";

function campaign(status: string, iteration = 2): CampaignDetail {
  return {
    id: 7,
    name: "headrest study",
    status,
    owner: "ana@lab",
    task: "two-phase",
    task_id: 1,
    oracle: "aux",
    oracle_id: 2,
    iteration,
    max_iterations: 10,
    force_rmse: 0.5,
    moment_rmse: 0.01,
    force_history: [],
    moment_history: [],
    started_at: "2026-11-21T22:00:00Z",
    eta_s: 120,
    current_step: "ocp",
    finished_at: null,
    stop_reason: null,
    error: null,
    source_campaign_id: null,
    source_iteration: null,
    config: { stopping: { max_iterations: 10 } },
  };
}

const point = (k: number, extra: Partial<MetricPoint> = {}): MetricPoint => ({ iteration: k, status: "succeeded", force_rmse: 1 / (k + 1), moment_rmse: 0.1 / (k + 1), quarantined: false, ...extra });

const curves = (k: number): IterationCurves => ({
  iteration: k,
  t: [0, 0.1, 0.2],
  q: [[0.2, 0.3, 0.35]],
  qd: [[0, 1, 0]],
  tau: [[1, 2, 3]],
  phases: [
    { name: "lean back", t_start: 0, t_end: 0.1 },
    { name: "hold", t_start: 0.1, t_end: 0.2 },
  ],
  force_t: [0, 0.1, 0.2],
  truth: { fx: [0, 5, 9], fy: [0, 0, 0], fz: [0, 1, 2], mx: [0, 0, 0], my: [0, 0.1, 0.2], mz: [0, 0, 0] },
  predicted: { fx: [0, 4, 8], fy: [0, 0, 0], fz: [0, 1, 1], mx: [0, 0, 0], my: [0, 0.1, 0.1], mz: [0, 0, 0] },
});

describe("campaign page", () => {
  it("polls only new iterations while the campaign runs and draws them on a log axis", async () => {
    let served = [point(0), point(1)];
    const { calls } = mockApi({
      "GET /campaigns/7": () => campaign("running"),
      "GET /campaigns/7/metrics": (url: URL) => {
        const after = url.searchParams.get("after");
        return served.filter((p) => after === null || p.iteration > Number(after));
      },
      "GET /campaigns/7/iterations/{k}/curves": (url: URL) => curves(Number(url.pathname.split("/")[6])),
    });
    renderPage(<CampaignPage />, { route: "/campaigns/7", path: "/campaigns/:id" });
    expect(await screen.findByRole("heading", { name: "headrest study" })).toBeInTheDocument();
    await waitFor(() => expect(screen.getByTestId("rmse-count")).toHaveTextContent("2 iterations"));
    expect(screen.getByTestId("rmse-plot")).toHaveAttribute("data-log-y", "true");
    expect(screen.getByTestId("rmse-plot")).toHaveAttribute("data-points", "4");

    served = [...served, point(2, { quarantined: true })];
    await waitFor(() => expect(screen.getByTestId("rmse-count")).toHaveTextContent("3 iterations"), { timeout: 4000 });
    const metricCalls = calls.filter((c) => c.path === "/campaigns/7/metrics");
    expect(metricCalls[0].url.searchParams.get("after")).toBeNull();
    expect(metricCalls[metricCalls.length - 1].url.searchParams.get("after")).toBe("1");
    // the quarantined iteration is drawn as a separate marked trace
    expect(screen.getByTestId("rmse-plot")).toHaveAttribute("data-traces", "3");
  });

  it("does not poll a finished campaign, keeps the log toggle in the URL, shows forces and controls", async () => {
    const { calls } = mockApi({
      "GET /campaigns/7": () => campaign("completed", 2),
      "GET /campaigns/7/metrics": () => [point(0), point(1), point(2)],
      "GET /campaigns/7/iterations/{k}/curves": (url: URL) => curves(Number(url.pathname.split("/")[6])),
    });
    renderPage(<CampaignPage />, { route: "/campaigns/7?log=0", path: "/campaigns/:id" });
    await screen.findByRole("heading", { name: "headrest study" });
    await waitFor(() => expect(screen.getByTestId("rmse-plot")).toHaveAttribute("data-points", "6"));
    expect(screen.getByTestId("rmse-plot")).toHaveAttribute("data-log-y", "false");
    await userEvent.click(screen.getByLabelText("log axis"));
    expect(screen.getByTestId("rmse-plot")).toHaveAttribute("data-log-y", "true");

    // latest iteration with oracle data is shown: oracle and surrogate for fx and fz
    await waitFor(() => expect(screen.getByTestId("force-plot")).toHaveAttribute("data-traces", "4"));
    expect(screen.getByTestId("iteration-value")).toHaveTextContent("k = 2");
    // overlay iteration 1: twice the traces
    await userEvent.click(within(screen.getByRole("group", { name: "Overlay iterations" })).getByLabelText("1"));
    await waitFor(() => expect(screen.getByTestId("force-plot")).toHaveAttribute("data-traces", "8"));

    const controls = screen.getByRole("group", { name: "Campaign controls" });
    expect(within(controls).getByRole("button", { name: "Pause" })).toBeDisabled();
    expect(within(controls).getByRole("button", { name: "Fork…" })).toBeEnabled();

    await new Promise((r) => setTimeout(r, 2300));
    expect(calls.filter((c) => c.path === "/campaigns/7/metrics")).toHaveLength(1);
  });

  it("shades the phases of the iteration's trajectory", async () => {
    mockApi({
      "GET /campaigns/7": () => campaign("completed", 1),
      "GET /campaigns/7/metrics": () => [point(0), point(1)],
      "GET /campaigns/7/iterations/{k}/curves": () => curves(1),
    });
    renderPage(<CampaignPage />, { route: "/campaigns/7?tab=trajectory", path: "/campaigns/:id" });
    await waitFor(() => expect(screen.getByTestId("angle-plot")).toHaveAttribute("data-points", "3"));
    expect(screen.getByTestId("torque-plot")).toHaveAttribute("data-points", "3");
  });

  it("shows the API's error instead of a blank page", async () => {
    mockApi({ "GET /campaigns/7": () => new Response(JSON.stringify({ detail: "campaign not found" }), { status: 404 }) });
    renderPage(<CampaignPage />, { route: "/campaigns/7", path: "/campaigns/:id" });
    expect(await screen.findByRole("alert")).toHaveTextContent("campaign not found");
  });
});
