/** The phases of a task as an editable table: duration, intervals, weights, bounds, target pose. */
import { FieldMessages, numberProblem, parseNumberList, resolveRef, type JsonSchema } from "../components/SchemaForm";
import { NumberInput } from "../components/NumberInput";
import type { FieldError } from "../api/errors";
import type { ErrorView } from "../lib/formErrors";

export interface PhaseRow {
  name?: string;
  duration: number;
  intervals?: number;
  w_tau: number;
  w_T: number;
  q_min?: number[] | null;
  q_max?: number[] | null;
  tau_max?: number[] | null;
  target_q?: number[] | null;
  [key: string]: unknown;
}

const LIST_FIELDS = ["q_min", "q_max", "tau_max", "target_q"] as const;
const NUMBER_FIELDS = ["duration", "intervals", "w_tau", "w_T"] as const;
const HEADERS: Record<string, string> = {
  duration: "duration [s]",
  intervals: "intervals",
  w_tau: "w_τ",
  w_T: "w_T",
  q_min: "q min [rad]",
  q_max: "q max [rad]",
  tau_max: "|τ| max [N m]",
  target_q: "end pose [rad]",
};

export const parseList = parseNumberList;

/** The paths of the table's fields, for placing errors (a list cell owns its items). */
export function phaseFieldPaths(phases: PhaseRow[]): string[] {
  return phases.flatMap((_, m) => ["name", ...NUMBER_FIELDS, ...LIST_FIELDS].map((f) => `phases.${m}.${f}`));
}

/** The table's own checks: numbers, whole numbers and the bounds of the phase schema. */
export function phaseLocalErrors(phases: PhaseRow[], phaseSchema: JsonSchema | null, root: JsonSchema | undefined): FieldError[] {
  const out: FieldError[] = [];
  const prop = (f: string): JsonSchema => {
    const p = phaseSchema?.properties?.[f];
    return p && root ? resolveRef(p, root) : {};
  };
  phases.forEach((p, m) => {
    for (const f of NUMBER_FIELDS) {
      const msg = numberProblem(p[f], prop(f), f === "intervals");
      if (msg) out.push({ field: `phases.${m}.${f}`, message: msg });
    }
    for (const f of LIST_FIELDS) {
      const v = p[f];
      if (Array.isArray(v)) v.forEach((x, i) => (typeof x === "number" && Number.isFinite(x) ? null : out.push({ field: `phases.${m}.${f}.${i}`, message: "must be a number" })));
    }
  });
  return out;
}

export function PhasesTable({ phases, onChange, errors }: { phases: PhaseRow[]; onChange: (p: PhaseRow[]) => void; errors: ErrorView }) {
  const set = (m: number, key: string, value: unknown) => onChange(phases.map((p, i) => (i === m ? { ...p, [key]: value } : p)));
  const cellError = (m: number, key: string) => errors.at(`phases.${m}.${key}`);
  return (
    <div>
      <table data-testid="phases-table">
        <thead>
          <tr>
            <th>#</th>
            <th>name</th>
            {NUMBER_FIELDS.map((f) => (
              <th key={f}>{HEADERS[f]}</th>
            ))}
            {LIST_FIELDS.map((f) => (
              <th key={f}>{HEADERS[f]}</th>
            ))}
            <th>
              <span className="sr-only">Actions</span>
            </th>
          </tr>
        </thead>
        <tbody>
          {phases.map((p, m) => (
            <tr key={m}>
              <td>{m + 1}</td>
              <td>
                <input aria-label={`phase ${m + 1} name`} value={p.name ?? ""} onChange={(e) => set(m, "name", e.target.value)} size={10} aria-invalid={cellError(m, "name").length > 0} />
                <FieldMessages problems={cellError(m, "name")} />
              </td>
              {NUMBER_FIELDS.map((f) => (
                <td key={f}>
                  <NumberInput
                    aria-label={`phase ${m + 1} ${HEADERS[f]}`}
                    className="num-cell"
                    value={p[f]}
                    onChange={(v) => set(m, f, v)}
                    aria-invalid={cellError(m, f).length > 0}
                  />
                  <FieldMessages problems={cellError(m, f)} />
                </td>
              ))}
              {LIST_FIELDS.map((f) => (
                <td key={f}>
                  <input
                    aria-label={`phase ${m + 1} ${HEADERS[f]}`}
                    style={{ width: 80 }}
                    placeholder="default"
                    defaultValue={Array.isArray(p[f]) ? (p[f] as number[]).join(", ") : ""}
                    onBlur={(e) => set(m, f, parseNumberList(e.target.value))}
                    aria-invalid={cellError(m, f).length > 0}
                  />
                  <FieldMessages problems={cellError(m, f)} item="joint" />
                </td>
              ))}
              <td>
                <button type="button" className="link" disabled={phases.length <= 1} onClick={() => onChange(phases.filter((_, i) => i !== m))} aria-label={`Remove phase ${m + 1}`}>
                  remove
                </button>
              </td>
            </tr>
          ))}
        </tbody>
      </table>
      <button type="button" onClick={() => onChange([...phases, { name: `phase ${phases.length + 1}`, duration: 0.2, intervals: 20, w_tau: 1, w_T: 0 }])}>
        Add phase
      </button>
      <FieldMessages problems={errors.at("phases")} />
    </div>
  );
}
