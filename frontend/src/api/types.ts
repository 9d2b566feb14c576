/**
 * The API's types, taken from the generated OpenAPI schema (src/api/schema.d.ts). Pages use
 * these; the few types below that are not plain response bodies say what they derive from.
 */
import type { components, operations } from "./schema";

export type Schemas = components["schemas"];

/** The JSON body of an operation's 200 answer. */
export type Ok<Op extends keyof operations> = operations[Op] extends { responses: { 200: { content: { "application/json": infer T } } } } ? T : never;

export type Me = Schemas["UserOut"];
export type Token = Schemas["TokenOut"];
export type CampaignSummary = Schemas["CampaignSummary"];
export type CampaignOut = Schemas["CampaignOut"];
export type CampaignStatus = Schemas["CampaignStatus"];
export type CampaignConfig = Schemas["CampaignConfig"];
/** An event of the live channel (EventRead; campaign_id names the campaign on the list's stream). */
export type CampaignEvent = Schemas["EventRead"] & { campaign_id: number };
export type MetricsRow = Schemas["MetricsRead"];
export type ValidationSeries = Schemas["ValidationSeries"];
export type IterationRow = Schemas["IterationRead"];
export type Job = Schemas["JobOut"];
/** A scheduler job of an oracle call that runs as a batch job (Slurm, PBS, LSF). */
export type BatchJob = Schemas["BatchJobRead"];
export type PoolVersion = Schemas["PoolVersionRead"];
export type ModelVersion = Schemas["ModelVersionRead"];
export type Task = Schemas["TaskOut"];
export type TaskVersion = Schemas["TaskVersionOut"];
export type TaskPreset = Schemas["TaskPresetOut"];
export type ModelPreset = Schemas["ModelPresetOut"];
export type ScenarioPreview = Schemas["ScenarioPreviewOut"];
export type Oracle = Schemas["OracleOut"];
export type OracleVersion = Schemas["OracleVersionOut"];
export type OracleType = Schemas["OracleTypeOut"];
export type SurrogateConfig = Schemas["SurrogateConfigOut"];
export type Share = Schemas["ShareOut"];
export type Preview = Schemas["PreviewOut"];
export type TaskPreviewResult = Schemas["TaskPreviewResult"];
export type OraclePreviewResult = Schemas["OraclePreviewResult"];
export type ForkRequest = Schemas["ForkRequest"];
export type IterationTrajectory = Schemas["IterationTrajectory"];
export type IterationCandidates = Schemas["IterationCandidates"];
export type CandidateDetail = Schemas["CandidateDetail"];

/** A task spec as the editor holds it: the schema's TaskSpec while being edited (may be invalid). */
export type TaskSpecDraft = Record<string, unknown> & { phases?: unknown[]; model?: Record<string, unknown> };

export type Wrench = Record<"fx" | "fy" | "fz" | "mx" | "my" | "mz", number[]>;
/** GET .../iterations/{k}/curves with the force rows turned into one array per wrench component. */
export interface IterationCurves {
  iteration: number;
  t: number[];
  /** joint angles at the samples, one row per sample (n, ndof) [rad] */
  q: number[][];
  truth: Wrench;
  /** the model's prediction: the ensemble mean */
  predicted: Wrench;
  /** the ensemble's standard deviation per output; null for a single model (K = 1) */
  std: Wrench | null;
  /** the model's history states along the motion (n, 3): max_indentation [m], slip_velocity_y and
   * slip_velocity_z [m/s]; null for a model of the state alone */
  history?: number[][] | null;
}

/** GET .../iterations/{k}/trajectory with q, qd, tau as one array per joint (rows are time samples on the wire). */
export interface WholeTrajectory extends Omit<IterationTrajectory, "q" | "qd" | "tau"> {
  q: number[][];
  qd: number[][];
  tau: number[][];
}
export type Phase = { name?: string | null; t_start: number; t_end: number };

/** Campaign statuses in which the campaign may still change by itself. */
const LIVE = new Set<string>(["queued", "running", "pausing", "cancelling"]);
export function isLive(status: string): boolean {
  return LIVE.has(status);
}
const TERMINAL = new Set<string>(["completed", "cancelled", "failed"]);
export function isTerminal(status: string): boolean {
  return TERMINAL.has(status);
}

/** Rows (time) x columns -> one array per column. */
export function columns<T>(rows: T[][]): T[][] {
  if (!rows.length) return [];
  return rows[0].map((_, j) => rows.map((r) => r[j]));
}
