import { describe, expect, it } from "vitest";
import { logTickLabel, logTicks, traceValues } from "./logTicks";

describe("log axis ticks", () => {
  it("are 1-2-5 per decade over a few decades, each labelled with its whole value", () => {
    const t = logTicks([0.03, 0.2, 4])!;
    expect(t.tickvals).toEqual([0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1, 2, 5, 10, 20, 50]);
    expect(t.ticktext).toEqual(["0.01", "0.02", "0.05", "0.1", "0.2", "0.5", "1", "2", "5", "10", "20", "50"]);
    // no bare digits in between: every label names its value (unlike Plotly's "D1"/"D2" minor labels)
    t.tickvals.forEach((v, i) => expect(Number(t.ticktext[i])).toBe(v));
  });

  it("are denser within one decade and only decades over many", () => {
    expect(logTicks([0.31, 0.6])!.tickvals).toEqual([0.1, 0.2, 0.3, 0.5, 0.7, 1, 2, 3, 5, 7]);
    const wide = logTicks([1e-6, 1e2])!;
    expect(wide.tickvals).toEqual([1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1, 10, 100, 1000]);
    expect(wide.ticktext).toEqual(["10⁻⁶", "10⁻⁵", "10⁻⁴", "0.001", "0.01", "0.1", "1", "10", "100", "1000"]);
  });

  it("write tiny and huge values as powers of ten", () => {
    expect(logTickLabel(2, -5)).toBe("2×10⁻⁵");
    expect(logTickLabel(1, 6)).toBe("10⁶");
    expect(logTickLabel(5, 3)).toBe("5000");
  });

  it("ignore values a log axis cannot show, and need at least one", () => {
    expect(logTicks([0, -1, null, NaN, Infinity])).toBeNull();
    expect(logTicks([0, 2, null])!.tickvals).toContain(2);
    expect([...traceValues([{ y: [1, 2] }, {}, { y: new Float64Array([3]) }])]).toEqual([1, 2, 3]);
  });
});
