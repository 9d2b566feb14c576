import { useState } from "react";
import { describe, expect, it } from "vitest";
import { screen, waitFor, within } from "@testing-library/react";
import userEvent from "@testing-library/user-event";
import { ForcesPanel } from "./ForcesPanel";
import { batchPicks, pickLabel } from "./PickChooser";
import type { CandidateDetail } from "../api/types";
import type { MetricPoint } from "../lib/metrics";
import { mockApi, renderPage } from "../test/utils";

const candidate = (slot: number, pick: number | null, value: number) => ({
  slot,
  scenario: { seed: 3, iteration: 1, slot, values: { "initial.q.0": value, "model.headrest_offset": 0.002 } },
  converged: true,
  score: 5 - slot,
  rank: slot + 1,
  pick,
  pick_reason: null,
  oracle_run_id: null,
  dataset_id: null,
  force_rmse: null,
  moment_rmse: null,
  ocp_solution_id: 100 + slot,
  features: [slot / 4],
  why: { code: (pick === null ? "batch-full" : "picked-top") as CandidateDetail["why"]["code"], text: "", nearest_pick: null, distance: null },
  has_curves: pick !== null,
});
const CANDIDATES = {
  iteration_index: 1,
  strategy: "ensemble-disagreement",
  batch: 2,
  n_candidates: 3,
  min_distance: 0,
  min_disagreement: null,
  top_score: 5,
  candidates: [candidate(0, null, 0.2), candidate(1, 1, 0.25), candidate(2, 0, 0.3)],
};
/** n samples of an oracle force ramp and a prediction off by `offset`, with a std if `std`. */
const curves = (n: number, offset: number, std: boolean) => {
  const row = (fx: number) => [fx, 0, fx / 2, 0, fx / 10, 0];
  const ts = Array.from({ length: n }, (_, i) => i / 10);
  return {
    iteration_index: 1,
    t: ts,
    q: ts.map((t) => [0.2 + t]),
    qd: ts.map(() => [1]),
    f_true: ts.map((t) => row(100 * t)),
    f_pred: ts.map((t) => row(100 * t + offset)),
    f_std: std ? ts.map(() => row(1)) : null,
  };
};
const trajectory = (slot: number) => ({ iteration_index: 1, t: [0, 1], q: [[0.2], [0.3]], qd: [[0], [0]], tau: [[0], [0]], duration: 1, phases: [], replay_phases: 1, replay_t_end: 1, solver: { status: "Solve_Succeeded", converged: true, iterations: 20 + slot, cost: 1.5, wall_time_s: 0.4, attempt: 1, initial_guess: "x" }, slot });
const point = (k: number, picks: MetricPoint["picks"] = []): MetricPoint => ({ iteration: k, status: "succeeded", force_rmse: 1, moment_rmse: 0.1, quarantined: false, picks });
const noop = () => undefined;

describe("the forces tab of a batch iteration", () => {
  it("lists the picks in pick order by their scenario values; a single pick has no choice", () => {
    expect(batchPicks(point(1, [{ pick: 1, slot: 1 }, { pick: 0, slot: 2 }])).map((p) => p.slot)).toEqual([2, 1]);
    expect(batchPicks(point(1, [{ pick: 0, slot: 0 }]))).toEqual([]);
    expect(batchPicks(point(1))).toEqual([]);
    expect(pickLabel({ pick: 1, slot: 1 }, CANDIDATES.candidates[1])).toBe("pick 2: initial.q.0 = 0.250, model.headrest_offset = 0.00200");
    expect(pickLabel({ pick: 1, slot: 1 }, undefined)).toBe("pick 2 (slot 1)");
  });

  it("shows pick 1 by default and the chosen pick's oracle force in the ensemble's ±2σ band", async () => {
    const { calls } = mockApi({
      "GET /campaigns/5/iterations/1/curves": curves(3, 1, true),
      "GET /campaigns/5/iterations/1/picks/1/curves": { ...curves(5, -2, true), pick: 1, slot: 1 },
      "GET /campaigns/5/iterations/1/candidates": CANDIDATES,
      "GET /campaigns/5/iterations/1/candidates/{slot}/trajectory": (url: URL) => trajectory(Number(url.pathname.split("/").at(-2))),
    });
    renderPage(<ForcesPanel campaignId={5} points={[point(1, [{ pick: 0, slot: 2 }, { pick: 1, slot: 1 }])]} iteration={1} setIteration={noop} overlay="" setOverlay={noop} />);
    const select = await screen.findByLabelText("picked trajectory shown");
    await waitFor(() => expect(within(select).getAllByRole("option").map((o) => o.textContent)).toEqual(["pick 1: initial.q.0 = 0.300, model.headrest_offset = 0.00200", "pick 2: initial.q.0 = 0.250, model.headrest_offset = 0.00200"]));
    expect(select).toHaveValue("0");
    const force = () => screen.getByTestId("force-plot");
    // pick 1: the iteration's own curves (3 samples), fx and fz each as band edges, oracle and mean
    await waitFor(() => expect(force()).toHaveAttribute("data-points", String(3 * 8)));
    expect(force()).toHaveAttribute("data-band", "2std");
    expect(await screen.findByTestId("pick-ocp")).toHaveTextContent("OCP of slot 2: converged, 22 IPOPT iterations");
    expect(calls.some((c) => c.path.includes("/picks/"))).toBe(false);

    await userEvent.selectOptions(select, "1");
    await waitFor(() => expect(force()).toHaveAttribute("data-points", String(5 * 8)));
    expect(screen.getByTestId("forces-panel")).toHaveAttribute("data-pick", "1");
    expect(force()).toHaveAttribute("data-band", "2std");
    expect(calls.some((c) => c.path === "/campaigns/5/iterations/1/picks/1/curves")).toBe(true);
    await waitFor(() => expect(screen.getByTestId("pick-ocp")).toHaveTextContent("OCP of slot 1: converged, 21 IPOPT iterations"));
    expect(screen.getByText(/this is pick 2's/)).toBeInTheDocument();

    await userEvent.selectOptions(select, "0");
    await waitFor(() => expect(force()).toHaveAttribute("data-points", String(3 * 8)));
  });

  it("the overlay box says which typed parts it left out and why, and keeps the rest", async () => {
    mockApi({ "GET /campaigns/5/iterations/{k}/curves": (url: URL) => ({ ...curves(3, 1, false), iteration: Number(url.pathname.split("/").at(-2)) }) });
    const set: string[] = [];
    const inheritedPoint = { ...point(1), inherited: true };
    function Harness() {
      const [overlay, setOverlay] = useState("");
      return <ForcesPanel campaignId={5} points={[inheritedPoint, point(2), point(3)]} iteration={3} setIteration={noop} overlay={overlay} setOverlay={(o) => (set.push(o), setOverlay(o))} />;
    }
    renderPage(<Harness />);
    await userEvent.type(await screen.findByLabelText("Overlay iterations"), "abc, 99, 1, 3-2, 7-9{Enter}");
    const problems = await screen.findByTestId("overlay-problems");
    expect(problems).toHaveTextContent('left out "abc": not an iteration number or range');
    expect(problems).toHaveTextContent("left out 99: no such iteration with oracle data");
    expect(problems).toHaveTextContent("left out 1: inherited from the source campaign");
    expect(problems).toHaveTextContent("left out 7-9: no iteration with oracle data in this range");
    expect(problems).toHaveTextContent("Overlay: 3-2: read as 2-3 (a range runs from low to high)");
    expect(set.at(-1)).toBe("2, 3");
    expect(screen.getByLabelText("Overlay iterations")).toHaveAttribute("aria-invalid", "true");
    await userEvent.click(screen.getByRole("button", { name: /^last 5/ }));
    expect(screen.queryByTestId("overlay-problems")).toBeNull();
  });

  it("a q = 1 iteration: no pick to choose, the iteration's curves as before", async () => {
    const { calls } = mockApi({ "GET /campaigns/5/iterations/2/curves": curves(3, 1, false) });
    renderPage(<ForcesPanel campaignId={5} points={[point(2)]} iteration={2} setIteration={noop} overlay="" setOverlay={noop} />);
    await waitFor(() => expect(screen.getByTestId("force-plot")).toHaveAttribute("data-points", String(3 * 4)));
    expect(screen.queryByTestId("pick-chooser")).toBeNull();
    expect(screen.getByTestId("forces-panel")).toHaveAttribute("data-pick", "");
    expect(calls.map((c) => c.path)).toEqual(["/campaigns/5/iterations/2/curves"]);
  });
});
