import { describe, expect, it } from "vitest";
import { screen, waitFor, within } from "@testing-library/react";
import userEvent from "@testing-library/user-event";
import { CampaignPage } from "./CampaignPage";
import { mockApi, renderPage } from "../test/utils";

function campaign(status: string, iteration = 2) {
  return {
    id: 7,
    campaign: {
      id: 7,
      owner_id: 1,
      name: "headrest study",
      description: "",
      status,
      stop_reason: null,
      error: null,
      task_version_id: 3,
      oracle_version_id: 4,
      surrogate_config_version_id: 5,
      seed: 0,
      config_version: 1,
      source_campaign_id: null,
      source_iteration: null,
      current_iteration: iteration,
      current_step: "ocp",
      pause_requested: false,
      cancel_requested: false,
      oracle_wall_time_s: 1,
      created_at: "2026-11-21T22:00:00Z",
      started_at: "2026-11-21T22:00:00Z",
      finished_at: null,
    },
    config: { stopping: { max_iterations: 10 }, preliminary: {}, policies: {}, settings: {} },
    current: null,
    latest_metrics: null,
    iterations_finished: iteration,
    iterations_failed: 0,
    mean_iteration_s: 10,
    eta_s: 80,
    owner: "ana@lab",
    can_edit: true,
    task_id: 1,
    task_version: 1,
    oracle_id: 2,
    oracle_version: 1,
  };
}

const metric = (k: number) => ({ iteration_index: k, force_rmse: 1 / (k + 1), moment_rmse: 0.1 / (k + 1), extra: {} });
const iteration = (k: number, status = "succeeded", error: string | null = null) => ({ id: k + 100, index: k, status, error, current_step: null, config_version_id: 1, started_at: null, finished_at: null, steps: [] });

// rows are time samples: q (n, 1), f (n, 6)
const curves = (k: number) => ({
  iteration_index: k,
  t: [0, 0.1, 0.2],
  q: [[0.2], [0.3], [0.35]],
  qd: [[0], [1], [0]],
  // the replayed motion's joint torque; iteration 0 (no oracle run) has none
  tau: k > 0 ? [[-1], [-2.5], [-3]] : null,
  f_true: [
    [0, 0, 0, 0, 0, 0],
    [5, 0, 1, 0, 0.1, 0],
    [9, 0, 2, 0, 0.2, 0],
  ],
  f_pred: [
    [0, 0, 0, 0, 0, 0],
    [4, 0, 1, 0, 0.1, 0],
    [8, 0, 1, 0, 0.1, 0],
  ],
});

const TASK_VERSION = { version: 1, spec_hash: "x", note: "", locked: true, created_at: "2026-11-21T22:00:00Z", spec: { name: "two-phase", phases: [{ name: "lean back", duration: 0.1 }, { name: "hold", duration: 0.1 }] } };
const CURVES_ROUTE = "GET /campaigns/7/iterations/{k}/curves";
const curvesHandler = (url: URL) => curves(Number(url.pathname.split("/")[6]));

const TRAJECTORY_ROUTE = "GET /campaigns/7/iterations/{k}/trajectory";
// the whole OCP solution of iteration k: 2 phases of 0.1 s, 2 intervals each
const trajectory = (k: number) => ({
  iteration_index: k,
  t: [0, 0.05, 0.1, 0.15, 0.2],
  q: [[0.2], [0.3], [0.35], [0.35], [0.35]],
  qd: [[0], [1], [0], [0], [0]],
  tau: [[-1], [-2.5], [-1], [0], [0]],
  duration: 0.2,
  phases: [
    { index: 0, name: "lean back", duration: 0.1, t_start: 0, t_end: 0.1, replayed: true },
    { index: 1, name: "hold", duration: 0.1, t_start: 0.1, t_end: 0.2, replayed: false },
  ],
  replay_phases: 1,
  replay_t_end: 0.1,
  replay_dt: 0.0025,
  solver: { status: "Solve_Succeeded", converged: true, iterations: 31, cost: 0.5, wall_time_s: 0.2, attempt: 1, initial_guess: "previous", message: "" },
});
const trajectoryHandler = (url: URL) => {
  const k = Number(url.pathname.split("/")[6]);
  return k > 0 ? trajectory(k) : new Response(JSON.stringify({ detail: `iteration: campaign 7 has no OCP solution for iteration ${k}` }), { status: 404 });
};

describe("campaign page", () => {
  it("polls only new iterations while the campaign runs and draws them on a log axis", async () => {
    let metrics = [metric(0), metric(1)];
    let iterations = [iteration(0), iteration(1), iteration(2, "running")];
    const after = (url: URL) => Number(url.searchParams.get("after") ?? -1);
    const { calls } = mockApi({
      "GET /campaigns/7": () => campaign("running"),
      "GET /campaigns/7/metrics": (url: URL) => metrics.filter((m) => m.iteration_index > after(url)),
      "GET /campaigns/7/iterations": (url: URL) => iterations.filter((it) => it.index > after(url)),
      "GET /tasks/1/versions/1": TASK_VERSION,
      [CURVES_ROUTE]: curvesHandler,
    });
    renderPage(<CampaignPage />, { route: "/campaigns/7", path: "/campaigns/:id" });
    expect(await screen.findByRole("heading", { name: "headrest study" })).toBeInTheDocument();
    await waitFor(() => expect(screen.getByTestId("rmse-count")).toHaveTextContent("2 iterations"));
    expect(screen.getByTestId("rmse-plot")).toHaveAttribute("data-log-y", "true");
    expect(screen.getByTestId("rmse-plot")).toHaveAttribute("data-points", "4");

    // iteration 2 fails (quarantined oracle result), iteration 3 succeeds
    iterations = [iteration(0), iteration(1), iteration(2, "failed", "oracle result quarantined: penetration too deep"), iteration(3)];
    metrics = [...metrics, metric(3)];
    await waitFor(() => expect(screen.getByTestId("rmse-count")).toHaveTextContent("3 iterations"), { timeout: 4000 });
    const metricCalls = calls.filter((c) => c.path === "/campaigns/7/metrics");
    const iterationCalls = calls.filter((c) => c.path === "/campaigns/7/iterations");
    expect(metricCalls[0].url.searchParams.get("after")).toBeNull();
    expect(metricCalls[metricCalls.length - 1].url.searchParams.get("after")).toBe("1");
    // the running iteration 2 is asked for again, the finished ones are not
    expect(iterationCalls[iterationCalls.length - 1].url.searchParams.get("after")).toBe("1");
    // the quarantined iteration is drawn as a separate marked trace
    await waitFor(() => expect(screen.getByTestId("rmse-plot")).toHaveAttribute("data-traces", "3"));
  });

  it("does not poll a finished campaign, keeps the log toggle in the URL, shows forces and controls", async () => {
    const { calls } = mockApi({
      "GET /campaigns/7": () => campaign("completed", 2),
      "GET /campaigns/7/metrics": () => [metric(0), metric(1), metric(2)],
      "GET /campaigns/7/iterations": () => [iteration(0), iteration(1), iteration(2)],
      "GET /tasks/1/versions/1": TASK_VERSION,
      [CURVES_ROUTE]: curvesHandler,
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
    expect(calls.some((c) => c.path.startsWith("/campaigns/7/") && c.path.endsWith("/pause"))).toBe(false);
  });

  it("plots the iteration's whole OCP trajectory with every phase shaded and the replayed part marked", async () => {
    mockApi({
      "GET /campaigns/7": () => campaign("completed", 1),
      "GET /campaigns/7/metrics": () => [metric(0), metric(1)],
      "GET /campaigns/7/iterations": () => [iteration(0), iteration(1)],
      "GET /tasks/1/versions/1": TASK_VERSION,
      [CURVES_ROUTE]: curvesHandler,
      [TRAJECTORY_ROUTE]: trajectoryHandler,
    });
    renderPage(<CampaignPage />, { route: "/campaigns/7?tab=trajectory", path: "/campaigns/:id" });
    // both phases over the whole task (5 nodes up to t = 0.2 s), not only the replayed one
    await waitFor(() => expect(screen.getByTestId("angle-plot")).toHaveAttribute("data-points", "5"));
    expect(screen.getByTestId("torque-plot")).toHaveAttribute("data-points", "5");
    // 2 phase rectangles + the 3 lines of the "replayed by the oracle" bracket
    expect(screen.getByTestId("angle-plot")).toHaveAttribute("data-shapes", "5");
    expect(screen.getByTestId("trajectory-panel")).toHaveAttribute("data-phases", "2");
    expect(screen.getByTestId("phases-replayed")).toHaveTextContent("The oracle replayed lean back (t ≤ 0.100 s, resampled every 2.50 ms). The task's later phase is not replayed.");
    const summary = screen.getByTestId("solver-summary");
    expect(summary).toHaveTextContent("Solve_Succeeded");
    expect(summary).toHaveTextContent("IPOPT iterations31");
  });

  it("says an iteration without an OCP solution has no trajectory", async () => {
    mockApi({
      "GET /campaigns/7": () => campaign("completed", 1),
      "GET /campaigns/7/metrics": () => [metric(0), metric(1)],
      "GET /campaigns/7/iterations": () => [iteration(0), iteration(1)],
      "GET /tasks/1/versions/1": TASK_VERSION,
      [CURVES_ROUTE]: curvesHandler,
      [TRAJECTORY_ROUTE]: trajectoryHandler,
    });
    renderPage(<CampaignPage />, { route: "/campaigns/7?tab=trajectory&k=0", path: "/campaigns/:id" });
    expect(await screen.findByText("Iteration 0 has no OCP trajectory")).toBeInTheDocument();
    expect(screen.queryByTestId("angle-plot")).not.toBeInTheDocument();
    expect(screen.queryByRole("alert")).not.toBeInTheDocument();
  });

  it("shows the API's error instead of a blank page", async () => {
    mockApi({ "GET /campaigns/7": () => new Response(JSON.stringify({ detail: "campaign not found" }), { status: 404 }) });
    renderPage(<CampaignPage />, { route: "/campaigns/7", path: "/campaigns/:id" });
    expect(await screen.findByRole("alert")).toHaveTextContent("campaign not found");
  });
});
