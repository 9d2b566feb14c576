import { fmtNumber } from "./format";

/** "initial.q.0 = 0.21, model.headrest_offset = -0.0012": a scenario's drawn values. */
export function scenarioText(scenario: unknown): string {
  const values = (scenario as { values?: Record<string, number> } | null | undefined)?.values;
  if (!values || !Object.keys(values).length) return "the task as written";
  return Object.entries(values)
    .map(([k, v]) => `${k} = ${fmtNumber(v, 3)}`)
    .join(", ");
}
