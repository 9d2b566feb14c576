import { describe, expect, it } from "vitest";
import { everyKth, formatSelection, lastN, parseSelection } from "./selection";
import { iterationColor, sequentialColor } from "./colors";

const K200 = Array.from({ length: 200 }, (_, i) => i + 1);

describe("iteration selection", () => {
  it("reads ranges and lists", () => {
    expect(parseSelection("1-5, 8, 12-14", K200).iterations).toEqual([1, 2, 3, 4, 5, 8, 12, 13, 14]);
    expect(parseSelection(" 20-18 ;7 7", K200).iterations).toEqual([7, 18, 19, 20]);
    expect(parseSelection("", K200)).toEqual({ iterations: [], errors: [], notes: [] });
  });
  it("leaves out iterations without data and says which parts it could not read", () => {
    const avail = [1, 2, 4, 5];
    expect(parseSelection("1-5", avail).iterations).toEqual([1, 2, 4, 5]);
    const s = parseSelection("3, abc, 2", avail);
    expect(s.iterations).toEqual([2]);
    expect(s.errors).toEqual(["3: no such iteration with oracle data", '"abc": not an iteration number or range (e.g. 1-5, 8, 12-20)']);
  });
  it("names every part it leaves out: a fork's inherited iteration, a range without any; a reversed range is read, and said so", () => {
    const s = parseSelection("2, 7-9, 5-3, abc, 99", [4, 5, 6], [1, 2, 3]);
    expect(s.iterations).toEqual([4, 5]);
    expect(s.errors).toEqual([
      "2: inherited from the source campaign (its curves are on the source's page)",
      "7-9: no iteration with oracle data in this range",
      '"abc": not an iteration number or range (e.g. 1-5, 8, 12-20)',
      "99: no such iteration with oracle data",
    ]);
    expect(s.notes).toEqual(["5-3: read as 3-5 (a range runs from low to high)"]);
  });
  it("selects all 200 iterations of a paper-scale campaign with one range and writes it back compactly", () => {
    const s = parseSelection("1-200", K200);
    expect(s.iterations).toHaveLength(200);
    expect(formatSelection(s.iterations, K200)).toBe("1-200");
    expect(formatSelection([1, 2, 3, 4, 5, 8, 12, 13, 14, 20, 21], K200)).toBe("1-5, 8, 12-14, 20, 21");
  });
  it("has quick choices: last N and every k-th (always with the latest)", () => {
    expect(lastN(K200, 5)).toEqual([196, 197, 198, 199, 200]);
    expect(everyKth(K200, 50)).toEqual([50, 100, 150, 200]);
    expect(everyKth([1, 2, 3], 5)).toEqual([3]);
  });
});

describe("colour by iteration", () => {
  it("runs from dark to light along a sequential scale without repeating", () => {
    expect(sequentialColor(0)).toBe("#440154");
    expect(sequentialColor(1)).toBe("#fde725");
    const colors = K200.map((k) => iterationColor(k, 1, 200));
    expect(new Set(colors).size).toBeGreaterThan(190); // neighbours may round to the same colour, never cycle
    // luminance grows with the iteration: later iterations are lighter
    const lum = (c: string) => [1, 3, 5].map((i) => Number.parseInt(c.slice(i, i + 2), 16)).reduce((a, v, j) => a + v * [0.299, 0.587, 0.114][j], 0);
    for (let i = 10; i < colors.length; i += 10) expect(lum(colors[i])).toBeGreaterThan(lum(colors[i - 10]));
  });
  it("gives a single iteration the middle of the scale", () => {
    expect(iterationColor(7, 7, 7)).toBe(sequentialColor(0.5));
  });
});
