import { describe, expect, it } from "vitest";
import { sparklinePath } from "./Sparkline";

describe("sparkline", () => {
  it("maps a decreasing log series from the top left to the bottom right", () => {
    const d = sparklinePath([1, 0.1, 0.01], 100, 20);
    expect(d).toBe("M0.0,0.0 L50.0,10.0 L100.0,20.0");
  });
  it("drops values a log axis cannot show", () => {
    expect(sparklinePath([0, -1, NaN], 100, 20)).toBe("");
    expect(sparklinePath([0, 1, 10], 100, 20)).toBe("M0.0,20.0 L100.0,0.0");
  });
});
