import { describe, expect, it } from "vitest";
import { act, screen, waitFor, within } from "@testing-library/react";
import userEvent from "@testing-library/user-event";
import { CampaignPage } from "./CampaignPage";
import { mockApi, renderPage, sseStream } from "../test/utils";

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
  it("updates from the live channel: an evaluated iteration fetches only the new metrics, and nothing polls", async () => {
    let metrics = [metric(0), metric(1)];
    let iterations = [iteration(0), iteration(1), iteration(2, "running")];
    const stream = sseStream();
    const after = (url: URL) => Number(url.searchParams.get("after") ?? -1);
    const { calls } = mockApi({
      "GET /campaigns/7": () => campaign("running"),
      "GET /campaigns/7/events/stream": (url: URL) => stream.response(url),
      "GET /campaigns/7/metrics": (url: URL) => metrics.filter((m) => m.iteration_index > after(url)),
      "GET /campaigns/7/iterations": (url: URL) => iterations.filter((it) => it.index > after(url)),
      "GET /tasks/1/versions/1": TASK_VERSION,
      [CURVES_ROUTE]: curvesHandler,
    });
    renderPage(<CampaignPage />, { route: "/campaigns/7", path: "/campaigns/:id" });
    expect(await screen.findByRole("heading", { name: "headrest study" })).toBeInTheDocument();
    await waitFor(() => expect(screen.getByTestId("rmse-count")).toHaveTextContent("2 iterations"));
    await waitFor(() => expect(screen.getByTestId("live-state")).toHaveAttribute("data-state", "live"));
    expect(screen.getByTestId("rmse-plot")).toHaveAttribute("data-log-y", "true");
    expect(screen.getByTestId("rmse-plot")).toHaveAttribute("data-points", "4");

    // iteration 2 fails (quarantined oracle result), iteration 3 is evaluated
    iterations = [iteration(0), iteration(1), iteration(2, "failed", "oracle result quarantined: penetration too deep"), iteration(3)];
    metrics = [...metrics, metric(3)];
    stream.send({ kind: "step_failed", iteration_index: 2, step: "oracle" });
    stream.send({ kind: "step_succeeded", iteration_index: 3, step: "evaluate" });
    await waitFor(() => expect(screen.getByTestId("rmse-count")).toHaveTextContent("3 iterations"), { timeout: 4000 });
    // the quarantined iteration is drawn as a separate marked trace
    await waitFor(() => expect(screen.getByTestId("rmse-plot")).toHaveAttribute("data-traces", "3"));
    const metricCalls = calls.filter((c) => c.path === "/campaigns/7/metrics");
    const iterationCalls = calls.filter((c) => c.path === "/campaigns/7/iterations");
    // the first fetch has the whole series, every later one only what is new (the catch-up at connection time, the evaluated iteration)
    const afters = metricCalls.map((c) => c.url.searchParams.get("after"));
    expect(afters[0]).toBeNull();
    expect(afters.slice(1).every((a) => a === "1")).toBe(true);
    expect(metricCalls.length).toBeLessThanOrEqual(3);
    // the running iteration 2 is asked for again, the finished ones are not
    expect(iterationCalls[iterationCalls.length - 1].url.searchParams.get("after")).toBe("1");

    // while the stream is up, nothing polls: no request for 2.5 s without an event
    const before = calls.length;
    await new Promise((r) => setTimeout(r, 2500));
    expect(calls.slice(before).map((c) => c.path)).toEqual([]);
    // a step that starts refreshes the header and the jobs, not the series
    stream.send({ kind: "step_started", iteration_index: 4, step: "train" });
    await waitFor(() => expect(calls.length).toBeGreaterThan(before));
    await new Promise((r) => setTimeout(r, 200));
    expect(new Set(calls.slice(before).map((c) => c.path))).toEqual(new Set(["/campaigns/7"]));
    stream.close();
  });

  it("falls back to polling, with backoff, while the stream is down, and reconnects with ?after= the last event", async () => {
    let streamUp = false;
    const stream = sseStream();
    const { calls } = mockApi({
      "GET /campaigns/7": () => campaign("running"),
      "GET /campaigns/7/events/stream": (url: URL) => (streamUp ? stream.response(url) : new Response("", { status: 503 })),
      "GET /campaigns/7/metrics": () => [],
      "GET /campaigns/7/iterations": () => [],
      "GET /tasks/1/versions/1": TASK_VERSION,
    });
    renderPage(<CampaignPage />, { route: "/campaigns/7", path: "/campaigns/:id" });
    await waitFor(() => expect(screen.getByTestId("live-state")).toHaveAttribute("data-state", "down"));
    expect(screen.getByTestId("live-state")).toHaveTextContent("checking every 2 s");
    await waitFor(() => expect(calls.filter((c) => c.path === "/campaigns/7/metrics").length).toBeGreaterThanOrEqual(2), { timeout: 3500 });
    streamUp = true;
    await waitFor(() => expect(screen.getByTestId("live-state")).toHaveAttribute("data-state", "live"), { timeout: 5000 });
    // up again: polling stops
    const polls = calls.filter((c) => c.path === "/campaigns/7/metrics").length;
    stream.send({ kind: "step_started", iteration_index: 1, step: "ocp" });
    const last = stream.send({ kind: "step_succeeded", iteration_index: 1, step: "ocp" });
    await new Promise((r) => setTimeout(r, 300));
    stream.close(); // the server's timeout: reconnect at once, after the last event
    await waitFor(() => expect(calls.filter((c) => c.path === "/campaigns/7/events/stream").pop()?.url.searchParams.get("after")).toBe(String(last)));
    await new Promise((r) => setTimeout(r, 2200));
    expect(calls.filter((c) => c.path === "/campaigns/7/metrics").length).toBe(polls);
    stream.close();
  }, 15000);

  it("a reconnection that missed too much (ready: complete false) refetches what the page shows; a complete one does not", async () => {
    const stream = sseStream();
    const { calls } = mockApi({
      "GET /campaigns/7": () => campaign("running"),
      "GET /campaigns/7/events/stream": (url: URL) => stream.response(url),
      "GET /campaigns/7/metrics": () => [metric(0)],
      "GET /campaigns/7/iterations": () => [iteration(0)],
      "GET /tasks/1/versions/1": TASK_VERSION,
    });
    renderPage(<CampaignPage />, { route: "/campaigns/7", path: "/campaigns/:id" });
    await waitFor(() => expect(screen.getByTestId("live-state")).toHaveAttribute("data-state", "live"));
    stream.send({ kind: "step_started", iteration_index: 1, step: "train" });
    await new Promise((r) => setTimeout(r, 300));
    const count = (path: string) => calls.filter((c) => c.path === path).length;
    let before = count("/campaigns/7/metrics");
    stream.close(); // resumed with ?after=, complete: nothing to reload
    await waitFor(() => expect(stream.connections).toBe(2));
    await new Promise((r) => setTimeout(r, 300));
    expect(count("/campaigns/7/metrics")).toBe(before);
    stream.incomplete = true;
    stream.close(); // resumed, but the server could not send all that was missed
    await waitFor(() => expect(stream.connections).toBe(3));
    await waitFor(() => expect(count("/campaigns/7/metrics")).toBe(before + 1));
    before = count("/campaigns/7/iterations");
    expect(before).toBeGreaterThanOrEqual(2);
    stream.close();
  });

  it("after the campaign ends, the plot shows every iteration the header reports, even if an answer was stale", async () => {
    // the defect: the header showed iteration 2's RMSE, the plot stopped at 1 until a reload
    let stale = true;
    const { calls } = mockApi({
      "GET /campaigns/7": () => ({ ...campaign("completed", 2), latest_metrics: { ...metric(2), iteration_index: 2 } }),
      "GET /campaigns/7/metrics": (url: URL) => {
        const after = Number(url.searchParams.get("after") ?? -1);
        const rows = stale ? [metric(0), metric(1)] : [metric(0), metric(1), metric(2)];
        stale = false; // an answer from before the last commit (or a short server-side reuse window)
        return rows.filter((m) => m.iteration_index > after);
      },
      "GET /campaigns/7/iterations": () => [iteration(0), iteration(1), iteration(2)],
      "GET /tasks/1/versions/1": TASK_VERSION,
      [CURVES_ROUTE]: curvesHandler,
    });
    renderPage(<CampaignPage />, { route: "/campaigns/7", path: "/campaigns/:id" });
    await waitFor(() => expect(screen.getByTestId("rmse-count")).toHaveTextContent("3 iterations"), { timeout: 3000 });
    expect(screen.getByTestId("rmse-plot")).toHaveAttribute("data-iterations", "0,1,2");
    expect(calls.filter((c) => c.path === "/campaigns/7/metrics").map((c) => c.url.searchParams.get("after"))).toEqual([null, "1"]);
    // a terminal campaign opens no stream
    expect(calls.some((c) => c.path.endsWith("/events/stream"))).toBe(false);
  });

  it("a campaign waiting for a free place says why beside its status", async () => {
    const reason = "waiting for a free place: 2 of your campaigns are running and your limit is 2 (max_running_campaigns); it starts when one of them ends";
    const waiting = campaign("queued", 0);
    mockApi({
      "GET /campaigns/7": () => ({ ...waiting, campaign: { ...waiting.campaign, wait_reason: reason } }),
      "GET /campaigns/7/metrics": () => [],
      "GET /campaigns/7/iterations": () => [],
      "GET /tasks/1/versions/1": TASK_VERSION,
      [CURVES_ROUTE]: curvesHandler,
    });
    renderPage(<CampaignPage />, { route: "/campaigns/7", path: "/campaigns/:id" });
    expect(await screen.findByTestId("wait-reason")).toHaveTextContent(reason);
    expect(screen.getByText("queued")).toHaveAttribute("title", reason);
  });

  it("clicking a point on the RMSE plot opens that iteration on the forces tab (k in the URL)", async () => {
    mockApi({
      "GET /campaigns/7": () => campaign("completed", 3),
      "GET /campaigns/7/metrics": () => [metric(0), metric(1), metric(2), metric(3)],
      "GET /campaigns/7/iterations": () => [iteration(0), iteration(1), iteration(2), iteration(3)],
      "GET /campaigns/7/jobs": () => [],
      "GET /tasks/1/versions/1": TASK_VERSION,
      [CURVES_ROUTE]: curvesHandler,
    });
    renderPage(<CampaignPage />, { route: "/campaigns/7?tab=jobs", path: "/campaigns/:id" });
    await waitFor(() => expect(screen.getByTestId("rmse-plot")).toHaveAttribute("data-rendered", "true"));
    const el = screen.getByTestId("rmse-plot") as HTMLElement & { __plotly: Record<string, (e: unknown) => void> };
    await act(async () => el.__plotly.plotly_click({ points: [{ x: 1, curveNumber: 0 }] }));
    await waitFor(() => expect(screen.getByTestId("forces-panel")).toHaveAttribute("data-iteration", "1"));
    const search = new URLSearchParams(screen.getByTestId("location").getAttribute("data-search") ?? "");
    expect(search.get("k")).toBe("1");
    expect(search.get("tab")).toBeNull(); // the forces tab is the default
    expect(screen.getByTestId("iteration-value")).toHaveTextContent("k = 1");
  });

  it("does not poll a finished campaign, keeps the log toggle in the URL, shows forces and overlays by range", async () => {
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
    // overlay iterations 1-2 by range: twice the curves plus the colorbar
    await userEvent.type(screen.getByLabelText("Overlay iterations"), "1-2{Enter}");
    await waitFor(() => expect(screen.getByTestId("force-plot")).toHaveAttribute("data-traces", "9"));
    expect(new URLSearchParams(screen.getByTestId("location").getAttribute("data-search") ?? "").get("overlay")).toBe("1, 2");

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
