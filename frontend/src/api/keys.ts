/**
 * Every query's key, in one place. Keys are prefixes of one another on purpose: a write or a
 * live event refreshes a prefix (`keys.definition("task")` is every task and what hangs below
 * it: its versions, its shares), so a key's shape says what a refresh reaches.
 */
export type DefinitionKind = "task" | "oracle";

export const keys = {
  me: ["me"] as const,
  tokens: ["tokens"] as const,
  openapi: ["openapi"] as const,
  taskPresets: ["task-presets"] as const,
  modelPresets: ["model-presets"] as const,
  taskSchema: ["task-schema"] as const,
  oracleTypes: ["oracle-types"] as const,
  surrogateConfigs: ["surrogate-configs"] as const,
  tasks: ["tasks"] as const,
  oracles: ["oracles"] as const,
  /** one task or oracle and what hangs below it; without an id: all of that kind */
  definition: (kind: DefinitionKind, id?: number | null) => (id === undefined ? ([kind] as const) : ([kind, id] as const)),
  versions: (kind: DefinitionKind, id: number | null) => [kind, id, "versions"] as const,
  taskVersion: (id: number | null | undefined, version: number | null | undefined) => ["task", id, "version", version] as const,
  shares: (kind: DefinitionKind, id: number | null) => [kind, id, "shares"] as const,
  preview: (id: number | null) => ["preview", id] as const,
  campaigns: ["campaigns"] as const,
  campaignList: (filters: { status?: string }) => ["campaigns", filters] as const,
  campaign: (id: number) => ["campaign", id] as const,
  metrics: (id: number) => ["metrics", id] as const,
  validation: (id: number) => ["validation", id] as const,
  iterationStates: (id: number) => ["iteration-states", id] as const,
  jobs: (id: number) => ["jobs", id] as const,
  pools: (id: number) => ["pools", id] as const,
  models: (id: number) => ["models", id] as const,
  curves: (id: number, k: number) => ["iteration", id, k] as const,
  trajectory: (id: number, k: number) => ["trajectory", id, k] as const,
  slotTrajectory: (id: number, k: number, slot: number) => ["trajectory", id, k, "slot", slot] as const,
  candidates: (id: number, k: number) => ["candidates", id, k] as const,
  pickCurves: (id: number, k: number, pick: number) => ["pick-curves", id, k, pick] as const,
};
