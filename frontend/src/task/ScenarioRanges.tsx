/** The task's scenario ranges (ranges of some parameters, each with how its values are drawn) and a preview of sampled scenarios. */
import type { FieldError } from "../api/errors";
import { FieldMessages, numberProblem } from "../components/SchemaForm";
import { NumberInput } from "../components/NumberInput";
import type { ScenarioPreview } from "../api/types";
import type { ErrorView } from "../lib/formErrors";

export type Distribution = "uniform" | "normal" | "triangular";

export interface RangeRow {
  parameter: string;
  low: number;
  high: number;
  /** absent: uniform */
  distribution?: Distribution;
  mean?: number;
  std?: number;
  mode?: number;
}

/** The shape fields each distribution takes (alcove.science.ocp.scenario_ranges.ParameterRange). */
const SHAPE_FIELDS: Record<Distribution, ("mean" | "std" | "mode")[]> = { uniform: [], normal: ["mean", "std"], triangular: ["mode"] };

/** A row with another distribution: the new shape's fields start at the range's middle (and a sixth of its width as std); the old shape's are dropped. */
export function withDistribution(r: RangeRow, distribution: Distribution): RangeRow {
  const { mean: _m, std: _s, mode: _o, distribution: _d, ...base } = r;
  // a range still being typed (no numbers yet) leaves the shape's fields empty for the user to fill
  const known = typeof r.low === "number" && typeof r.high === "number" && Number.isFinite(r.low) && Number.isFinite(r.high);
  const mid = known ? (r.low + r.high) / 2 : undefined;
  if (distribution === "normal") return { ...base, distribution, mean: mid, std: known ? (r.high - r.low) / 6 || 1e-3 : undefined };
  if (distribution === "triangular") return { ...base, distribution, mode: mid };
  return base;
}

/** The parameters a range may name (alcove.science.ocp.scenarios.PARAMETERS; i: phase, j: joint). */
export const RANGE_PARAMETERS = [
  "initial.q.0",
  "initial.qd.0",
  "phases.0.duration",
  "phases.0.w_tau",
  "phases.0.w_T",
  "phases.0.target_q.0",
  "final.q.0",
  "endpoint_cost.w_q",
  "endpoint_cost.w_qd",
  "endpoint_cost.q_ref.0",
  "model.headrest_offset",
  // within +-0.05 rad of the task's own tilt (MAX_TILT_DEVIATION)
  "model.tilt",
];

/** The paths of the section's fields, for placing errors. */
export function rangeFieldPaths(ranges: RangeRow[]): string[] {
  return ["ranges", ...ranges.flatMap((_, i) => ["parameter", "low", "high", "distribution", "mean", "std", "mode"].map((f) => `ranges.${i}.${f}`))];
}

/** The section's own checks, made while typing: every value a number, and low <= high (the API's rule, at the same field). */
export function rangeLocalErrors(ranges: RangeRow[]): FieldError[] {
  const out: FieldError[] = [];
  ranges.forEach((r, i) => {
    for (const f of ["low", "high", ...SHAPE_FIELDS[r.distribution ?? "uniform"]] as const) {
      const m = numberProblem(r[f], {}, false) ?? (r[f] === undefined || r[f] === null ? "a number is needed" : null);
      if (m) out.push({ field: `ranges.${i}.${f}`, message: m });
    }
    if (typeof r.low === "number" && typeof r.high === "number" && Number.isFinite(r.low) && Number.isFinite(r.high) && r.low > r.high)
      out.push({ field: `ranges.${i}.high`, message: `must be at least low (${r.high} < ${r.low})` });
  });
  return out;
}

function fmt(v: number): string {
  return Number.isInteger(v) ? String(v) : v.toPrecision(4);
}

export function ScenarioRanges({
  ranges,
  onChange,
  errors,
  preview,
  previewing,
  onPreview,
  canPreview,
  previewError,
}: {
  ranges: RangeRow[];
  onChange: (r: RangeRow[] | null) => void;
  errors: ErrorView;
  preview: ScenarioPreview | undefined;
  previewing: boolean;
  onPreview: () => void;
  canPreview: boolean;
  previewError?: string | null;
}) {
  const set = (i: number, key: keyof RangeRow, value: unknown) => onChange(ranges.map((r, k) => (k === i ? { ...r, [key]: value } : r)));
  const remove = (i: number) => {
    const rest = ranges.filter((_, k) => k !== i);
    onChange(rest.length ? rest : null);
  };
  const columns = preview ? Array.from(new Set(preview.scenarios.flatMap((s) => Object.keys(s.values)))) : [];
  return (
    <section className="panel" aria-labelledby="ranges-title" data-testid="scenario-ranges">
      <h2 id="ranges-title">Scenario ranges</h2>
      <p className="hint">
        Ranges of some parameters make the task a distribution of scenarios: a campaign with the strategy random-scenarios solves a new draw every iteration (seeded by the campaign seed and the
        iteration). Values are drawn uniformly between low and high, or from a normal distribution (mean, std) truncated to them, or a triangular one peaking at its mode. No ranges: the task has one
        scenario, itself. Units are the parameter&apos;s (rad, rad/s, s, m); a headrest tilt (model.tilt) stays within ±0.05 rad of the task&apos;s own.
      </p>
      <datalist id="range-parameters">
        {RANGE_PARAMETERS.map((p) => (
          <option key={p} value={p} />
        ))}
      </datalist>
      {ranges.length > 0 && (
        <table className="table" aria-label="scenario ranges">
          <thead>
            <tr>
              <th>parameter</th>
              <th>low</th>
              <th>high</th>
              <th>distribution</th>
              <th>shape</th>
              <th />
            </tr>
          </thead>
          <tbody>
            {ranges.map((r, i) => (
              <tr key={i}>
                <td>
                  <input
                    aria-label={`range ${i + 1} parameter`}
                    list="range-parameters"
                    value={r.parameter}
                    onChange={(e) => set(i, "parameter", e.target.value)}
                    onBlur={(e) => e.target.value !== e.target.value.trim() && set(i, "parameter", e.target.value.trim())}
                    aria-invalid={errors.at(`ranges.${i}.parameter`).length > 0}
                  />
                  <FieldMessages problems={errors.at(`ranges.${i}.parameter`)} />
                </td>
                {(["low", "high"] as const).map((f) => (
                  <td key={f}>
                    <NumberInput aria-label={`range ${i + 1} ${f}`} value={r[f]} onChange={(v) => set(i, f, v)} aria-invalid={errors.at(`ranges.${i}.${f}`).length > 0} />
                    <FieldMessages problems={errors.at(`ranges.${i}.${f}`)} />
                  </td>
                ))}
                <td>
                  <select
                    aria-label={`range ${i + 1} distribution`}
                    value={r.distribution ?? "uniform"}
                    onChange={(e) => onChange(ranges.map((row, k) => (k === i ? withDistribution(row, e.target.value as Distribution) : row)))}
                    aria-invalid={errors.at(`ranges.${i}.distribution`).length > 0}
                  >
                    {(Object.keys(SHAPE_FIELDS) as Distribution[]).map((d) => (
                      <option key={d} value={d}>
                        {d}
                      </option>
                    ))}
                  </select>
                  <FieldMessages problems={errors.at(`ranges.${i}.distribution`)} />
                </td>
                <td>
                  {SHAPE_FIELDS[r.distribution ?? "uniform"].map((f) => (
                    <label key={f} className="inline">
                      {f}{" "}
                      <NumberInput aria-label={`range ${i + 1} ${f}`} size={7} value={r[f]} onChange={(v) => set(i, f, v)} aria-invalid={errors.at(`ranges.${i}.${f}`).length > 0} />
                      <FieldMessages problems={errors.at(`ranges.${i}.${f}`)} />
                    </label>
                  ))}
                </td>
                <td>
                  <button type="button" onClick={() => remove(i)} aria-label={`remove range ${i + 1}`}>
                    Remove
                  </button>
                </td>
              </tr>
            ))}
          </tbody>
        </table>
      )}
      <FieldMessages problems={errors.at("ranges")} />
      <div className="row">
        <button type="button" onClick={() => onChange([...ranges, { parameter: "initial.q.0", low: 0.15, high: 0.3 }])}>
          Add range
        </button>
        <button type="button" disabled={!canPreview || previewing || ranges.length === 0} onClick={onPreview} title={canPreview ? "Draw 5 scenarios with seed 0" : "Create the task first, and fix its problems"}>
          {previewing ? "Sampling…" : "Preview scenarios"}
        </button>
      </div>
      {previewError && (
        <p className="error-text" role="alert">
          {previewError}
        </p>
      )}
      {preview && (
        <table className="table" aria-label="sampled scenarios" data-testid="scenario-preview">
          <caption className="muted">Scenarios of iterations 1 to {preview.scenarios.length} of a random-scenarios campaign with seed {preview.seed}</caption>
          <thead>
            <tr>
              <th>iteration</th>
              {columns.map((c) => (
                <th key={c}>{c}</th>
              ))}
            </tr>
          </thead>
          <tbody>
            {preview.scenarios.map((s) => (
              <tr key={s.iteration}>
                <td>{s.iteration}</td>
                {columns.map((c) => (
                  <td key={c}>{s.values[c] === undefined ? "" : fmt(s.values[c])}</td>
                ))}
              </tr>
            ))}
          </tbody>
        </table>
      )}
    </section>
  );
}
