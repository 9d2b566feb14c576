/**
 * Every API call the UI makes, as TanStack Query hooks returning view types. This is the
 * only module that knows routes and response shapes; pages only see the types below.
 */
import { keepPreviousData, queryOptions, useMutation, useQuery, useQueryClient } from "@tanstack/react-query";
import { ApiError, fieldErrors, type FieldError } from "./errors";
import { storedToken } from "./auth";
import { mergeMetrics, afterCursor, type MetricPoint } from "../lib/metrics";
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
export interface OracleTestResult {
  t: number[];
  wrench: Wrench;
  wall_time_s: number | null;
  message: string;
}
export interface SolveResult {
  success: boolean;
  status: string;
  cost: number | null;
  wall_time_s: number | null;
  t: number[];
  t_tau?: number[];
  q: number[][];
  tau: number[][];
}

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

export function useCampaigns(filters: { status?: string }) {
  return useQuery({
    queryKey: ["campaigns", filters],
    queryFn: () => api<CampaignRow[]>("GET", "/campaigns", { query: { status: filters.status, limit: 200 } }),
    placeholderData: keepPreviousData,
    refetchInterval: (q) => (q.state.data?.some((c) => isLive(c.status)) ? POLL_MS * 2 : false),
  });
}

export function useCampaign(id: number) {
  return useQuery({
    queryKey: ["campaign", id],
    queryFn: () => api<CampaignDetail>("GET", `/campaigns/${id}`),
    refetchInterval: (q) => (q.state.data && isLive(q.state.data.status) ? POLL_MS : false),
  });
}

/** The RMSE series, polled incrementally: each poll asks only for iterations after the last final one. */
export function metricsQuery(id: number, live = false) {
  const key = ["metrics", id] as const;
  return queryOptions({
    queryKey: key,
    queryFn: async ({ client }) => {
      const known = client.getQueryData<MetricPoint[]>(key);
      const fresh = await api<MetricPoint[]>("GET", `/campaigns/${id}/metrics`, { query: { after: afterCursor(known) } });
      return mergeMetrics(known, fresh);
    },
    refetchInterval: live ? POLL_MS : false,
  });
}
export function useMetrics(id: number, live: boolean) {
  return useQuery(metricsQuery(id, live));
}

export function iterationQuery(id: number, k: number) {
  return queryOptions({
    queryKey: ["iteration", id, k],
    queryFn: () => api<IterationCurves>("GET", `/campaigns/${id}/iterations/${k}/curves`),
    staleTime: Infinity,
  });
}

export function useJobs(id: number, live: boolean) {
  return useQuery({ queryKey: ["jobs", id], queryFn: () => api<JobRow[]>("GET", `/campaigns/${id}/jobs`), refetchInterval: live ? POLL_MS : false });
}
export function usePoolVersions(id: number, live: boolean) {
  return useQuery({ queryKey: ["pools", id], queryFn: () => api<PoolVersionRow[]>("GET", `/campaigns/${id}/pool-versions`), refetchInterval: live ? POLL_MS * 2 : false });
}
export function useModelVersions(id: number, live: boolean) {
  return useQuery({ queryKey: ["models", id], queryFn: () => api<ModelVersionRow[]>("GET", `/campaigns/${id}/model-versions`), refetchInterval: live ? POLL_MS * 2 : false });
}

export async function startCampaign(id: number): Promise<void> {
  await api("POST", `/campaigns/${id}/start`);
}

export function useCampaignAction(id: number) {
  const qc = useQueryClient();
  return useMutation({
    mutationFn: (action: "start" | "pause" | "resume" | "cancel" | "retry") => api<CampaignDetail>("POST", `/campaigns/${id}/${action}`),
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
    mutationFn: (body: { iteration: number; name: string } & Record<string, unknown>) => api<CampaignDetail>("POST", `/campaigns/${id}/fork`, { body }),
    onSuccess: () => qc.invalidateQueries({ queryKey: ["campaigns"] }),
  });
}

export function useCreateCampaign() {
  const qc = useQueryClient();
  return useMutation({
    mutationFn: (body: { name: string; task_version_id: number; oracle_version_id: number; surrogate_config_version_id: number; seed: number } & Record<string, unknown>) =>
      api<CampaignDetail>("POST", "/campaigns", { body }),
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
export function useSurrogateConfigs() {
  return useQuery({ queryKey: ["surrogate-configs"], queryFn: () => api<SurrogateConfigRow[]>("GET", "/surrogate-configs") });
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
export function useTaskPresets() {
  return useQuery({
    queryKey: ["task-presets"],
    queryFn: async (): Promise<TaskPreset[]> => unwrap(await client.GET("/api/v1/tasks/presets")).map((p) => ({ name: p.key, spec: p.spec as TaskSpecDraft })),
    staleTime: Infinity,
  });
}
/** Whether the API offers a route (optional features such as "solve once" appear when it does). */
export function hasRoute(doc: OpenApiDocument | undefined, method: string, path: string): boolean {
  return Boolean((doc as { paths?: Record<string, Record<string, unknown>> } | undefined)?.paths?.[API + path]?.[method.toLowerCase()]);
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
/** Optional: "solve once" preview (the UI shows the button only when the API has the route). */
export const SOLVE_ONCE_ROUTE = "/tasks/solve";
export function useSolveOnce() {
  return useMutation({ mutationFn: (body: { spec: TaskSpecDraft }) => api<SolveResult>("POST", SOLVE_ONCE_ROUTE, { body }) });
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
/** Optional: "test on a sample trajectory" (shown only when the API has the route). */
export const ORACLE_TEST_ROUTE = "/oracles/test";
export function useTestOracle() {
  return useMutation({ mutationFn: (body: { type: string; params: Record<string, unknown> }) => api<OracleTestResult>("POST", ORACLE_TEST_ROUTE, { body }) });
}
