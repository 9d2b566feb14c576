/** Per-iteration metrics as the dashboard keeps them: fetched incrementally with ?after=k. */
export interface MetricPoint {
  iteration: number;
  status: string;
  /** RMSE of the force error vector, sqrt(mean |F_pred - F_true|^2) [N] (docs/concepts.md) */
  force_rmse: number | null;
  /** RMSE of the moment error vector [N m] */
  moment_rmse: number | null;
  /** model k's generalisation error on the held-out validation suite (null until evaluated) */
  validation_force_rmse?: number | null;
  validation_moment_rmse?: number | null;
  /** the ensemble's calibration on the held-out validation suite (null: K = 1, not evaluated, or not recorded) */
  validation_calibration?: number | null;
  /** the same over the samples in contact (|F_true| > 0); null if none or not given */
  force_rmse_contact?: number | null;
  moment_rmse_contact?: number | null;
  /** the ensemble's calibration: fraction of oracle values inside mean +- 2 std (null for K = 1) */
  calibration?: number | null;
  /** the oracle result of this iteration failed its quality gate */
  quarantined: boolean;
  /** a fork's iteration from its source campaign (shown greyed) */
  inherited?: boolean;
  /** false: the iteration's OCP solution relies on force outside the data; null/undefined: not assessed */
  ocp_trusted?: boolean | null;
  /** why it is not trusted (ghost force, ensemble disagreement in contact) */
  trust_reasons?: string[];
  /** oracle runs of iterations 1..k (a fork's sources' included): an x axis across strategies */
  cumulative_oracle_calls?: number | null;
  /** wall time of iterations 1..k until model k was evaluated [s] */
  cumulative_wall_time_s?: number | null;
  /** RMSE per component (fx .. mz) and in contact (fx_contact .. mz_contact), in the loop and on the suite */
  components?: Record<string, number | null> | null;
  validation_components?: Record<string, number | null> | null;
  /** a batch iteration's in-loop RMSE per picked trajectory (the point's RMSE is their mean) */
  picks?: { pick: number; slot: number; force_rmse?: number | null; moment_rmse?: number | null }[];
}

/** Merge newly fetched points into the known series (by iteration, newer wins), sorted. */
export function mergeMetrics(known: MetricPoint[] | undefined, fresh: MetricPoint[]): MetricPoint[] {
  if (!known?.length) return [...fresh].sort((a, b) => a.iteration - b.iteration);
  if (!fresh.length) return known;
  const byIteration = new Map(known.map((p) => [p.iteration, p]));
  for (const p of fresh) byIteration.set(p.iteration, p);
  return [...byIteration.values()].sort((a, b) => a.iteration - b.iteration);
}

/** The `after` cursor for the next poll: the last iteration whose metrics are final. */
export function afterCursor(known: MetricPoint[] | undefined): number | undefined {
  if (!known?.length) return undefined;
  let cursor: number | undefined;
  for (const p of known) {
    if (p.status === "running" || p.status === "pending") break;
    cursor = p.iteration;
  }
  return cursor;
}

export function isMarked(p: MetricPoint): boolean {
  return p.quarantined || p.status === "failed";
}

/** What the RMSE plot shows: the force and moment error vectors, or one wrench component. */
export const RMSE_QUANTITIES = [
  ["vector", "force & moment"],
  ["fx", "fx"],
  ["fz", "fz"],
  ["my", "my"],
  ["fy", "fy"],
  ["mx", "mx"],
  ["mz", "mz"],
] as const;
export type RmseQuantity = (typeof RMSE_QUANTITIES)[number][0];

export function isRmseQuantity(v: string): v is RmseQuantity {
  return RMSE_QUANTITIES.some(([key]) => key === v);
}

/** The unit of a component's RMSE: N for a force component, N m for a moment component. */
export function componentUnit(c: string): string {
  return c.startsWith("f") ? "N" : "N m";
}

/** A reference model's error on the held-out suite (the auxiliary law's): a horizontal line on the RMSE plot. */
export interface SuiteReference {
  force_rmse: number;
  moment_rmse: number;
  components: Record<string, number | null>;
}

/**
 * The suite's best-possible line: per oracle budget, the suite error of a model trained from
 * scratch on that many oracle replays of motions spread over the suite's range (FE data only).
 */
export interface BestPossible {
  points: (SuiteReference & { budget: number })[];
  replays: number;
}
