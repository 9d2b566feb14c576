/**
 * A campaign's per-iteration series: metrics (RMSE) and iteration statuses, fetched
 * incrementally with ?after= and merged into the cached series. Live updates (lib/live) tell
 * these queries when to refetch; ensureIteration makes sure an iteration the server has is in
 * the series, however the answers raced.
 */
import { useEffect, useMemo } from "react";
import { queryOptions, useQuery, type QueryClient } from "@tanstack/react-query";
import { client, unwrap } from "./client";
import { mergeMetrics, type MetricPoint } from "../lib/metrics";
import type { MetricsRow, ValidationSeries } from "./types";
import { keys } from "./keys";


/** A metrics row as the series keeps it: `inherited` rows belong to a fork's source campaigns. */
export type SeriesRow = MetricsRow & { campaign_id?: number; inherited?: boolean };

interface IterationState {
  iteration: number;
  status: string;
  error: string | null;
}
const FINAL_ITERATION = new Set(["succeeded", "failed", "cancelled"]);

function lastFinal<T>(rows: T[], index: (r: T) => number, final: (r: T) => boolean): number | undefined {
  let cursor: number | undefined;
  for (const r of rows) {
    if (!final(r)) break;
    cursor = index(r);
  }
  return cursor;
}

export function upsert<T>(known: T[], fresh: T[], key: (r: T) => number): T[] {
  if (!fresh.length) return known;
  const m = new Map(known.map((r) => [key(r), r]));
  for (const r of fresh) m.set(key(r), r);
  return [...m.values()].sort((a, b) => key(a) - key(b));
}

export function toPoints(metrics: SeriesRow[], iterations: IterationState[]): MetricPoint[] {
  const byIndex = new Map(iterations.map((it) => [it.iteration, it]));
  const points: MetricPoint[] = metrics.map((m) => ({
    iteration: m.iteration_index,
    status: byIndex.get(m.iteration_index)?.status ?? "succeeded",
    force_rmse: m.force_rmse ?? null,
    moment_rmse: m.moment_rmse ?? null,
    validation_force_rmse: m.validation_force_rmse ?? null,
    validation_moment_rmse: m.validation_moment_rmse ?? null,
    validation_calibration: m.validation_calibration ?? null,
    force_rmse_contact: m.force_rmse_contact ?? null,
    moment_rmse_contact: m.moment_rmse_contact ?? null,
    calibration: m.calibration ?? null,
    components: m.components ?? null,
    validation_components: m.validation_components ?? null,
    quarantined: false,
    inherited: Boolean(m.inherited),
    ocp_trusted: m.ocp_trusted ?? null,
    trust_reasons: m.ocp_trust?.reasons ?? [],
    cumulative_oracle_calls: m.cumulative_oracle_calls ?? null,
    cumulative_wall_time_s: m.cumulative_wall_time_s ?? null,
    picks: m.picks ?? [],
  }));
  const withMetrics = new Set(points.map((p) => p.iteration));
  for (const it of iterations) {
    if (withMetrics.has(it.iteration) || it.status !== "failed") continue;
    points.push({ iteration: it.iteration, status: "failed", force_rmse: null, moment_rmse: null, quarantined: /quarantin/i.test(it.error ?? ""), inherited: false });
  }
  return mergeMetrics(undefined, points);
}

/** The `after` cursor of the next metrics fetch: the last of the campaign's own iterations known. */
export function metricsCursor(rows: SeriesRow[]): number | undefined {
  const own = rows.filter((r) => !r.inherited);
  return own.length ? own[own.length - 1].iteration_index : undefined;
}

/**
 * Per-iteration metrics, fetched incrementally: each fetch asks only for iterations after the
 * last one known. A fork's first fetch also asks for the inherited rows of its source chain.
 */
export function rawMetricsQuery(id: number, inherited = false) {
  // a fork's page keeps the series with its source's rows apart from the own-only series (sparklines)
  const key = [...keys.metrics(id), inherited ? "with-source" : "own"] as const;
  return queryOptions({
    queryKey: key,
    // `signal`: a fetch that an event superseded is aborted, not left to transfer what the next one will
    queryFn: async ({ client: qc, signal }): Promise<SeriesRow[]> => {
      const known = qc.getQueryData<SeriesRow[]>(key) ?? [];
      const after = metricsCursor(known);
      const query = inherited && !known.length ? { inherited: true } : { after };
      const fresh = unwrap(await client.GET("/api/v1/campaigns/{campaign_id}/metrics", { params: { path: { campaign_id: id }, query }, signal })) as SeriesRow[];
      return upsert(known, fresh, (r) => r.iteration_index);
    },
  });
}

/** Iteration statuses (to mark failed and quarantined iterations), fetched after the last final one. */
export function iterationStatesQuery(id: number) {
  const key = keys.iterationStates(id);
  return queryOptions({
    queryKey: key,
    queryFn: async ({ client: qc, signal }): Promise<IterationState[]> => {
      const known = qc.getQueryData<IterationState[]>(key) ?? [];
      const after = lastFinal(known, (r) => r.iteration, (r) => FINAL_ITERATION.has(r.status));
      const fresh = unwrap(await client.GET("/api/v1/campaigns/{campaign_id}/iterations", { params: { path: { campaign_id: id }, query: { after } }, signal }));
      return upsert(
        known,
        fresh.map((it) => ({ iteration: it.index, status: it.status, error: it.error ?? null })),
        (r) => r.iteration,
      );
    },
  });
}

/** RMSE series without failure marks (sparklines, comparisons). */
export function metricsQuery(id: number) {
  return queryOptions({ ...rawMetricsQuery(id), select: (rows: SeriesRow[]) => toPoints(rows, []) });
}

const ENSURE_DELAYS_MS = [0, 300, 700, 1500, 3000, 5000];

/**
 * Refetch the metrics until the series holds iteration k (an answer may predate the commit
 * that wrote it, or come from a short server-side reuse window); gives up after about 10 s.
 * Concurrent calls for the same campaign share one loop.
 */
const ensuring = new Map<string, Promise<boolean>>();
/** Whether some cached series of the campaign is loaded (a catch-up fetch is only needed then). */
export function hasSeries(qc: QueryClient, id: number): boolean {
  return qc.getQueriesData<SeriesRow[]>({ queryKey: keys.metrics(id) }).some(([, d]) => d !== undefined);
}
export function ensureIteration(qc: QueryClient, id: number, k: number): Promise<boolean> {
  // every loaded series of the campaign (own, with its source) holds k
  const has = () => {
    const loaded = qc.getQueriesData<SeriesRow[]>({ queryKey: keys.metrics(id) }).filter(([, d]) => d !== undefined);
    return loaded.length > 0 && loaded.every(([, d]) => d!.some((r) => r.iteration_index >= k));
  };
  if (has()) return Promise.resolve(true);
  const tag = `${id}:${k}`;
  const running = ensuring.get(tag);
  if (running) return running;
  const loop = (async () => {
    for (const delay of ENSURE_DELAYS_MS) {
      if (delay) await new Promise((r) => setTimeout(r, delay));
      if (!qc.getQueryCache().findAll({ queryKey: keys.metrics(id) }).length) return false; // nobody shows it any more
      await qc.refetchQueries({ queryKey: keys.metrics(id) });
      if (has()) return true;
    }
    return false;
  })().finally(() => ensuring.delete(tag));
  ensuring.set(tag, loop);
  return loop;
}

/**
 * The campaign page's series: metrics as soon as they arrive, failure marks when the statuses
 * do. `latest` is the iteration of the campaign's latest metrics as the detail reports it: the
 * series is refetched until it holds it, so the plot never lags the header.
 */
/**
 * The held-out validation suite and each model version's generalisation error: fetched whole
 * (a few numbers per model version), apart from the incremental metrics series, because an
 * earlier model's error arrives when the suite's replays finish, after its iteration.
 */
export function validationQuery(id: number) {
  return queryOptions({
    queryKey: keys.validation(id),
    queryFn: async ({ signal }): Promise<ValidationSeries> =>
      unwrap(await client.GET("/api/v1/campaigns/{campaign_id}/validation", { params: { path: { campaign_id: id } }, signal })),
  });
}

/** The metrics points with each model version's generalisation error from the validation series. */
export function withValidation(points: MetricPoint[], validation: ValidationSeries | undefined): MetricPoint[] {
  if (!validation?.points.length) return points;
  const byK = new Map(validation.points.map((v) => [v.iteration_index, v]));
  return points.map((p) => {
    const v = p.inherited ? undefined : byK.get(p.iteration);
    return v ? { ...p, validation_force_rmse: v.force_rmse, validation_moment_rmse: v.moment_rmse, validation_calibration: v.calibration ?? null, validation_components: v.components } : p;
  });
}

export function useMetrics(id: number, { inherited = false, latest = null, qc }: { inherited?: boolean; latest?: number | null; qc: QueryClient }) {
  const metrics = useQuery(rawMetricsQuery(id, inherited));
  const states = useQuery(iterationStatesQuery(id));
  const validation = useQuery(validationQuery(id));
  const loaded = metrics.isSuccess;
  useEffect(() => {
    if (loaded && latest !== null) void ensureIteration(qc, id, latest);
  }, [qc, id, latest, loaded]);
  const data = useMemo(
    () => (metrics.data ? withValidation(toPoints(metrics.data, states.data ?? []), validation.data) : undefined),
    [metrics.data, states.data, validation.data],
  );
  const auxLaw = validation.data?.aux_law ?? null;
  const bestPossible = validation.data?.best_possible ?? null;
  return { data, auxLaw, bestPossible, isPending: metrics.isPending, isError: metrics.isError, error: metrics.error, refetch: metrics.refetch };
}
