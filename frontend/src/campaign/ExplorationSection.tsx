/**
 * The new-campaign form's "Exploration" section (docs/active-learning.md): the
 * acquisition strategy, batch size q, candidates C, the diversity rule's minimum distance, the
 * cap on concurrent oracle jobs and the stopping threshold on the candidates' disagreement.
 * The schema's bounds are checked with the rest of the config (configLocalErrors); the rules
 * that tie fields together are checked here, and every error is shown at its field.
 */
import { useId } from "react";
import type { FieldError } from "../api/errors";
import { FieldMessages } from "../components/SchemaForm";
import { NumberInput, type NumberText } from "../components/NumberInput";
import type { ErrorView } from "../lib/formErrors";
import type { ConfigDraft } from "./ConfigSections";

export const STRATEGIES = [
  ["paper", "paper: the task as written, one trajectory per iteration"],
  ["random-scenarios", "random-scenarios: q scenarios drawn from the task's ranges"],
  ["ensemble-disagreement", "ensemble-disagreement: C candidates, the q most disputed far enough apart"],
  ["press-family", "press-family: q prescribed press motions (unloads, re-loads) spread over the task's range, no OCP"],
] as const;

/** The config paths this section edits (the generic sections leave them out). */
export const EXPLORATION_PATHS = [
  "settings.strategy",
  "settings.batch",
  "settings.candidates",
  "settings.min_distance",
  "settings.max_concurrent_oracle_jobs",
  "stopping.min_disagreement",
] as const;

/** The rules between fields, as the API checks them (settings.batch names the field). */
export function explorationErrors(config: ConfigDraft): FieldError[] {
  const st = config.settings ?? {};
  const strategy = st.strategy ?? "paper";
  const batch = st.batch;
  const out: FieldError[] = [];
  if (typeof batch === "number" && Number.isInteger(batch)) {
    if (strategy === "paper" && batch !== 1)
      out.push({ field: "settings.batch", message: `strategy 'paper' replays one trajectory per iteration (batch 1), got ${batch}` });
    const c = st.candidates;
    if (strategy === "ensemble-disagreement" && typeof c === "number" && batch > c)
      out.push({ field: "settings.batch", message: `a batch of ${batch} needs at least as many candidates, got candidates = ${c}` });
  }
  return out;
}

function NumberField({ path, label, hint, value, onChange, errors, integer, nullable }: { path: string; label: string; hint: string; value: unknown; onChange: (v: NumberText | null) => void; errors: ErrorView; integer?: boolean; nullable?: boolean }) {
  const id = useId();
  const problems = errors.at(path);
  return (
    <div className="field">
      <label htmlFor={id}>{label}</label>
      <NumberInput
        id={id}
        inputMode={integer ? "numeric" : undefined}
        value={value}
        placeholder={nullable ? "none" : undefined}
        onChange={(v) => onChange(v === undefined && nullable ? null : v)}
        aria-describedby={`${id}-hint${problems.length ? ` ${id}-err` : ""}`}
        aria-invalid={problems.length > 0}
        data-path={path}
      />
      <small id={`${id}-hint`} className="hint">
        {hint}
      </small>
      <FieldMessages problems={problems} id={`${id}-err`} />
    </div>
  );
}

export function ExplorationSection({ value, onChange, errors }: { value: ConfigDraft; onChange: (v: ConfigDraft) => void; errors: ErrorView }) {
  const id = useId();
  const st = value.settings ?? {};
  const strategy = String(st.strategy ?? "paper");
  const setSetting = (k: string, v: unknown) => onChange({ ...value, settings: { ...st, [k]: v } });
  const selecting = strategy === "ensemble-disagreement";
  return (
    <section className="panel" aria-label="Exploration" data-testid="exploration">
      <h2>Exploration</h2>
      <p className="hint">How each iteration chooses what the oracle replays (docs/active-learning.md).</p>
      <div className="row">
        <div className="field grow">
          <label htmlFor={id}>Strategy</label>
          <select
            id={id}
            value={strategy}
            onChange={(e) => {
              const next = e.target.value;
              // the stopping threshold and the candidates only mean something to ensemble-disagreement
              const stopping = next === "ensemble-disagreement" ? value.stopping : { ...value.stopping, min_disagreement: null };
              onChange({ ...value, settings: { ...st, strategy: next, ...(next === "paper" ? { batch: 1 } : {}) }, stopping });
            }}
            aria-invalid={errors.at("settings.strategy").length > 0}
          >
            {STRATEGIES.map(([k, label]) => (
              <option key={k} value={k}>
                {label}
              </option>
            ))}
          </select>
          <FieldMessages problems={errors.at("settings.strategy")} />
        </div>
      </div>
      <div className="row">
        <NumberField path="settings.batch" label="Batch q" hint="trajectories the oracle replays per iteration, in parallel (1 to 64; paper: 1)" value={st.batch} onChange={(v) => setSetting("batch", v)} errors={errors} integer />
        {selecting && (
          <>
            <NumberField path="settings.candidates" label="Candidates C" hint="scenarios solved and scored per iteration (1 to 64, at least q)" value={st.candidates} onChange={(v) => setSetting("candidates", v)} errors={errors} integer />
            <NumberField path="settings.min_distance" label="Min distance" hint="no two picks closer than this, ranged parameters scaled to [0, 1] (0 to 10)" value={st.min_distance} onChange={(v) => setSetting("min_distance", v)} errors={errors} />
          </>
        )}
        <NumberField
          path="settings.max_concurrent_oracle_jobs"
          label="Concurrency cap"
          hint="oracle jobs of this campaign at once (1 to 64; empty: no cap)"
          value={st.max_concurrent_oracle_jobs}
          onChange={(v) => setSetting("max_concurrent_oracle_jobs", v)}
          errors={errors}
          integer
          nullable
        />
        {selecting && (
          <NumberField
            path="stopping.min_disagreement"
            label="Stopping threshold [N]"
            hint="stop when the highest candidate score falls below this (above 0, at most 1e4 N; empty: never)"
            value={value.stopping?.min_disagreement}
            onChange={(v) => onChange({ ...value, stopping: { ...value.stopping, min_disagreement: v } })}
            errors={errors}
            nullable
          />
        )}
      </div>
    </section>
  );
}
