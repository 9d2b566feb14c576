import { describe, expect, it } from "vitest";
import { historyTraces } from "./ForcesPanel";

const zero = { fx: [], fy: [], fz: [], mx: [], my: [], mz: [] };

describe("historyTraces", () => {
  it("plots the largest indentation and the filtered slip velocity in mm and mm/s", () => {
    const traces = historyTraces({
      iteration: 3,
      t: [0, 0.1],
      q: [[0.2], [0.3]],
      truth: zero,
      predicted: zero,
      std: null,
      history: [
        [0.001, 0, -0.002],
        [0.0025, 0, 0.004],
      ],
    });
    expect(traces.map((t) => t.name)).toEqual(["largest indentation so far [mm]", "slip velocity z, low-pass [mm/s]"]);
    expect(traces[0]?.y).toEqual([1, 2.5]);
    expect(traces[1]?.y).toEqual([-2, 4]);
  });

  it("has nothing to plot for a model of the state alone", () => {
    expect(historyTraces({ iteration: 1, t: [0], q: [[0]], truth: zero, predicted: zero, std: null, history: null })).toEqual([]);
  });
});
