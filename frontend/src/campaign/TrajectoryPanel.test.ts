import { describe, expect, it } from "vitest";
import { forceOnGrid, clipPhases, phaseShapes, phaseSpans, replayMarks, replayText, scenarioText, solverRows, trajectoryPhases } from "./TrajectoryPanel";

describe("phases of a trajectory", () => {
  const spans = phaseSpans([{ name: "approach", duration: 0.2 }, { name: "rest", duration: 1 }]);

  it("are consecutive spans of the durations", () => {
    expect(spans.map((p) => [p.t_start, p.t_end])).toEqual([
      [0, 0.2],
      [0.2, 1.2],
    ]);
  });

  it("are clipped to the time range of the curves", () => {
    // only the first phase replayed: the second one, touching at t = 0.2, is dropped
    expect(clipPhases(spans, [0, 0.1, 0.2])).toEqual([{ name: "approach", t_start: 0, t_end: 0.2 }]);
    // the replay ends inside the second phase: it is cut at the end of the curves
    expect(clipPhases(spans, [0, 0.5])).toEqual([
      { name: "approach", t_start: 0, t_end: 0.2 },
      { name: "rest", t_start: 0.2, t_end: 0.5 },
    ]);
    expect(clipPhases(spans, [])).toEqual(spans);
  });
});

describe("the whole OCP trajectory", () => {
  const data = {
    phases: [
      { index: 0, name: "approach", duration: 1, t_start: 0, t_end: 1, replayed: true },
      { index: 1, name: "", duration: 1, t_start: 1, t_end: 2, replayed: false },
    ],
    replay_t_end: 1,
    replay_dt: 0.0025,
  };

  it("names every phase (unnamed ones by their number) and keeps which were replayed", () => {
    expect(trajectoryPhases(data)).toEqual([
      { name: "approach", t_start: 0, t_end: 1, replayed: true },
      { name: "phase 2", t_start: 1, t_end: 2, replayed: false },
    ]);
  });

  it("shades each phase over the whole plot height, labelled", () => {
    const shapes = phaseShapes(trajectoryPhases(data));
    expect(shapes.map((s) => [s.x0, s.x1, s.y0, s.y1, s.yref])).toEqual([
      [0, 1, 0, 1, "paper"],
      [1, 2, 0, 1, "paper"],
    ]);
    expect(shapes.map((s) => (s as { label?: { text?: string } }).label?.text)).toEqual(["approach", "phase 2"]);
    expect(shapes[0].fillcolor).not.toEqual(shapes[1].fillcolor);
  });

  it("brackets exactly the replayed span and labels it", () => {
    const { shapes, annotations } = replayMarks(0, 1);
    const xs = shapes.flatMap((s) => [s.x0, s.x1]) as number[];
    expect(Math.min(...xs)).toBe(0);
    expect(Math.max(...xs)).toBe(1);
    expect(shapes).toHaveLength(3);
    expect(annotations).toHaveLength(1);
    expect(annotations[0].x).toBe(0.5);
    expect(annotations[0].text).toBe("replayed by the oracle");
  });

  it("says what the oracle replayed and on which grid", () => {
    expect(replayText(data)).toBe("The oracle replayed approach (t ≤ 1.00 s, resampled every 2.50 ms). The task's later phase is not replayed.");
    const all = { ...data, phases: data.phases.map((p) => ({ ...p, replayed: true })), replay_t_end: 2, replay_dt: null };
    expect(replayText(all)).toBe("The oracle replayed approach, phase 2 (t ≤ 2.00 s, on the OCP grid).");
  });

  it("summarizes the solve, failed or not", () => {
    const ok = solverRows({ status: "Solve_Succeeded", converged: true, iterations: 12, cost: 0.123456, wall_time_s: 0.25, attempt: 1, initial_guess: "previous", message: "" });
    expect(Object.fromEntries(ok)).toEqual({
      Status: "Solve_Succeeded",
      Converged: "yes",
      "IPOPT iterations": "12",
      Cost: "0.1235",
      "Wall time": "0.250 s",
      Attempt: "1 (initial guess: previous)",
    });
    const failed = Object.fromEntries(solverRows({ status: "Maximum_Iterations_Exceeded", converged: false, iterations: null, cost: null, wall_time_s: null, attempt: 2, initial_guess: "default", message: "x" }));
    expect([failed.Converged, failed["IPOPT iterations"], failed.Cost, failed["Wall time"]]).toEqual(["no", "—", "—", "—"]);
  });
});

describe("the scenario an iteration solved", () => {
  it("lists the drawn values; none for the task as written", () => {
    expect(scenarioText({ seed: 7, iteration: 2, slot: 0, values: { "initial.q.0": 0.2345678, "model.headrest_offset": -0.0031 } })).toBe(
      "Scenario (seed 7, draw 2): initial.q.0 = 0.2346, model.headrest_offset = -0.003100",
    );
    expect(scenarioText(null)).toBeNull();
    expect(scenarioText(undefined)).toBeNull();
    expect(scenarioText({ seed: 7, iteration: 2, slot: 0, values: {} })).toBeNull();
  });
});

describe("the oracle's force on the OCP grid (the playback's arrow)", () => {
  it("the replayed sample at or before each node within the replayed part, none after it", () => {
    const curves = { t: [0, 0.05, 0.1, 0.15, 0.2], truth: { fx: [0, 0, 10, 20, 5], fy: [], fz: [0, 0, 1, 2, 0.5], mx: [], my: [], mz: [] } };
    const f = forceOnGrid([0, 0.1, 0.12, 0.2, 0.3, 0.4], 0.2, curves)!;
    expect(f.fx).toEqual([0, 10, 10, 5, null, null]);
    expect(f.fz).toEqual([0, 1, 1, 0.5, null, null]);
    expect(forceOnGrid([0, 0.1], 0.2, undefined)).toBeNull();
  });
});
