/** Campaigns: the list, one campaign, its iterations' data, jobs, pool and model versions, and the lifecycle. */
import { keepPreviousData, queryOptions, useMutation, useQuery, useQueryClient } from "@tanstack/react-query";
import { client, unwrap } from "../api/client";
import { fieldProblems, type FieldError } from "../api/errors";
import { refetchAfterWrite } from "../api/refresh";
import { keys } from "../api/keys";
import { columns, type CampaignOut, type CampaignStatus, type CampaignSummary, type ForkRequest, type IterationCurves, type Job, type ModelVersion, type PoolVersion, type Schemas, type WholeTrajectory, type Wrench } from "../api/types";

export { downloadFile } from "../api/client";
export const API = "/api/v1";

export function useCampaigns(filters: { status?: string }) {
  return useQuery({
    queryKey: keys.campaignList(filters),
    queryFn: async ({ signal }): Promise<CampaignSummary[]> => {
      const status = (filters.status || undefined) as CampaignStatus | undefined;
      return unwrap(await client.GET("/api/v1/campaigns", { params: { query: { status, limit: 500 } }, signal }));
    },
    placeholderData: keepPreviousData,
  });
}

export function campaignQuery(id: number) {
  return queryOptions({
    queryKey: keys.campaign(id),
    queryFn: async ({ signal }): Promise<CampaignOut> => unwrap(await client.GET("/api/v1/campaigns/{campaign_id}", { params: { path: { campaign_id: id } }, signal })),
  });
}
export function useCampaign(id: number) {
  return useQuery(campaignQuery(id));
}

/** The stopping rule's iteration limit of a campaign, if it has one. */
export function maxIterations(c: CampaignOut): number | null {
  return c.config.stopping?.max_iterations ?? null;
}

/** "k / N" while k <= N; a campaign past its limit (or without one) shows k alone, never k / N with k > N. */
export function progressText(k: number, max: number | null | undefined): string {
  return max !== null && max !== undefined && k <= max ? `${k} / ${max}` : String(k);
}

/** Iteration k's whole OCP solution (every phase, on the OCP grid); immutable per attempt. */
export function trajectoryQuery(id: number, k: number) {
  return queryOptions({
    queryKey: keys.trajectory(id, k),
    queryFn: async (): Promise<WholeTrajectory> => {
      const r = unwrap(await client.GET("/api/v1/campaigns/{campaign_id}/iterations/{iteration}/trajectory", { params: { path: { campaign_id: id, iteration: k } } }));
      return { ...r, q: columns(r.q), qd: columns(r.qd), tau: columns(r.tau) };
    },
    staleTime: 60_000,
  });
}

const WRENCH = ["fx", "fy", "fz", "mx", "my", "mz"] as const;
function wrench(rows: number[][]): Wrench {
  const cols = columns(rows);
  return Object.fromEntries(WRENCH.map((w, j) => [w, cols[j] ?? []])) as Wrench;
}

/** Iteration k's oracle forces and the surrogate's prediction on the same trajectory; immutable. */
export function iterationQuery(id: number, k: number) {
  return queryOptions({
    queryKey: keys.curves(id, k),
    queryFn: async (): Promise<IterationCurves> => {
      const c = unwrap(await client.GET("/api/v1/campaigns/{campaign_id}/iterations/{iteration}/curves", { params: { path: { campaign_id: id, iteration: k } } }));
      return { iteration: c.iteration_index, t: c.t, q: c.q, truth: wrench(c.f_true), predicted: wrench(c.f_pred), std: c.f_std ? wrench(c.f_std) : null, history: c.history ?? null };
    },
    staleTime: Infinity,
  });
}

/** Iteration k's candidates, ranked, with which were picked and why (changes until the fan-in). */
export function candidatesQuery(id: number, k: number) {
  return queryOptions({
    queryKey: keys.candidates(id, k),
    queryFn: async ({ signal }) =>
      unwrap(await client.GET("/api/v1/campaigns/{campaign_id}/iterations/{iteration}/candidates", { params: { path: { campaign_id: id, iteration: k } }, signal })),
    staleTime: 5_000,
  });
}

/** Candidate `slot`'s whole OCP solution of iteration k (over the scenario it solved). */
export function candidateTrajectoryQuery(id: number, k: number, slot: number) {
  return queryOptions({
    queryKey: keys.slotTrajectory(id, k, slot),
    queryFn: async (): Promise<WholeTrajectory> => {
      const r = unwrap(await client.GET("/api/v1/campaigns/{campaign_id}/iterations/{iteration}/candidates/{slot}/trajectory", { params: { path: { campaign_id: id, iteration: k, slot } } }));
      return { ...r, q: columns(r.q), qd: columns(r.qd), tau: columns(r.tau) };
    },
    staleTime: 60_000,
  });
}

/** Pick `pick` of iteration k: the oracle's forces and the surrogate's mean and std along it; immutable. */
export function pickCurvesQuery(id: number, k: number, pick: number) {
  return queryOptions({
    queryKey: keys.pickCurves(id, k, pick),
    queryFn: async (): Promise<IterationCurves> => {
      const c = unwrap(await client.GET("/api/v1/campaigns/{campaign_id}/iterations/{iteration}/picks/{pick}/curves", { params: { path: { campaign_id: id, iteration: k, pick } } }));
      return { iteration: c.iteration_index, t: c.t, q: c.q, truth: wrench(c.f_true), predicted: wrench(c.f_pred), std: c.f_std ? wrench(c.f_std) : null, history: c.history ?? null };
    },
    staleTime: Infinity,
  });
}

/** Jobs, newest first. */
export function useJobs(id: number) {
  return useQuery({
    queryKey: keys.jobs(id),
    queryFn: async ({ signal }): Promise<Job[]> => unwrap(await client.GET("/api/v1/campaigns/{campaign_id}/jobs", { params: { path: { campaign_id: id } }, signal })).reverse(),
  });
}

export type PoolVersionRow = PoolVersion & { parent_version: number | null; parquet_url: string; csv_url: string };
export function usePoolVersions(id: number) {
  return useQuery({
    queryKey: keys.pools(id),
    queryFn: async (): Promise<PoolVersionRow[]> => {
      const rows = unwrap(await client.GET("/api/v1/campaigns/{campaign_id}/pool-versions", { params: { path: { campaign_id: id } } }));
      const versionOf = new Map(rows.map((p) => [p.id, p.version]));
      const base = `${API}/campaigns/${id}/pool-versions`;
      return rows
        .map((p) => ({
          ...p,
          parent_version: p.parent_id ? (versionOf.get(p.parent_id) ?? null) : null,
          parquet_url: `${base}/${p.version}/download?format=parquet`,
          csv_url: `${base}/${p.version}/download?format=csv`,
        }))
        .reverse();
    },
  });
}

export type ModelVersionRow = ModelVersion & { pool_version: number | null; parent_version: number | null; artifact_url: string };
export function useModelVersions(id: number) {
  return useQuery({
    queryKey: keys.models(id),
    queryFn: async (): Promise<ModelVersionRow[]> => {
      const [models, pools] = await Promise.all([
        client.GET("/api/v1/campaigns/{campaign_id}/model-versions", { params: { path: { campaign_id: id } } }).then(unwrap),
        client.GET("/api/v1/campaigns/{campaign_id}/pool-versions", { params: { path: { campaign_id: id } } }).then(unwrap),
      ]);
      const poolVersion = new Map(pools.map((p) => [p.id, p.version]));
      const modelVersion = new Map(models.map((m) => [m.id, m.version]));
      return models
        .map((m) => ({
          ...m,
          pool_version: poolVersion.get(m.pool_version_id) ?? null,
          parent_version: m.parent_model_id ? (modelVersion.get(m.parent_model_id) ?? null) : null,
          artifact_url: `${API}/campaigns/${id}/model-versions/${m.version}/artifact.zip`,
        }))
        .reverse();
    },
  });
}

export type Action = "start" | "pause" | "resume" | "cancel" | "retry";
async function campaignAction(id: number, action: Action): Promise<CampaignOut> {
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

export function useCampaignAction(id: number) {
  const qc = useQueryClient();
  return useMutation({
    mutationFn: (action: Action) => campaignAction(id, action),
    onSuccess: (detail) => qc.setQueryData(keys.campaign(id), detail),
    onSettled: () => {
      // the detail was just set from the answer: a cancel would revert it to the state before
      void qc.invalidateQueries({ queryKey: keys.campaign(id) });
      void qc.invalidateQueries({ queryKey: keys.jobs(id) });
      void refetchAfterWrite(qc, keys.campaigns);
    },
  });
}

export function useForkCampaign(id: number) {
  const qc = useQueryClient();
  return useMutation({
    mutationFn: async (body: ForkRequest): Promise<CampaignOut> => unwrap(await client.POST("/api/v1/campaigns/{campaign_id}/fork", { params: { path: { campaign_id: id } }, body })),
    onSuccess: () => refetchAfterWrite(qc, keys.campaigns),
  });
}

/** Every problem of a new campaign's request, each at its field, without creating it (empty list: valid). */
export function checkCampaign(body: Record<string, unknown>): Promise<FieldError[]> {
  return fieldProblems(async () => unwrap(await client.POST("/api/v1/campaigns/check", { body })));
}

export function useCreateCampaign() {
  const qc = useQueryClient();
  return useMutation({
    mutationFn: async (body: Schemas["CampaignCreateIn"]): Promise<CampaignOut> => unwrap(await client.POST("/api/v1/campaigns", { body })),
    onSuccess: () => refetchAfterWrite(qc, keys.campaigns),
  });
}
