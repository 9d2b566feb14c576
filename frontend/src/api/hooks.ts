/**
 * Every API call the UI makes, as TanStack Query hooks returning view types. This is the
 * only module that knows routes and response shapes; pages only see the types below.
 */
import { useMemo } from "react";
import { keepPreviousData, queryOptions, useMutation, useQuery, useQueryClient } from "@tanstack/react-query";
import { ApiError, fieldErrors, type FieldError } from "./errors";
import { storedToken } from "./auth";
import { mergeMetrics, type MetricPoint } from "../lib/metrics";
import type { JsonSchema } from "../components/SchemaForm";
import { client, unwrap } from "./client";
import type { components } from "./schema";
export { downloadFile } from "./client";

type Schemas = components["schemas"];

const API = "/api/v1";
export const POLL_MS = 2000;

// ------------------------------------------------------------------ view types
export interface Me {
  id: number;
  username: string;
  role: string;
}
export interface TokenRow {
  id: number;
  name: string;
  created_at: string | null;
  last_used_at: string | null;
  expires_at: string | null;
  revoked: boolean;
}
export interface CampaignRow {
  id: number;
  name: string;
  status: string;
  owner: string | null;
  task: string | null;
  oracle: string | null;
  iteration: number;
  max_iterations: number | null;
  force_rmse: number | null;
  moment_rmse: number | null;
  force_history: number[];
  moment_history: number[];
  started_at: string | null;
  eta_s: number | null;
}
export interface CampaignDetail extends CampaignRow {
  task_id: number | null;
  oracle_id: number | null;
  current_step: string | null;
  finished_at: string | null;
  stop_reason: string | null;
  error: string | null;
  source_campaign_id: number | null;
  source_iteration: number | null;
  /** the editable settings (preliminary, stopping, policies, settings) */
  config: Record<string, Record<string, unknown>> | null;
  task_version?: number;
  can_edit?: boolean;
  iterations_failed?: number;
}
export interface Phase {
  name?: string;
  t_start: number;
  t_end: number;
}
export type Wrench = Partial<Record<"fx" | "fy" | "fz" | "mx" | "my" | "mz", number[]>>;
export interface IterationCurves {
  iteration: number;
  t: number[];
  t_tau?: number[];
  q: number[][];
  qd: number[][];
  tau: number[][];
  phases: Phase[];
  force_t: number[];
  truth: Wrench | null;
  predicted: Wrench | null;
}
export interface JobRow {
  id: number;
  iteration: number;
  step: string;
  status: string;
  worker: string | null;
  attempts: number;
  started_at: string | null;
  duration_s: number | null;
  error: string | null;
}
export interface PoolVersionRow {
  id: number;
  version: number;
  parent_version: number | null;
  n_datasets: number;
  n_samples: number;
  created_at: string | null;
  parquet_url: string;
  csv_url: string;
}
export interface ModelVersionRow {
  id: number;
  version: number;
  pool_version: number | null;
  parent_version: number | null;
  test_force_rmse: number | null;
  test_moment_rmse: number | null;
  epochs: number | null;
  artifact_url: string;
}
export type TaskSpecDraft = Record<string, unknown> & { phases?: unknown[]; model?: Record<string, unknown> };
export interface TaskRow {
  id: number;
  /** id of the latest version (what a campaign references) */
  version_id: number;
  name: string;
  description?: string;
  version?: number;
  n_phases?: number;
  owner?: string | null;
  updated_at?: string | null;
  spec: TaskSpecDraft;
}
export interface TaskPreset {
  name: string;
  spec: TaskSpecDraft;
}
export interface OracleRow {
  id: number;
  version_id: number;
  name: string;
  description?: string;
  type: string;
  version?: number;
  owner?: string | null;
  updated_at?: string | null;
  params: Record<string, unknown>;
}
export interface SurrogateConfigRow {
  id: number;
  version_id: number;
  name: string;
  version: number;
}
export interface OracleType {
  name: string;
  kind: string;
  available: boolean;
  description: string;
  schema: JsonSchema;
}
export type Preview = Schemas["PreviewOut"];
export type TaskPreviewResult = Schemas["TaskPreviewResult"];
export type OraclePreviewResult = Schemas["OraclePreviewResult"];

// ------------------------------------------------------------------ transport
type Query = Record<string, string | number | boolean | undefined | null>;

export async function api<T>(method: string, path: string, opts: { query?: Query; body?: unknown; token?: string } = {}): Promise<T> {
  const url = new URL(API + path, window.location.origin);
  for (const [k, v] of Object.entries(opts.query ?? {})) if (v !== undefined && v !== null && v !== "") url.searchParams.set(k, String(v));
  const token = opts.token ?? storedToken();
  const headers: Record<string, string> = { Accept: "application/json" };
  if (token) headers.Authorization = `Bearer ${token}`;
  if (opts.body !== undefined) headers["Content-Type"] = "application/json";
  let response: Response;
  try {
    response = await fetch(url, { method, headers, body: opts.body === undefined ? undefined : JSON.stringify(opts.body) });
  } catch {
    throw new ApiError(0, null);
  }
  if (response.status === 401 && path !== "/auth/login") window.dispatchEvent(new Event("alcove:unauthorized"));
  const text = await response.text();
  let body: unknown = null;
  if (text) {
    try {
      body = JSON.parse(text);
    } catch {
      body = { detail: text.slice(0, 200) };
    }
  }
  if (!response.ok) throw new ApiError(response.status, body);
  return body as T;
}

// ------------------------------------------------------------------ auth
export async function login(email: string, password: string): Promise<string> {
  const r = unwrap(await client.POST("/api/v1/auth/login", { body: { email, password } }));
  return r.access_token;
}

export function useMe() {
  return useQuery({
    queryKey: ["me"],
    queryFn: async (): Promise<Me> => {
      const u = unwrap(await client.GET("/api/v1/me"));
      return { id: u.id, username: u.display_name || u.email, role: u.role };
    },
    staleTime: 60_000,
  });
}

export function useTokens() {
  return useQuery({
    queryKey: ["tokens"],
    queryFn: async (): Promise<TokenRow[]> => unwrap(await client.GET("/api/v1/me/tokens")),
  });
}
export function useCreateToken() {
  const qc = useQueryClient();
  return useMutation({
    mutationFn: async (body: { name: string }) => unwrap(await client.POST("/api/v1/me/tokens", { body })),
    onSuccess: () => qc.invalidateQueries({ queryKey: ["tokens"] }),
  });
}
export function useRevokeToken() {
  const qc = useQueryClient();
  return useMutation({
    mutationFn: async (id: number) => {
      const r = await client.DELETE("/api/v1/me/tokens/{token_id}", { params: { path: { token_id: id } } });
      if (!r.response.ok) unwrap(r);
    },
    onSuccess: () => qc.invalidateQueries({ queryKey: ["tokens"] }),
  });
}

// ------------------------------------------------------------------ campaigns
const LIVE = new Set(["queued", "running", "pausing", "cancelling"]);
export function isLive(status: string): boolean {
  return LIVE.has(status);
}

function campaignRow(c: Schemas["CampaignSummary"]): CampaignRow {
  return {
    id: c.id,
    name: c.name,
    status: c.status,
    owner: c.owner,
    task: `${c.task} v${c.task_version}`,
    oracle: `${c.oracle} (${c.oracle_type})`,
    iteration: c.current_iteration,
    max_iterations: c.max_iterations ?? null,
    force_rmse: c.force_rmse ?? null,
    moment_rmse: c.moment_rmse ?? null,
    force_history: [],
    moment_history: [],
    started_at: c.started_at ?? null,
    eta_s: c.eta_s ?? null,
  };
}

export function useCampaigns(filters: { status?: string }) {
  return useQuery({
    queryKey: ["campaigns", filters],
    queryFn: async () => {
      const status = (filters.status || undefined) as Schemas["CampaignStatus"] | undefined;
      return unwrap(await client.GET("/api/v1/campaigns", { params: { query: { status, limit: 500 } } })).map(campaignRow);
    },
    placeholderData: keepPreviousData,
    refetchInterval: (q) => (q.state.data?.some((c) => isLive(c.status)) ? POLL_MS * 2 : false),
  });
}

function campaignDetail(c: Schemas["CampaignOut"]): CampaignDetail {
  const r = c.campaign;
  const config = c.config as unknown as Record<string, Record<string, unknown>>;
  return {
    id: c.id,
    name: r.name,
    status: r.status,
    owner: c.owner,
    task: null,
    task_id: c.task_id,
    task_version: c.task_version,
    oracle: null,
    oracle_id: c.oracle_id,
    iteration: r.current_iteration,
    max_iterations: (config?.stopping?.max_iterations as number | null | undefined) ?? null,
    force_rmse: c.latest_metrics?.force_rmse ?? null,
    moment_rmse: c.latest_metrics?.moment_rmse ?? null,
    force_history: [],
    moment_history: [],
    started_at: r.started_at ?? null,
    eta_s: c.eta_s ?? null,
    current_step: r.current_step ?? null,
    finished_at: r.finished_at ?? null,
    stop_reason: r.stop_reason ?? null,
    error: r.error ?? null,
    source_campaign_id: r.source_campaign_id ?? null,
    source_iteration: r.source_iteration ?? null,
    config,
    can_edit: c.can_edit,
    iterations_failed: c.iterations_failed,
  };
}

export function useCampaign(id: number) {
  return useQuery({
    queryKey: ["campaign", id],
    queryFn: async () => campaignDetail(unwrap(await client.GET("/api/v1/campaigns/{campaign_id}", { params: { path: { campaign_id: id } } }))),
    refetchInterval: (q) => (q.state.data && isLive(q.state.data.status) ? POLL_MS : false),
  });
}

/** Iteration statuses (to mark failed and quarantined iterations), fetched incrementally. */
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

function upsert<T>(known: T[], fresh: T[], key: (r: T) => number): T[] {
  if (!fresh.length) return known;
  const m = new Map(known.map((r) => [key(r), r]));
  for (const r of fresh) m.set(key(r), r);
  return [...m.values()].sort((a, b) => key(a) - key(b));
}

export function toPoints(metrics: Schemas["MetricsRead"][], iterations: IterationState[]): MetricPoint[] {
  const byIndex = new Map(iterations.map((it) => [it.iteration, it]));
  const points: MetricPoint[] = metrics.map((m) => ({
    iteration: m.iteration_index,
    status: byIndex.get(m.iteration_index)?.status ?? "succeeded",
    force_rmse: m.force_rmse ?? null,
    moment_rmse: m.moment_rmse ?? null,
    quarantined: false,
  }));
  const withMetrics = new Set(points.map((p) => p.iteration));
  for (const it of iterations) {
    if (withMetrics.has(it.iteration) || it.status !== "failed") continue;
    points.push({ iteration: it.iteration, status: "failed", force_rmse: null, moment_rmse: null, quarantined: /quarantin/i.test(it.error ?? "") });
  }
  return mergeMetrics(undefined, points);
}

/** Per-iteration metrics, polled incrementally: each poll asks only for iterations after the last one known. */
export function rawMetricsQuery(id: number, live = false) {
  const key = ["metrics", id] as const;
  return queryOptions({
    queryKey: key,
    queryFn: async ({ client: qc }): Promise<Schemas["MetricsRead"][]> => {
      const known = qc.getQueryData<Schemas["MetricsRead"][]>(key) ?? [];
      const after = known.length ? known[known.length - 1].iteration_index : undefined;
      const fresh = unwrap(await client.GET("/api/v1/campaigns/{campaign_id}/metrics", { params: { path: { campaign_id: id }, query: { after } } }));
      return upsert(known, fresh, (r) => r.iteration_index);
    },
    refetchInterval: live ? POLL_MS : false,
  });
}

/** Iteration statuses (to mark failed and quarantined iterations), polled after the last final one. */
export function iterationStatesQuery(id: number, live = false) {
  const key = ["iteration-states", id] as const;
  return queryOptions({
    queryKey: key,
    queryFn: async ({ client: qc }): Promise<IterationState[]> => {
      const known = qc.getQueryData<IterationState[]>(key) ?? [];
      const after = lastFinal(known, (r) => r.iteration, (r) => FINAL_ITERATION.has(r.status));
      const fresh = unwrap(await client.GET("/api/v1/campaigns/{campaign_id}/iterations", { params: { path: { campaign_id: id }, query: { after } } }));
      return upsert(
        known,
        fresh.map((it) => ({ iteration: it.index, status: it.status, error: it.error ?? null })),
        (r) => r.iteration,
      );
    },
    refetchInterval: live ? POLL_MS : false,
  });
}

/** RMSE series without failure marks (sparklines, comparisons). */
export function metricsQuery(id: number, live = false) {
  return queryOptions({ ...rawMetricsQuery(id, live), select: (rows: Schemas["MetricsRead"][]) => toPoints(rows, []) });
}

/** The campaign page's series: metrics as soon as they arrive, failure marks when the statuses do. */
export function useMetrics(id: number, live: boolean) {
  const metrics = useQuery(rawMetricsQuery(id, live));
  const states = useQuery(iterationStatesQuery(id, live));
  const data = useMemo(() => (metrics.data ? toPoints(metrics.data, states.data ?? []) : undefined), [metrics.data, states.data]);
  return { data, isPending: metrics.isPending, isError: metrics.isError, error: metrics.error, refetch: metrics.refetch };
}

/** Rows (time) x columns -> one array per column. */
export function columns(rows: number[][]): number[][] {
  if (!rows.length) return [];
  return rows[0].map((_, j) => rows.map((r) => r[j]));
}
const WRENCH = ["fx", "fy", "fz", "mx", "my", "mz"] as const;

export type IterationTrajectory = Schemas["IterationTrajectory"];
export interface WholeTrajectory extends Omit<IterationTrajectory, "q" | "qd" | "tau"> {
  /** one array per joint */
  q: number[][];
  qd: number[][];
  tau: number[][];
}

/** Iteration k's whole OCP solution (every phase, on the OCP grid); immutable per attempt. */
export function trajectoryQuery(id: number, k: number) {
  return queryOptions({
    queryKey: ["trajectory", id, k],
    queryFn: async (): Promise<WholeTrajectory> => {
      const r = unwrap(await client.GET("/api/v1/campaigns/{campaign_id}/iterations/{iteration}/trajectory", { params: { path: { campaign_id: id, iteration: k } } }));
      return { ...r, q: columns(r.q), qd: columns(r.qd), tau: columns(r.tau) };
    },
    staleTime: 60_000,
  });
}

export function iterationQuery(id: number, k: number) {
  return queryOptions({
    queryKey: ["iteration", id, k],
    queryFn: async (): Promise<IterationCurves> => {
      const c = unwrap(await client.GET("/api/v1/campaigns/{campaign_id}/iterations/{iteration}/curves", { params: { path: { campaign_id: id, iteration: k } } }));
      const truth = columns(c.f_true);
      const pred = columns(c.f_pred);
      return {
        iteration: c.iteration_index,
        t: c.t,
        q: columns(c.q),
        qd: columns(c.qd),
        tau: c.tau ? columns(c.tau) : [],
        phases: [],
        force_t: c.t,
        truth: Object.fromEntries(WRENCH.map((w, j) => [w, truth[j] ?? []])),
        predicted: Object.fromEntries(WRENCH.map((w, j) => [w, pred[j] ?? []])),
      };
    },
    staleTime: Infinity,
  });
}

export function useJobs(id: number, live: boolean) {
  return useQuery({
    queryKey: ["jobs", id],
    queryFn: async (): Promise<JobRow[]> =>
      unwrap(await client.GET("/api/v1/campaigns/{campaign_id}/jobs", { params: { path: { campaign_id: id } } }))
        .map((j) => ({
          id: j.id,
          iteration: j.iteration,
          step: j.step,
          status: j.status,
          worker: j.worker_name ?? null,
          attempts: j.attempts,
          started_at: j.started_at ?? null,
          duration_s: j.wall_time_s ?? null,
          error: j.error ?? null,
        }))
        .reverse(),
    refetchInterval: live ? POLL_MS : false,
  });
}

export function usePoolVersions(id: number, live: boolean) {
  return useQuery({
    queryKey: ["pools", id],
    queryFn: async (): Promise<PoolVersionRow[]> => {
      const rows = unwrap(await client.GET("/api/v1/campaigns/{campaign_id}/pool-versions", { params: { path: { campaign_id: id } } }));
      const versionOf = new Map(rows.map((p) => [p.id, p.version]));
      const base = `${API}/campaigns/${id}/pool-versions`;
      return rows
        .map((p) => ({
          id: p.id,
          version: p.version,
          parent_version: p.parent_id ? (versionOf.get(p.parent_id) ?? null) : null,
          n_datasets: p.n_datasets,
          n_samples: p.n_samples,
          created_at: p.created_at,
          parquet_url: `${base}/${p.version}/download?format=parquet`,
          csv_url: `${base}/${p.version}/download?format=csv`,
        }))
        .reverse();
    },
    refetchInterval: live ? POLL_MS * 2 : false,
  });
}

export function useModelVersions(id: number, live: boolean) {
  return useQuery({
    queryKey: ["models", id],
    queryFn: async (): Promise<ModelVersionRow[]> => {
      const [models, pools] = await Promise.all([
        client.GET("/api/v1/campaigns/{campaign_id}/model-versions", { params: { path: { campaign_id: id } } }).then(unwrap),
        client.GET("/api/v1/campaigns/{campaign_id}/pool-versions", { params: { path: { campaign_id: id } } }).then(unwrap),
      ]);
      const poolVersion = new Map(pools.map((p) => [p.id, p.version]));
      const modelVersion = new Map(models.map((m) => [m.id, m.version]));
      return models
        .map((m) => ({
          id: m.id,
          version: m.version,
          pool_version: poolVersion.get(m.pool_version_id) ?? null,
          parent_version: m.parent_model_id ? (modelVersion.get(m.parent_model_id) ?? null) : null,
          test_force_rmse: m.test_force_rmse ?? null,
          test_moment_rmse: m.test_moment_rmse ?? null,
          epochs: m.epochs ?? null,
          artifact_url: `${API}/campaigns/${id}/model-versions/${m.version}/artifact.zip`,
        }))
        .reverse();
    },
    refetchInterval: live ? POLL_MS * 2 : false,
  });
}

type Action = "start" | "pause" | "resume" | "cancel" | "retry";
async function campaignAction(id: number, action: Action) {
  const path = { params: { path: { campaign_id: id } } };
  switch (action) {
    case "start":
      return unwrap(await client.POST("/api/v1/campaigns/{campaign_id}/start", path));
    case "pause":
      return unwrap(await client.POST("/api/v1/campaigns/{campaign_id}/pause", path));
    case "resume":
      return unwrap(await client.POST("/api/v1/campaigns/{campaign_id}/resume", path));
    case "cancel":
      return unwrap(await client.POST("/api/v1/campaigns/{campaign_id}/cancel", path));
    case "retry":
      return unwrap(await client.POST("/api/v1/campaigns/{campaign_id}/retry", path));
  }
}

export async function startCampaign(id: number): Promise<void> {
  await campaignAction(id, "start");
}

export function useCampaignAction(id: number) {
  const qc = useQueryClient();
  return useMutation({
    mutationFn: async (action: Action) => campaignDetail(await campaignAction(id, action)),
    onSuccess: (detail) => qc.setQueryData(["campaign", id], detail),
    onSettled: () => {
      void qc.invalidateQueries({ queryKey: ["campaign", id] });
      void qc.invalidateQueries({ queryKey: ["jobs", id] });
      void qc.invalidateQueries({ queryKey: ["campaigns"] });
    },
  });
}

export function useForkCampaign(id: number) {
  const qc = useQueryClient();
  return useMutation({
    mutationFn: async (body: Schemas["ForkRequest"]) =>
      campaignDetail(unwrap(await client.POST("/api/v1/campaigns/{campaign_id}/fork", { params: { path: { campaign_id: id } }, body }))),
    onSuccess: () => qc.invalidateQueries({ queryKey: ["campaigns"] }),
  });
}

export function useCreateCampaign() {
  const qc = useQueryClient();
  return useMutation({
    mutationFn: async (body: Schemas["CampaignCreateIn"]) => campaignDetail(unwrap(await client.POST("/api/v1/campaigns", { body }))),
    onSuccess: () => qc.invalidateQueries({ queryKey: ["campaigns"] }),
  });
}

// ------------------------------------------------------------------ schema
export interface OpenApiDocument {
  components?: { schemas?: Record<string, JsonSchema> };
}
/** The API's own OpenAPI document: forms for settings are generated from its component schemas. */
export function useOpenApi() {
  return useQuery({ queryKey: ["openapi"], queryFn: () => api<OpenApiDocument>("GET", "/openapi.json"), staleTime: Infinity });
}
export function componentSchema(doc: OpenApiDocument | undefined, name: string): JsonSchema | null {
  const schemas = doc?.components?.schemas;
  const schema = schemas?.[name];
  return schema ? { ...schema, $defs: schemas } : null;
}

// ------------------------------------------------------------------ surrogate configs
/** Surrogate configurations you can use (campaigns default to the paper's). */
export function useSurrogateConfigs(enabled = true) {
  return useQuery({
    queryKey: ["surrogate-configs"],
    queryFn: async (): Promise<SurrogateConfigRow[]> =>
      unwrap(await client.GET("/api/v1/surrogate-configs", { params: { query: { limit: 500 } } })).map((c) => ({ id: c.id, version_id: c.id, name: c.name, version: c.version })),
    enabled,
  });
}

// ------------------------------------------------------------------ tasks
function taskRow(t: Schemas["TaskOut"]): TaskRow {
  const versionId = (t as { version_id?: number }).version_id;
  return { ...t, version_id: versionId ?? t.id, spec: t.spec as TaskSpecDraft };
}
export function useTasks() {
  return useQuery({ queryKey: ["tasks"], queryFn: async () => unwrap(await client.GET("/api/v1/tasks", { params: { query: { limit: 500 } } })).map(taskRow) });
}
export function useTask(id: number | null) {
  return useQuery({
    queryKey: ["task", id],
    queryFn: async () => taskRow(unwrap(await client.GET("/api/v1/tasks/{task_id}", { params: { path: { task_id: id ?? 0 } } }))),
    enabled: id !== null,
  });
}
/** One version of a task (the exact spec a campaign runs). */
export function useTaskVersion(id: number | null | undefined, version: number | null | undefined) {
  return useQuery({
    queryKey: ["task-version", id, version],
    queryFn: async () =>
      unwrap(await client.GET("/api/v1/tasks/{task_id}/versions/{version}", { params: { path: { task_id: id ?? 0, version: version ?? 1 } } })),
    enabled: Boolean(id && version),
    staleTime: Infinity,
  });
}
export function useTaskPresets() {
  return useQuery({
    queryKey: ["task-presets"],
    queryFn: async (): Promise<TaskPreset[]> => unwrap(await client.GET("/api/v1/tasks/presets")).map((p) => ({ name: p.key, spec: p.spec as TaskSpecDraft })),
    staleTime: Infinity,
  });
}
export function useTaskSchema() {
  return useQuery({ queryKey: ["task-schema"], queryFn: async () => unwrap(await client.GET("/api/v1/tasks/schema")) as JsonSchema, staleTime: Infinity });
}
/** Field-level problems of a draft, without saving (empty list: valid). */
export async function validateTask(body: { name: string; description: string; spec: TaskSpecDraft }): Promise<FieldError[]> {
  try {
    return fieldErrors(unwrap(await client.POST("/api/v1/tasks/validate", { body })));
  } catch (err) {
    if (err instanceof ApiError && err.status === 422) return err.fieldErrors;
    throw err;
  }
}
export function useSaveTask(id: number | null) {
  const qc = useQueryClient();
  return useMutation({
    mutationFn: async (body: { name: string; description: string; spec: TaskSpecDraft }) => {
      const spec = body.spec as unknown as Schemas["TaskSpec"];
      const saved =
        id === null
          ? unwrap(await client.POST("/api/v1/tasks", { body: { ...body, spec } }))
          : unwrap(await client.PUT("/api/v1/tasks/{task_id}", { params: { path: { task_id: id } }, body: { ...body, spec } }));
      return taskRow(saved);
    },
    onSuccess: () => {
      void qc.invalidateQueries({ queryKey: ["tasks"] });
      void qc.invalidateQueries({ queryKey: ["task", id] });
    },
  });
}
// ------------------------------------------------------------------ editor previews
/**
 * Previews run by a worker: POST creates one (202, pending), then GET /previews/{id} is polled
 * until it succeeded or failed. The preview of an unsaved edit sends the edit in the body.
 */
export const PREVIEW_POLL_MS = 1000;
const PREVIEW_FINAL = new Set(["succeeded", "failed"]);
export function isPreviewFinal(p: Preview | undefined): boolean {
  return Boolean(p && PREVIEW_FINAL.has(p.status));
}
export function usePreview(id: number | null) {
  return useQuery({
    queryKey: ["preview", id],
    queryFn: async () => unwrap(await client.GET("/api/v1/previews/{preview_id}", { params: { path: { preview_id: id as number } } })),
    enabled: id !== null,
    refetchInterval: (q) => (isPreviewFinal(q.state.data) ? false : PREVIEW_POLL_MS),
    staleTime: Infinity,
  });
}
/** "Solve once": the task (or its unsaved edit `spec`) solved with the auxiliary contact. */
export function useCreateTaskPreview(taskId: number | null) {
  const qc = useQueryClient();
  return useMutation({
    mutationFn: async (body: { spec?: TaskSpecDraft; intervals?: number }) =>
      unwrap(await client.POST("/api/v1/tasks/{task_id}/previews", { params: { path: { task_id: taskId as number } }, body: body as Schemas["TaskPreviewIn"] })),
    onSuccess: (p) => qc.setQueryData(["preview", p.id], p),
  });
}

// ------------------------------------------------------------------ oracles
function oracleRow(o: Schemas["OracleOut"]): OracleRow {
  const versionId = (o as { version_id?: number }).version_id;
  return { ...o, version_id: versionId ?? o.id };
}
export function useOracles() {
  return useQuery({ queryKey: ["oracles"], queryFn: async () => unwrap(await client.GET("/api/v1/oracles", { params: { query: { limit: 500 } } })).map(oracleRow) });
}
export function useOracle(id: number | null) {
  return useQuery({
    queryKey: ["oracle", id],
    queryFn: async () => oracleRow(unwrap(await client.GET("/api/v1/oracles/{oracle_id}", { params: { path: { oracle_id: id ?? 0 } } }))),
    enabled: id !== null,
  });
}
export function useOracleTypes() {
  return useQuery({
    queryKey: ["oracle-types"],
    queryFn: async (): Promise<OracleType[]> => {
      const rows = unwrap(await client.GET("/api/v1/oracles/types"));
      return rows.map((r) => ({
        name: r.name,
        kind: r.kind,
        description: r.available ? r.description : `${r.description} (${r.unavailable_reason ?? "unavailable"})`,
        available: r.available,
        schema: r.params_schema as JsonSchema,
      }));
    },
    staleTime: 60_000,
  });
}
/** Field-level problems of an oracle's type and parameters, without saving. */
export async function validateOracle(body: { type: string; params: Record<string, unknown> }): Promise<FieldError[]> {
  try {
    return fieldErrors(unwrap(await client.POST("/api/v1/oracles/validate", { body })));
  } catch (err) {
    if (err instanceof ApiError && err.status === 422) return err.fieldErrors;
    throw err;
  }
}
export function useSaveOracle(id: number | null) {
  const qc = useQueryClient();
  return useMutation({
    mutationFn: async (body: { name: string; description: string; type: string; params: Record<string, unknown> }) =>
      oracleRow(
        id === null
          ? unwrap(await client.POST("/api/v1/oracles", { body }))
          : unwrap(await client.PUT("/api/v1/oracles/{oracle_id}", { params: { path: { oracle_id: id } }, body })),
      ),
    onSuccess: () => {
      void qc.invalidateQueries({ queryKey: ["oracles"] });
      void qc.invalidateQueries({ queryKey: ["oracle", id] });
    },
  });
}
/** "Test on a sample trajectory": the FE reference head motion replayed through the oracle (or its unsaved `params`). */
export function useCreateOraclePreview(oracleId: number | null) {
  const qc = useQueryClient();
  return useMutation({
    mutationFn: async (body: { params?: Record<string, unknown> }) =>
      unwrap(await client.POST("/api/v1/oracles/{oracle_id}/previews", { params: { path: { oracle_id: oracleId as number } }, body })),
    onSuccess: (p) => qc.setQueryData(["preview", p.id], p),
  });
}
