/**
 * The x axis of the per-iteration plots: the iteration index, the cumulative oracle calls, or
 * the cumulative wall time, so that campaigns with different strategies and batch sizes compare
 * on one axis (the API's `cumulative_oracle_calls` and `cumulative_wall_time_s`).
 */
import type { MetricPoint } from "./metrics";

export type XAxis = "iteration" | "oracle" | "wall";

export const X_AXES: readonly (readonly [XAxis, string])[] = [
  ["iteration", "iteration"],
  ["oracle", "oracle calls"],
  ["wall", "wall time"],
] as const;

export function isXAxis(v: string | null | undefined): v is XAxis {
  return v === "iteration" || v === "oracle" || v === "wall";
}

export function xTitle(axis: XAxis): string {
  return axis === "oracle" ? "oracle calls (cumulative)" : axis === "wall" ? "wall time (cumulative) [s]" : "iteration k";
}

/** A point's x on `axis`; null where the series does not say (then the point is not drawn). */
export function xOf(p: MetricPoint, axis: XAxis): number | null {
  if (axis === "oracle") return p.cumulative_oracle_calls ?? null;
  if (axis === "wall") return p.cumulative_wall_time_s ?? null;
  return p.iteration;
}

/** The iteration of the point drawn at x on `axis` among `points` (a click), or null. */
export function iterationAt(points: MetricPoint[], axis: XAxis, x: number): number | null {
  if (axis === "iteration") return x;
  const hit = points.find((p) => {
    const v = xOf(p, axis);
    return v !== null && Math.abs(v - x) <= 1e-9 * Math.max(1, Math.abs(x));
  });
  return hit ? hit.iteration : null;
}
