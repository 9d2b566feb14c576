/**
 * Previews run by a worker: POST creates one (202, pending), then GET /previews/{id} is polled
 * until it succeeded or failed. The preview of an unsaved edit sends the edit in the body.
 */
import { useMutation, useQuery, useQueryClient } from "@tanstack/react-query";
import { client, unwrap } from "./client";
import { keys } from "./keys";
import type { Preview, Schemas, TaskSpecDraft } from "./types";

export const PREVIEW_POLL_MS = 1000;
const PREVIEW_FINAL = new Set(["succeeded", "failed"]);
export function isPreviewFinal(p: Preview | undefined): boolean {
  return Boolean(p && PREVIEW_FINAL.has(p.status));
}
export function usePreview(id: number | null) {
  return useQuery({
    queryKey: keys.preview(id),
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
    onSuccess: (p) => qc.setQueryData(keys.preview(p.id), p),
  });
}
/** "Test on a sample trajectory": the FE reference head motion replayed through the oracle (or its unsaved `params`). */
export function useCreateOraclePreview(oracleId: number | null) {
  const qc = useQueryClient();
  return useMutation({
    mutationFn: async (body: { params?: Record<string, unknown> }) =>
      unwrap(await client.POST("/api/v1/oracles/{oracle_id}/previews", { params: { path: { oracle_id: oracleId as number } }, body })),
    onSuccess: (p) => qc.setQueryData(keys.preview(p.id), p),
  });
}
