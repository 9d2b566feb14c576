/**
 * Tasks, oracles and surrogate configurations: the versioned definitions a campaign uses,
 * their versions and shares, and the schemas their forms are generated from.
 */
import { useMutation, useQuery, useQueryClient } from "@tanstack/react-query";
import { client, unwrap } from "./client";
import { refetchAfterWrite } from "./refresh";
import { keys, type DefinitionKind } from "./keys";
import { ApiError, fieldProblems, type FieldError } from "./errors";
import type { JsonSchema } from "../components/SchemaForm";
import type { ModelPreset, Oracle, OracleType, ScenarioPreview, Schemas, Share, SurrogateConfig, Task, TaskPreset, TaskSpecDraft } from "./types";

export type { DefinitionKind };

// ------------------------------------------------------------------ the API's own schema
export interface OpenApiDocument {
  components?: { schemas?: Record<string, JsonSchema> };
}
/** The API's own OpenAPI document: forms for settings are generated from its component schemas. */
export function useOpenApi() {
  return useQuery({
    queryKey: keys.openapi,
    queryFn: async (): Promise<OpenApiDocument> => {
      const r = await fetch(new URL("/api/v1/openapi.json", window.location.origin), { headers: { Accept: "application/json" } });
      if (!r.ok) throw new ApiError(r.status, null);
      return (await r.json()) as OpenApiDocument;
    },
    staleTime: Infinity,
  });
}
export function componentSchema(doc: OpenApiDocument | undefined, name: string): JsonSchema | null {
  const schemas = doc?.components?.schemas;
  const schema = schemas?.[name];
  return schema ? { ...schema, $defs: schemas } : null;
}

// ------------------------------------------------------------------ lists and single definitions
export function useTasks() {
  return useQuery({ queryKey: keys.tasks, queryFn: async (): Promise<Task[]> => unwrap(await client.GET("/api/v1/tasks", { params: { query: { limit: 500 } } })) });
}
export function useTask(id: number | null) {
  return useQuery({
    queryKey: keys.definition("task", id),
    queryFn: async (): Promise<Task> => unwrap(await client.GET("/api/v1/tasks/{task_id}", { params: { path: { task_id: id ?? 0 } } })),
    enabled: id !== null,
  });
}
export function useOracles() {
  return useQuery({ queryKey: keys.oracles, queryFn: async (): Promise<Oracle[]> => unwrap(await client.GET("/api/v1/oracles", { params: { query: { limit: 500 } } })) });
}
export function useOracle(id: number | null) {
  return useQuery({
    queryKey: keys.definition("oracle", id),
    queryFn: async (): Promise<Oracle> => unwrap(await client.GET("/api/v1/oracles/{oracle_id}", { params: { path: { oracle_id: id ?? 0 } } })),
    enabled: id !== null,
  });
}
/** Surrogate configurations you can use (campaigns default to the paper's). */
export function useSurrogateConfigs(enabled = true) {
  return useQuery({
    queryKey: keys.surrogateConfigs,
    queryFn: async (): Promise<SurrogateConfig[]> => unwrap(await client.GET("/api/v1/surrogate-configs", { params: { query: { limit: 500 } } })),
    enabled,
  });
}

// ------------------------------------------------------------------ versions and shares (both kinds)
export interface VersionEntry {
  version: number;
  locked: boolean;
  note: string;
  created_at: string;
}
export function useVersions(kind: DefinitionKind, id: number | null) {
  return useQuery({
    queryKey: keys.versions(kind, id),
    queryFn: async (): Promise<VersionEntry[]> => {
      const rows =
        kind === "task"
          ? unwrap(await client.GET("/api/v1/tasks/{task_id}/versions", { params: { path: { task_id: id ?? 0 } } }))
          : unwrap(await client.GET("/api/v1/oracles/{oracle_id}/versions", { params: { path: { oracle_id: id ?? 0 } } }));
      return rows.map((v) => ({ version: v.version, locked: v.locked, note: v.note, created_at: v.created_at })).sort((a, b) => b.version - a.version);
    },
    enabled: id !== null,
  });
}
/** One version of a task (the exact spec a campaign runs). */
export function useTaskVersion(id: number | null | undefined, version: number | null | undefined) {
  return useQuery({
    queryKey: keys.taskVersion(id, version),
    queryFn: async () => unwrap(await client.GET("/api/v1/tasks/{task_id}/versions/{version}", { params: { path: { task_id: id ?? 0, version: version ?? 1 } } })),
    enabled: Boolean(id && version),
    staleTime: Infinity,
  });
}
export function useShares(kind: DefinitionKind, id: number | null) {
  return useQuery({
    queryKey: keys.shares(kind, id),
    queryFn: async (): Promise<Share[]> => unwrap(await client.GET("/api/v1/shares", { params: { query: { object_type: kind, object_id: id ?? 0 } } })),
    enabled: id !== null,
  });
}
export function useShare(kind: DefinitionKind, id: number | null) {
  const qc = useQueryClient();
  const refresh = () => refetchAfterWrite(qc, keys.shares(kind, id));
  const add = useMutation({
    mutationFn: async (body: { email: string; permission: "view" | "edit" }) =>
      unwrap(await client.POST("/api/v1/shares", { body: { ...body, object_type: kind, object_id: id ?? 0 } })),
    onSuccess: refresh,
  });
  const remove = useMutation({
    mutationFn: async (shareId: number) => {
      const r = await client.DELETE("/api/v1/shares/{share_id}", { params: { path: { share_id: shareId } } });
      if (!r.response.ok) unwrap(r);
    },
    onSuccess: refresh,
  });
  return { add, remove };
}

// ------------------------------------------------------------------ tasks
export function useTaskPresets() {
  return useQuery({ queryKey: keys.taskPresets, queryFn: async (): Promise<TaskPreset[]> => unwrap(await client.GET("/api/v1/tasks/presets")), staleTime: Infinity });
}
/** The model presets (model.preset) with every parameter: what the editor loads when one is chosen. */
export function useModelPresets() {
  return useQuery({ queryKey: keys.modelPresets, queryFn: async (): Promise<ModelPreset[]> => unwrap(await client.GET("/api/v1/tasks/model-presets")), staleTime: Infinity });
}
export function useTaskSchema() {
  return useQuery({ queryKey: keys.taskSchema, queryFn: async () => unwrap(await client.GET("/api/v1/tasks/schema")) as JsonSchema, staleTime: Infinity });
}
/** Field-level problems of a draft, without saving (empty list: valid). */
export function checkTask(body: { name: string; description: string; spec: TaskSpecDraft }): Promise<FieldError[]> {
  return fieldProblems(async () => unwrap(await client.POST("/api/v1/tasks/check", { body })));
}
/** Scenarios iterations 1..n of a random-scenarios campaign with ``seed`` would solve (a draft spec, or the saved one). */
export function useScenarioPreview(id: number | null) {
  return useMutation({
    mutationFn: async (body: { n: number; seed: number; spec?: TaskSpecDraft }): Promise<ScenarioPreview> =>
      unwrap(await client.POST("/api/v1/tasks/{task_id}/scenarios/preview", { params: { path: { task_id: id ?? 0 } }, body })),
  });
}
export function useSaveTask(id: number | null) {
  const qc = useQueryClient();
  return useMutation({
    mutationFn: async (body: { name: string; description: string; spec: TaskSpecDraft }): Promise<Task> => {
      const b = { ...body, spec: body.spec as unknown as Schemas["TaskSpec"] };
      return id === null
        ? unwrap(await client.POST("/api/v1/tasks", { body: b }))
        : unwrap(await client.PUT("/api/v1/tasks/{task_id}", { params: { path: { task_id: id } }, body: b }));
    },
    onSuccess: () => refetchAfterWrite(qc, keys.definition("task")).then(() => refetchAfterWrite(qc, keys.tasks)),
  });
}

// ------------------------------------------------------------------ oracles
export function useOracleTypes() {
  return useQuery({ queryKey: keys.oracleTypes, queryFn: async (): Promise<OracleType[]> => unwrap(await client.GET("/api/v1/oracles/types")), staleTime: 60_000 });
}
/** Field-level problems of an oracle's type and parameters, without saving. */
export function checkOracle(body: { type: string; params: Record<string, unknown> }): Promise<FieldError[]> {
  return fieldProblems(async () => unwrap(await client.POST("/api/v1/oracles/check", { body })));
}
export function useSaveOracle(id: number | null) {
  const qc = useQueryClient();
  return useMutation({
    mutationFn: async (body: { name: string; description: string; type: string; params: Record<string, unknown> }): Promise<Oracle> =>
      id === null
        ? unwrap(await client.POST("/api/v1/oracles", { body }))
        : unwrap(await client.PUT("/api/v1/oracles/{oracle_id}", { params: { path: { oracle_id: id } }, body })),
    onSuccess: () => refetchAfterWrite(qc, keys.definition("oracle")).then(() => refetchAfterWrite(qc, keys.oracles)),
  });
}
