import { describe, expect, it } from "vitest";
import { clipPhases, phaseSpans } from "./TrajectoryPanel";

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
