import { describe, expect, it } from "vitest";
import { fireEvent, screen, waitFor, within } from "@testing-library/react";
import userEvent from "@testing-library/user-event";
import Plotly from "plotly.js-basic-dist-min";
import openapi from "../../openapi.json";
import { CandidatesPanel, scenarioText } from "./CandidatesPanel";
import { explorationErrors } from "./ExplorationSection";
import { rmseTraces } from "./RmsePlot";
import { ComparePage } from "../pages/ComparePage";
import { NewCampaignPage } from "../pages/NewCampaignPage";
import { iterationAt, xOf } from "../lib/xaxis";
import type { MetricPoint } from "../lib/metrics";
import { mockApi, renderPage } from "../test/utils";

const why = (code: string, text: string, nearest_pick: number | null = null) => ({ code, text, nearest_pick, distance: nearest_pick === null ? null : 0.05 });
const cand = (slot: number, score: number | null, rank: number | null, pick: number | null, w: ReturnType<typeof why>) => ({
  slot,
  scenario: { seed: 3, iteration: 1, slot, values: { "initial.q.0": 0.2 + slot / 100 } },
  converged: score !== null,
  score,
  rank,
  pick,
  pick_reason: pick === null ? null : w.text,
  oracle_run_id: null,
  dataset_id: pick === null ? null : 10 + slot,
  force_rmse: pick === null ? null : 2 + slot,
  moment_rmse: null,
  ocp_solution_id: 100 + slot,
  features: [slot / 4],
  why: w,
  has_curves: pick !== null,
});
const CANDIDATES = {
  iteration_index: 1,
  strategy: "ensemble-disagreement",
  batch: 2,
  n_candidates: 4,
  min_distance: 0.1,
  min_disagreement: 0.5,
  top_score: 9,
  candidates: [
    cand(0, 4, 3, null, why("too-close", "disagreement 4 N, but 0.05 from pick 1 (slot 2) < min_distance 0.1", 0)),
    cand(1, 7, 2, 1, why("picked-far", "disagreement 7 N (rank 2); nearest pick at 0.4 >= 0.1", 0)),
    cand(2, 9, 1, 0, why("picked-top", "disagreement 9 N (rank 1)")),
    cand(3, null, null, null, why("not-converged", "its OCP did not converge: not scored, never picked")),
  ],
};
const curves = (std: boolean) => ({
  iteration_index: 1,
  t: [0, 0.1, 0.2],
  q: [[0.2], [0.25], [0.3]],
  qd: [[0], [0.5], [0.5]],
  f_true: [[0, 0, 0, 0, 0, 0], [10, 0, 5, 0, 1, 0], [20, 0, 8, 0, 2, 0]],
  f_pred: [[0, 0, 0, 0, 0, 0], [11, 0, 4, 0, 1, 0], [18, 0, 9, 0, 2, 0]],
  f_std: std ? [[0, 0, 0, 0, 0, 0], [1, 0, 1, 0, 0.1, 0], [2, 0, 1, 0, 0.2, 0]] : null,
});

describe("the candidates & picks tab", () => {
  it("lists every candidate ranked with why it was or was not picked, scores the slots, and draws each pick's forces in the ensemble's band", async () => {
    const { calls } = mockApi({
      "GET /campaigns/5/iterations/1/candidates": CANDIDATES,
      "GET /campaigns/5/iterations/1/picks/0/curves": { ...curves(true), pick: 0, slot: 2 },
      "GET /campaigns/5/iterations/1/picks/1/curves": { ...curves(true), pick: 1, slot: 1 },
      "GET /campaigns/5/iterations/1/candidates/0/trajectory": { iteration_index: 1, t: [0, 1], q: [[0.2], [0.3]], qd: [[0], [0]], tau: [[0], [0]], duration: 1, phases: [], replay_phases: 1, replay_t_end: 1, solver: { status: "ok", converged: true, attempt: 1, initial_guess: "x" }, slot: 0 },
    });
    renderPage(<CandidatesPanel campaignId={5} iteration={1} />);
    const table = await screen.findByTestId("candidates-table");
    const rows = within(table).getAllByRole("row").slice(1);
    // by rank; the unscored candidate last
    expect(rows.map((r) => [r.dataset.slot, r.dataset.why, r.dataset.picked])).toEqual([
      ["2", "picked-top", "true"],
      ["1", "picked-far", "true"],
      ["0", "too-close", "false"],
      ["3", "not-converged", "false"],
    ]);
    expect(rows[2]).toHaveTextContent("too close to a pick");
    expect(rows[2]).toHaveTextContent("0.05 from pick 1 (slot 2)");
    expect(screen.getByTestId("candidates-summary")).toHaveTextContent("4 of 4 candidates solved, 2 picked (q = 2)");
    const scores = screen.getByTestId("candidate-scores");
    expect(scores).toHaveAttribute("data-picked", "2,1");
    // one plot per pick, each with the oracle, the ensemble mean and its ±2σ band for fx and fz (fy is zero throughout)
    await waitFor(() => expect(screen.getAllByTestId("pick-forces")).toHaveLength(2));
    const picks = screen.getAllByTestId("pick-forces");
    expect(picks.map((p) => p.dataset.pick)).toEqual(["0", "1"]);
    expect(picks.every((p) => p.dataset.band === "true")).toBe(true);
    expect(picks[0]).toHaveAttribute("data-traces", String(2 * 4));
    await userEvent.click(screen.getByLabelText("moments"));
    await waitFor(() => expect(screen.getAllByTestId("pick-forces")[0]).toHaveAttribute("data-traces", String(1 * 4))); // my only
    // a candidate's OCP solution on demand
    await userEvent.click(screen.getByLabelText("show the OCP solution of slot 0"));
    await waitFor(() => expect(screen.getByTestId("candidate-trajectories")).toHaveAttribute("data-points", "2"));
    expect(calls.some((c) => c.path === "/campaigns/5/iterations/1/candidates/0/trajectory")).toBe(true);
  });

  it("says a paper iteration has no candidates", async () => {
    mockApi({ "GET /campaigns/5/iterations/2/candidates": { ...CANDIDATES, strategy: "paper", batch: 1, n_candidates: 1, candidates: [] } });
    const chosen: number[] = [];
    renderPage(<CandidatesPanel campaignId={5} iteration={2} last={3} setIteration={(k) => chosen.push(k)} />);
    expect(await screen.findByText("Iteration 2 has no candidates")).toBeInTheDocument();
    // any iteration can be chosen, also one without metrics (e.g. the one the stopping rule ended)
    fireEvent.change(screen.getByLabelText("iteration of the candidates"), { target: { value: "3" } });
    fireEvent.change(screen.getByLabelText("iteration of the candidates"), { target: { value: "4" } });
    expect(chosen).toEqual([3]);
    expect(scenarioText(null)).toBe("the task as written");
  });
});

const pt = (k: number, calls: number, wall: number, picks: MetricPoint["picks"] = []): MetricPoint => ({ iteration: k, status: "succeeded", force_rmse: 1 / k, moment_rmse: 0.1, quarantined: false, cumulative_oracle_calls: calls, cumulative_wall_time_s: wall, picks });

describe("the x axis: iteration, oracle calls or wall time", () => {
  const points = [pt(1, 4, 30, [{ pick: 0, slot: 2, force_rmse: 0.9 }, { pick: 1, slot: 0, force_rmse: 1.1 }]), pt(2, 8, 70)];
  it("plots the RMSE against the cumulative oracle calls or wall time, with each pick's RMSE as a point", () => {
    const byCalls = rmseTraces(points, "", "oracle");
    expect(byCalls[0].x).toEqual([4, 8]);
    expect(rmseTraces(points, "", "wall")[0].x).toEqual([30, 70]);
    expect(rmseTraces(points)[0].x).toEqual([1, 2]);
    const perPick = byCalls.find((t) => String(t.name).includes("per pick"))!;
    expect(perPick.x).toEqual([4, 4]);
    expect(perPick.y).toEqual([0.9, 1.1]);
    // a click at x maps back to its iteration
    expect(iterationAt(points, "oracle", 8)).toBe(2);
    expect(iterationAt(points, "wall", 30)).toBe(1);
    expect(xOf({ ...points[0], cumulative_oracle_calls: null }, "oracle")).toBeNull();
  });

  it("the Compare page switches its x axis", async () => {
    const rows = (calls: number) => [1, 2].map((k) => ({ iteration_index: k, force_rmse: 1 / k, moment_rmse: 0.1, cumulative_oracle_calls: k * calls, cumulative_wall_time_s: 10 * k, extra: {} }));
    mockApi({
      "GET /campaigns": [1, 2].map((id) => ({ id, name: `c${id}`, status: "completed", owner: "a", task: "t", task_version: 1, oracle: "o", oracle_type: "aux-penalty", current_iteration: 2, max_iterations: 2, force_rmse: 1, moment_rmse: 0.1 })),
      "GET /campaigns/1/metrics": rows(1),
      "GET /campaigns/2/metrics": rows(4),
    });
    renderPage(<ComparePage />, { route: "/compare?ids=1,2" });
    await waitFor(() => expect(screen.getByTestId("compare-force")).toHaveAttribute("data-points", "4"));
    await userEvent.click(screen.getByLabelText("oracle calls"));
    await waitFor(() => {
      const last = (Plotly.react as unknown as { mock: { calls: unknown[][] } }).mock.calls.filter((c) => (c[0] as HTMLElement).dataset.testid === "compare-force").pop()!;
      expect((last[1] as { x: number[] }[]).map((t) => t.x)).toEqual([
        [1, 2],
        [4, 8],
      ]);
    });
    expect(screen.getByTestId("x-axis")).toHaveAttribute("data-value", "oracle");
  });
});

describe("the new-campaign form's Exploration section", () => {
  it("the rules between fields, as the API checks them", () => {
    expect(explorationErrors({ settings: { strategy: "paper", batch: 2 } })[0].field).toBe("settings.batch");
    expect(explorationErrors({ settings: { strategy: "ensemble-disagreement", batch: 5, candidates: 4 } })[0].message).toMatch(/at least as many candidates/);
    expect(explorationErrors({ settings: { strategy: "ensemble-disagreement", batch: 4, candidates: 8 } })).toEqual([]);
  });

  it("edits strategy, q, C, min distance, cap and threshold, and shows each error at its field", async () => {
    const { calls } = mockApi({
      "GET /openapi.json": openapi,
      "GET /tasks": [{ id: 1, name: "t", version: 1 }],
      "GET /oracles": [{ id: 2, name: "o", type: "aux-penalty", version: 1 }],
      "GET /surrogate-configs": [],
      "POST /campaigns/check": { valid: true, errors: [] },
    });
    renderPage(<NewCampaignPage />, { route: "/campaigns/new" });
    const section = await screen.findByTestId("exploration");
    // the settings it edits are not repeated in the generic Run settings
    expect(within(screen.getByRole("region", { name: "Run settings" })).queryByText("batch")).toBeNull();
    await userEvent.selectOptions(within(section).getByLabelText("Strategy"), "ensemble-disagreement");
    const field = (label: string) => within(section).getByLabelText(label);
    fireEvent.change(field("Batch q"), { target: { value: "5" } });
    fireEvent.change(field("Candidates C"), { target: { value: "4" } });
    fireEvent.change(field("Min distance"), { target: { value: "-1" } });
    fireEvent.change(field("Concurrency cap"), { target: { value: "0" } });
    fireEvent.change(field("Stopping threshold [N]"), { target: { value: "0" } });
    fireEvent.change(screen.getByLabelText("Name"), { target: { value: "explore" } });
    await userEvent.click(screen.getByRole("button", { name: "Create campaign" }));
    for (const label of ["Batch q", "Min distance", "Concurrency cap", "Stopping threshold [N]"])
      await waitFor(() => expect(field(label)).toHaveAttribute("aria-invalid", "true"));
    expect(within(section).getByText(/needs at least as many candidates/)).toBeInTheDocument();
    expect(calls.some((c) => c.method === "POST" && c.path === "/campaigns")).toBe(false);
    // fixed: sent with the exploration settings
    fireEvent.change(field("Batch q"), { target: { value: "2" } });
    fireEvent.change(field("Min distance"), { target: { value: "0.2" } });
    fireEvent.change(field("Concurrency cap"), { target: { value: "" } });
    fireEvent.change(field("Stopping threshold [N]"), { target: { value: "0.5" } });
    await userEvent.click(screen.getByRole("button", { name: "Create campaign" }));
    await waitFor(() => expect(calls.some((c) => c.method === "POST" && c.path === "/campaigns")).toBe(true));
    const body = calls.find((c) => c.method === "POST" && c.path === "/campaigns")!.body as { settings: Record<string, unknown>; stopping: Record<string, unknown> };
    expect(body.settings).toMatchObject({ strategy: "ensemble-disagreement", batch: 2, candidates: 4, min_distance: 0.2, max_concurrent_oracle_jobs: null });
    expect(body.stopping.min_disagreement).toBe(0.5);
  });
});
