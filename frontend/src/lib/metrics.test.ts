import { describe, expect, it } from "vitest";
import { afterCursor, mergeMetrics, type MetricPoint } from "./metrics";

const point = (iteration: number, status = "succeeded", force = 1 / (iteration + 1)): MetricPoint => ({
  iteration,
  status,
  force_rmse: force,
  moment_rmse: force / 10,
  quarantined: false,
});

describe("incremental metrics", () => {
  it("appends new iterations in order", () => {
    const merged = mergeMetrics([point(0), point(1)], [point(3), point(2)]);
    expect(merged.map((p) => p.iteration)).toEqual([0, 1, 2, 3]);
  });

  it("replaces an iteration that was still running with its final row", () => {
    const merged = mergeMetrics([point(0), point(1, "running", NaN)], [point(1, "succeeded", 0.5)]);
    expect(merged).toHaveLength(2);
    expect(merged[1].status).toBe("succeeded");
    expect(merged[1].force_rmse).toBe(0.5);
  });

  it("polls after the last final iteration, so a running one is fetched again", () => {
    expect(afterCursor(undefined)).toBeUndefined();
    expect(afterCursor([point(0), point(1), point(2, "running")])).toBe(1);
    expect(afterCursor([point(0), point(1, "failed")])).toBe(1);
  });

  it("keeps the known array when nothing is new (no re-render churn)", () => {
    const known = [point(0)];
    expect(mergeMetrics(known, [])).toBe(known);
  });
});
