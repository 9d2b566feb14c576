import { useEffect, useMemo, useRef, useState, type FormEvent } from "react";
import { useNavigate, useParams } from "react-router-dom";
import { columns, isPreviewFinal, useCreateTaskPreview, usePreview, useSaveTask, useTask, useTaskPresets, useTaskSchema, validateTask, type TaskPreviewResult, type TaskSpecDraft } from "../api/hooks";
import { ApiError, errorMessage, type FieldError } from "../api/errors";
import { SchemaForm, type JsonSchema } from "../components/SchemaForm";
import { errorAt, PhasesTable, type PhaseRow } from "../task/PhasesTable";
import { ErrorBox, Loading } from "../components/States";
import { Plot, type Trace } from "../components/Plot";
import { phaseShapes } from "../campaign/TrajectoryPanel";
import { PreviewPanel } from "../components/PreviewPanel";

function toMap(errors: FieldError[], prefix = ""): Record<string, string> {
  const out: Record<string, string> = {};
  for (const e of errors) {
    const f = prefix && e.field.startsWith(prefix) ? e.field.slice(prefix.length) : e.field;
    out[f] = out[f] ? `${out[f]}; ${e.message}` : e.message;
  }
  return out;
}

/** Phase spans [t_start, t_end] from the durations, for shading the preview. */
export function phaseSpans(phases: PhaseRow[]): { name?: string; t_start: number; t_end: number }[] {
  let t = 0;
  return phases.map((p) => {
    const span = { name: p.name, t_start: t, t_end: t + (Number(p.duration) || 0) };
    t = span.t_end;
    return span;
  });
}

/** Rows (time) x joints -> one trace per joint (null samples are gaps). */
function jointTraces(t: number[], rows: (number | null)[][], name: string, unit: string): Trace[] {
  const cols = columns(rows as number[][]);
  return cols.map((y, j) => ({ x: t, y, name: cols.length > 1 ? `${name}_${j} [${unit}]` : `${name} [${unit}]`, mode: "lines", type: "scatter" }));
}

function SolvePreview({ result, phases }: { result: TaskPreviewResult; phases: PhaseRow[] }) {
  const shapes = useMemo(() => phaseShapes(phaseSpans(phases)), [phases]);
  const angle = useMemo(() => jointTraces(result.t, result.q, "θ", "rad"), [result]);
  const torque = useMemo(() => jointTraces(result.t, result.tau, "τ", "N m"), [result]);
  return (
    <div data-testid="solve-preview">
      <p className={result.converged ? "muted" : "error-text"} data-testid="solve-summary">
        IPOPT: {result.status}
        {result.converged ? "" : " (not converged)"} · {result.iterations} iterations
        {result.cost !== null && result.cost !== undefined ? ` · cost ${result.cost.toPrecision(4)}` : ""}
        {result.constraint_violation !== null && result.constraint_violation !== undefined ? ` · constraint violation ${result.constraint_violation.toExponential(1)}` : ""}
        {` · ${result.wall_time_s.toFixed(2)} s`}
        <span className="hint" data-testid="solve-grid">
          Grid: {result.grid ?? `${result.intervals} intervals`}
        </span>
      </p>
      <div className="grid2">
        <Plot testId="preview-angle" traces={angle} shapes={shapes} xTitle="t [s]" yTitle="joint angle θ [rad]" exportName="solve-angle" height={260} />
        <Plot testId="preview-torque" traces={torque} shapes={shapes} xTitle="t [s]" yTitle="joint torque τ [N m]" exportName="solve-torque" height={260} />
      </div>
    </div>
  );
}

export function TaskEditorPage() {
  const { id } = useParams();
  const editing = id !== undefined;
  const navigate = useNavigate();
  const presets = useTaskPresets();
  const schema = useTaskSchema();
  const existing = useTask(editing ? Number(id) : null);
  const save = useSaveTask(editing ? Number(id) : null);
  const solve = useCreateTaskPreview(editing ? Number(id) : null);
  const [previewId, setPreviewId] = useState<number | null>(null);
  const preview = usePreview(previewId);
  const solving = solve.isPending || (previewId !== null && !isPreviewFinal(preview.data));
  const [name, setName] = useState("");
  const [description, setDescription] = useState("");
  const [spec, setSpec] = useState<TaskSpecDraft | null>(null);
  const [validation, setValidation] = useState<FieldError[]>([]);
  const [validating, setValidating] = useState(false);
  const seq = useRef(0);

  useEffect(() => {
    if (existing.data) {
      setName(existing.data.name);
      setDescription(existing.data.description ?? "");
      setSpec(existing.data.spec);
    }
  }, [existing.data]);
  useEffect(() => {
    if (!editing && spec === null && presets.data?.length) setSpec(structuredClone(presets.data[0].spec));
  }, [editing, spec, presets.data]);

  // Inline validation: ask the API (which knows the science rules) 400 ms after the last edit.
  useEffect(() => {
    if (!spec) return;
    const mine = ++seq.current;
    setValidating(true);
    const timer = setTimeout(() => {
      validateTask({ name: name || "untitled", description, spec })
        .then((errors) => mine === seq.current && setValidation(errors))
        .catch((err) => mine === seq.current && setValidation([{ field: "", message: errorMessage(err) }]))
        .finally(() => mine === seq.current && setValidating(false));
    }, 400);
    return () => clearTimeout(timer);
  }, [spec, name, description]);

  const errors = useMemo(() => {
    const fromSave = save.error instanceof ApiError ? save.error.fieldErrors : [];
    const fromSolve = solve.error instanceof ApiError ? solve.error.fieldErrors : [];
    return toMap([...validation, ...fromSave, ...fromSolve], "spec.");
  }, [validation, save.error, solve.error]);

  function solveOnce() {
    if (!spec) return;
    setPreviewId(null);
    // the task as it is on screen: an unsaved edit is sent along, else the saved version is solved
    const edited = JSON.stringify(spec) !== JSON.stringify(existing.data?.spec);
    solve.mutate(edited ? { spec } : {}, { onSuccess: (p) => setPreviewId(p.id) });
  }

  async function submit(e: FormEvent) {
    e.preventDefault();
    if (!spec) return;
    const saved = await save.mutateAsync({ name, description, spec });
    navigate(`/tasks/${saved.id}`);
  }

  if (presets.isPending || (editing && existing.isPending)) return <Loading />;
  if (presets.isError) return <ErrorBox error={presets.error} retry={() => void presets.refetch()} />;
  if (existing.isError) return <ErrorBox error={existing.error} />;
  if (!spec) return <Loading />;

  const modelSchema = (schema.data?.$defs?.ModelSpec ?? null) as JsonSchema | null;
  const modelErrors = Object.fromEntries(Object.entries(errors).filter(([k]) => k.startsWith("model.")).map(([k, v]) => [k.slice(6), v]));
  const general = Object.entries(errors).filter(([k]) => !k.startsWith("model.") && !k.startsWith("phases.") && k !== "name");
  const phases = (spec.phases ?? []) as PhaseRow[];

  return (
    <form onSubmit={submit}>
      <div className="toolbar">
        <h1 style={{ margin: 0 }}>{editing ? `Task: ${name}` : "New task"}</h1>
        {existing.data?.version !== undefined && <span className="badge">version {existing.data.version}</span>}
        <span className={validation.length ? "badge bad" : "badge ok"} data-testid="validation-state" aria-live="polite">
          {validating ? "checking…" : validation.length ? `${validation.length} problem(s)` : "valid"}
        </span>
        <span className="spacer" />
        {!editing && (
          <>
            <label htmlFor="preset">Start from preset</label>
            <select id="preset" onChange={(e) => setSpec(structuredClone(presets.data.find((p) => p.name === e.target.value)?.spec ?? spec))}>
              {presets.data.map((p) => (
                <option key={p.name} value={p.name}>
                  {p.name}
                </option>
              ))}
            </select>
          </>
        )}
        <button
          type="button"
          disabled={!editing || solving || validation.length > 0}
          title={editing ? "Solve the task as shown once with the auxiliary contact, on a worker" : "Create the task first; then edits can be previewed before saving"}
          onClick={solveOnce}
        >
          {solving ? "Solving…" : "Solve once"}
        </button>
        <button type="submit" className="primary" disabled={save.isPending}>
          {editing ? "Save (new version if used)" : "Create task"}
        </button>
      </div>
      {save.isError && (
        <p className="error-text" role="alert">
          {errorMessage(save.error)}
        </p>
      )}
      {general.length > 0 && (
        <ul className="error-text" role="alert" data-testid="general-errors">
          {general.map(([k, v]) => (
            <li key={k}>
              {k ? `${k}: ` : ""}
              {v}
            </li>
          ))}
        </ul>
      )}
      <section className="panel">
        <div className="row">
          <div className="field grow">
            <label htmlFor="task-name">Name</label>
            <input id="task-name" value={name} onChange={(e) => setName(e.target.value)} required maxLength={200} />
            {errors["name"] && <small className="field-error">{errors["name"]}</small>}
          </div>
          <div className="field grow">
            <label htmlFor="task-description">Description</label>
            <input id="task-description" value={description} onChange={(e) => setDescription(e.target.value)} />
          </div>
        </div>
      </section>
      <section className="panel" aria-labelledby="model-title">
        <h2 id="model-title">Model</h2>
        {modelSchema ? (
          <SchemaForm schema={{ ...modelSchema, $defs: schema.data?.$defs }} value={(spec.model ?? {}) as Record<string, unknown>} onChange={(model) => setSpec({ ...spec, model })} errors={modelErrors} />
        ) : schema.isPending ? (
          <Loading />
        ) : (
          <p className="muted">The API offers no schema for the model; it is kept as in the preset.</p>
        )}
      </section>
      <section className="panel" aria-labelledby="phases-title">
        <h2 id="phases-title">Phases</h2>
        <p className="hint">
          Running cost per phase: w_τ τᵀτ + w_T T (kinetic energy). Empty bounds use the model's joint range and torque limit. Total{" "}
          {phases.reduce((s, p) => s + (Number(p.duration) || 0), 0).toFixed(3)} s, {phases.reduce((s, p) => s + (Number(p.intervals) || 0), 0)} intervals.
        </p>
        <PhasesTable phases={phases} onChange={(p) => setSpec({ ...spec, phases: p })} errors={errors} />
      </section>
      <section className="panel" aria-labelledby="bc-title">
        <h2 id="bc-title">Start and end</h2>
        <div className="row">
          <BoundaryFields title="Initial state" value={(spec.initial ?? {}) as Record<string, unknown>} fields={["q", "qd"]} velocityOptions={["given", "free"]} errors={errors} prefix="initial" onChange={(initial) => setSpec({ ...spec, initial })} />
          <BoundaryFields title="Final condition" value={(spec.final ?? {}) as Record<string, unknown>} fields={["q"]} velocityOptions={["rest", "free"]} errors={errors} prefix="final" onChange={(final) => setSpec({ ...spec, final })} />
        </div>
      </section>
      <PreviewPanel<TaskPreviewResult>
        id={previewId}
        title="Solve once (auxiliary contact)"
        startError={solve.error}
        render={(result) => <SolvePreview result={result} phases={phases} />}
      />
    </form>
  );
}

function BoundaryFields({
  title,
  value,
  fields,
  velocityOptions,
  errors,
  prefix,
  onChange,
}: {
  title: string;
  value: Record<string, unknown>;
  fields: string[];
  velocityOptions: string[];
  errors: Record<string, string>;
  prefix: string;
  onChange: (v: Record<string, unknown>) => void;
}) {
  return (
    <fieldset className="grow" style={{ border: "1px solid var(--line)", borderRadius: 6 }}>
      <legend>{title}</legend>
      <div className="field">
        <label htmlFor={`${prefix}-velocity`}>velocity</label>
        <select id={`${prefix}-velocity`} value={String(value.velocity ?? velocityOptions[0])} onChange={(e) => onChange({ ...value, velocity: e.target.value })}>
          {velocityOptions.map((o) => (
            <option key={o}>{o}</option>
          ))}
        </select>
      </div>
      {fields.map((f) => (
        <div className="field" key={f}>
          <label htmlFor={`${prefix}-${f}`}>{f} (blank: default)</label>
          <input
            id={`${prefix}-${f}`}
            defaultValue={Array.isArray(value[f]) ? (value[f] as number[]).join(", ") : ""}
            onBlur={(e) => {
              const parts = e.target.value.split(",").map((s) => s.trim()).filter(Boolean);
              onChange({ ...value, [f]: parts.length ? parts.map(Number) : null });
            }}
            aria-invalid={Boolean(errorAt(errors, `${prefix}.${f}`))}
          />
          {errorAt(errors, `${prefix}.${f}`) && <small className="field-error">{errorAt(errors, `${prefix}.${f}`)}</small>}
        </div>
      ))}
    </fieldset>
  );
}
