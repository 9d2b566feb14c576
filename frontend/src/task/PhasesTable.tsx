/** The phases of a task as an editable table: duration, intervals, weights, bounds, target pose. */
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

/** The error of a field and those of its list items (`phases.0.q_min.0`: "joint 0: ..."), joined. */
export function errorAt(errors: Record<string, string>, path: string): string | undefined {
  const messages = Object.entries(errors)
    .filter(([k]) => k === path || k.startsWith(`${path}.`))
    .map(([k, v]) => (k === path ? v : `joint ${k.slice(path.length + 1)}: ${v}`));
  return messages.length ? messages.join("; ") : undefined;
}

export function parseList(text: string): number[] | null {
  const parts = text.split(",").map((s) => s.trim()).filter(Boolean);
  if (!parts.length) return null;
  return parts.map(Number);
}

export function PhasesTable({ phases, onChange, errors }: { phases: PhaseRow[]; onChange: (p: PhaseRow[]) => void; errors: Record<string, string> }) {
  const set = (m: number, key: string, value: unknown) => onChange(phases.map((p, i) => (i === m ? { ...p, [key]: value } : p)));
  const cellError = (m: number, key: string) => errorAt(errors, `phases.${m}.${key}`);
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
                <input aria-label={`phase ${m + 1} name`} value={p.name ?? ""} onChange={(e) => set(m, "name", e.target.value)} size={10} />
              </td>
              {NUMBER_FIELDS.map((f) => (
                <td key={f}>
                  <input
                    aria-label={`phase ${m + 1} ${HEADERS[f]}`}
                    type="number"
                    step={f === "intervals" ? 1 : "any"}
                    style={{ width: 90 }}
                    value={p[f] === undefined || p[f] === null ? "" : String(p[f])}
                    onChange={(e) => set(m, f, e.target.value === "" ? undefined : Number(e.target.value))}
                    aria-invalid={Boolean(cellError(m, f))}
                    title={cellError(m, f)}
                  />
                  {cellError(m, f) && <small className="field-error">{cellError(m, f)}</small>}
                </td>
              ))}
              {LIST_FIELDS.map((f) => (
                <td key={f}>
                  <input
                    aria-label={`phase ${m + 1} ${HEADERS[f]}`}
                    style={{ width: 80 }}
                    placeholder="default"
                    defaultValue={Array.isArray(p[f]) ? (p[f] as number[]).join(", ") : ""}
                    onBlur={(e) => set(m, f, parseList(e.target.value))}
                    aria-invalid={Boolean(cellError(m, f))}
                    title={cellError(m, f)}
                  />
                  {cellError(m, f) && <small className="field-error">{cellError(m, f)}</small>}
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
      {errors["phases"] && <p className="field-error">{errors["phases"]}</p>}
    </div>
  );
}
