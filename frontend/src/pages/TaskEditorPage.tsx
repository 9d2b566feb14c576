import { useEffect, useMemo, useState } from "react";
import { useNavigate, useParams } from "react-router-dom";
import { useModelPresets, useSaveTask, useScenarioPreview, useTask, useTaskPresets, useTaskSchema, checkTask } from "../api/definitions";
import { isPreviewFinal, useCreateTaskPreview, usePreview } from "../api/previews";
import { columns, type ModelPreset, type Task, type TaskPreset, type TaskPreviewResult, type TaskSpecDraft } from "../api/types";
import { errorMessage, type FieldError } from "../api/errors";
import { FieldMessages, parseNumberList, SchemaForm, schemaFieldPaths, schemaLocalErrors, type JsonSchema } from "../components/SchemaForm";
import { PhasesTable, phaseFieldPaths, phaseLocalErrors, type PhaseRow } from "../task/PhasesTable";
import { ScenarioRanges, rangeFieldPaths, rangeLocalErrors, type RangeRow } from "../task/ScenarioRanges";
import { ErrorBox, Loading } from "../components/States";
import { Plot, type Trace } from "../components/Plot";
import { ChainDrawing } from "../components/ChainDrawing";
import { ChainPlayer } from "../components/ChainPlayer";
import { ChainEditor, chainFieldPaths, chainLocalErrors } from "../task/ChainEditor";
import { initialPose, isChainModel, oneDofAsChain, resolveModel } from "../lib/kinematics";
import { phaseShapes } from "../campaign/TrajectoryPanel";
import { PreviewPanel } from "../components/PreviewPanel";
import { useUnsavedWarning } from "../lib/unsaved";
import { DefinitionEditor } from "../components/DefinitionEditor";
import { generalFailure, serverProblems } from "../components/FormErrors";
import { cleanName, errorView, nameProblems, schemaLabel, type ErrorView } from "../lib/formErrors";

/** Paths of the body (`spec.phases.0.duration`) as the form's (`phases.0.duration`); name and description stay. */
function specPaths(errors: FieldError[]): FieldError[] {
  return errors.map((e) => (e.field.startsWith("spec.") ? { ...e, field: e.field.slice(5) } : e));
}

const BOUNDARY_FIELDS = ["initial.velocity", "initial.q", "initial.qd", "final.velocity", "final.q"];

function listProblems(spec: TaskSpecDraft): FieldError[] {
  const out: FieldError[] = [];
  for (const path of ["initial.q", "initial.qd", "final.q"]) {
    const [a, b] = path.split(".");
    const v = (spec[a] as Record<string, unknown> | undefined)?.[b];
    if (Array.isArray(v)) v.forEach((x, i) => typeof x === "number" && Number.isFinite(x) ? null : out.push({ field: `${path}.${i}`, message: "must be a number" }));
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

/** Rows (time) x 6 -> the force components fx, fz in the headrest frame (null rows: gaps). */
function forceColumns(rows: (number | null)[][] | null | undefined): { fx: (number | null)[]; fz: (number | null)[] } | null {
  if (!rows?.length) return null;
  return { fx: rows.map((r) => r[0]), fz: rows.map((r) => r[2]) };
}

function SolvePreview({ result, phases, model }: { result: TaskPreviewResult; phases: PhaseRow[]; model: Record<string, unknown> | undefined }) {
  const shapes = useMemo(() => phaseShapes(phaseSpans(phases)), [phases]);
  const angle = useMemo(() => jointTraces(result.t, result.q, "θ", "rad"), [result]);
  const torque = useMemo(() => jointTraces(result.t, result.tau, "τ", "N m"), [result]);
  const force = useMemo(() => forceColumns(result.wrench), [result]);
  const forceTraces = useMemo<Trace[]>(
    () =>
      force
        ? [
            { x: result.t, y: force.fx, name: "fx (normal) [N]", mode: "lines", type: "scatter", line: { color: "#2f5bd3" } },
            { x: result.t, y: force.fz, name: "fz (along the surface) [N]", mode: "lines", type: "scatter", line: { color: "#d3662f", dash: "longdash" } },
          ]
        : [],
    [force, result.t],
  );
  const chain = useMemo(() => resolveModel(model), [model]);
  const rows = useMemo(() => result.q.map((r) => r.map((v) => v ?? Number.NaN)), [result]);
  const [index, setIndex] = useState(0);
  const cursor = result.t[Math.min(index, result.t.length - 1)];
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
        <Plot testId="preview-angle" traces={angle} shapes={shapes} xTitle="t [s]" yTitle="joint angle θ [rad]" exportName="solve-angle" height={260} cursorX={chain ? cursor : null} />
        <Plot testId="preview-torque" traces={torque} shapes={shapes} xTitle="t [s]" yTitle="joint torque τ [N m]" exportName="solve-torque" height={260} cursorX={chain ? cursor : null} />
      </div>
      <div className="grid2">
        {chain ? (
          <ChainPlayer chain={chain} t={result.t} q={rows} force={force} index={index} setIndex={setIndex} testId="preview-player" label="The solution" />
        ) : (
          <p className="muted">The model of this solution cannot be drawn (a number is missing).</p>
        )}
        {force && <Plot testId="preview-force" traces={forceTraces} shapes={shapes} xTitle="t [s]" yTitle="contact force on the head [N]" exportName="solve-force" height={300} cursorX={chain ? cursor : null} />}
      </div>
    </div>
  );
}

export function TaskEditorPage() {
  const { id } = useParams();
  const editing = id !== undefined;
  const presets = useTaskPresets();
  const existing = useTask(editing ? Number(id) : null);
  if (presets.isPending || (editing && existing.isPending)) return <Loading />;
  if (presets.isError) return <ErrorBox error={presets.error} retry={() => void presets.refetch()} />;
  if (existing.isError) return <ErrorBox error={existing.error} />;
  if (!editing && !presets.data.length) return <ErrorBox error="the API offers no task preset to start from" />;
  // a new form for each task (and one for a new task): the draft starts from what was loaded
  return <TaskEditor key={existing.data?.id ?? "new"} existing={existing.data} presets={presets.data} />;
}

function TaskEditor({ existing, presets }: { existing: Task | undefined; presets: TaskPreset[] }) {
  const navigate = useNavigate();
  const taskId = existing?.id ?? null;
  const schema = useTaskSchema();
  const save = useSaveTask(taskId);
  const solve = useCreateTaskPreview(taskId);
  const sample = useScenarioPreview(taskId);
  const [previewId, setPreviewId] = useState<number | null>(null);
  const preview = usePreview(previewId);
  const modelPresets = useModelPresets();
  // the model the previewed solution was solved with (the drawing plays it back)
  const [solvedModel, setSolvedModel] = useState<Record<string, unknown> | undefined>(undefined);
  // bumped when the number of joints changes: the per-joint list fields (typed text) start afresh
  const [jointsKey, setJointsKey] = useState(0);
  const solving = solve.isPending || (previewId !== null && !isPreviewFinal(preview.data));
  const [name, setName] = useState(existing?.name ?? "");
  const [description, setDescription] = useState(existing?.description ?? "");
  const [spec, setSpec] = useState<TaskSpecDraft>(() => structuredClone((existing?.spec ?? presets[0].spec) as TaskSpecDraft));
  const [checked, setChecked] = useState<{ key: string; errors: FieldError[] } | null>(null);
  // the draft the last save sent: its refused problems apply while the form still shows that draft
  const [sentKey, setSentKey] = useState<string | null>(null);

  // Inline checks: ask the API (which knows the science rules) 400 ms after the last edit.
  const draftKey = JSON.stringify([name, description, spec]);
  // the draft as loaded or last saved: anything else is an unsaved edit, and leaving the page asks first
  const [baseline, setBaseline] = useState(draftKey);
  useUnsavedWarning(draftKey !== baseline);
  useEffect(() => {
    let current = true;
    const timer = setTimeout(() => {
      checkTask({ name: cleanName(name) || "untitled", description, spec })
        .then((errors) => current && setChecked({ key: draftKey, errors }))
        .catch((err) => current && setChecked({ key: draftKey, errors: [{ field: "", message: errorMessage(err) }] }));
    }, 400);
    return () => {
      current = false;
      clearTimeout(timer);
    };
  }, [draftKey, name, description, spec]);
  const checking = checked?.key !== draftKey;

  const root = schema.data;
  const fullModelSchema = (root?.$defs?.ModelSpec ?? null) as JsonSchema | null;
  const preset = (spec.model as { preset?: string } | undefined)?.preset ?? "head-neck-1dof";
  // the head-neck-1dof preset has no chain: its form does not show the (empty) chain group
  const modelSchema = useMemo(() => modelFormSchema(fullModelSchema, preset), [fullModelSchema, preset]);
  const chainModel = isChainModel(spec.model);
  const chainSpec = useMemo(() => (chainModel ? ((spec.model?.chain ?? {}) as Record<string, unknown>) : undefined), [chainModel, spec.model]);
  const phaseSchema = (root?.$defs?.PhaseSpec ?? null) as JsonSchema | null;
  const phases = useMemo(() => (spec.phases ?? []) as PhaseRow[], [spec.phases]);
  const ranges = useMemo(() => (spec.ranges ?? []) as RangeRow[], [spec.ranges]);
  const view: ErrorView = useMemo(() => {
    const local = [
      ...nameProblems(name),
      ...(modelSchema && root ? schemaLocalErrors(modelSchema, spec.model, root, "model") : []),
      ...chainLocalErrors(chainSpec, root),
      ...phaseLocalErrors(phases, phaseSchema, root),
      ...listProblems(spec),
      ...rangeLocalErrors(ranges),
    ];
    const known = ["name", "description", "phases", ...(modelSchema && root ? schemaFieldPaths(modelSchema, root, "model") : []), ...(chainSpec ? chainFieldPaths(chainSpec, root) : []), ...phaseFieldPaths(phases), ...BOUNDARY_FIELDS, ...rangeFieldPaths(ranges)];
    const label = (p: string) => (p === "name" ? "Name" : p === "description" ? "Description" : root ? schemaLabel(root, p) : p);
    return errorView(
      [local, specPaths(checked?.errors ?? []), specPaths(sentKey === draftKey ? serverProblems(save.error) : []), specPaths(serverProblems(solve.error)), specPaths(serverProblems(sample.error))],
      known,
      label,
    );
  }, [name, modelSchema, chainSpec, phaseSchema, root, spec, phases, ranges, checked, sentKey, draftKey, save.error, solve.error, sample.error]);

  const drawn = useMemo(() => resolveModel(spec.model), [spec.model]);
  const initialQ = (spec.initial as { q?: unknown } | undefined)?.q;

  /** A model edit; a new preset loads that preset's model (a user-defined chain starts from the model on screen). */
  function changeModel(model: Record<string, unknown>) {
    const next = (model.preset as string | undefined) ?? "head-neck-1dof";
    if (next === preset) return setSpec({ ...spec, model });
    let fresh: Record<string, unknown> | null = null;
    if (next === "chain") fresh = chainModel ? { preset: "chain", chain: spec.model?.chain } : oneDofAsChain(spec.model ?? {});
    else fresh = structuredClone(modelPresets.data?.find((p: ModelPreset) => p.key === next)?.model ?? null) as Record<string, unknown> | null;
    if (!fresh) return setSpec({ ...spec, model });
    save.reset(); // a refused save's problems concerned the other model
    const joints = (m: Record<string, unknown> | undefined) => (isChainModel(m) ? ((m?.chain as { links?: unknown[] } | undefined)?.links?.length ?? 0) : 1);
    setSpec(joints(fresh) === joints(spec.model) ? { ...spec, model: fresh } : withoutJointLists({ ...spec, model: fresh }));
    if (joints(fresh) !== joints(spec.model)) setJointsKey((k) => k + 1);
  }

  function solveOnce() {
    setPreviewId(null);
    // the task as it is on screen: an unsaved edit is sent along, else the saved version is solved
    const edited = JSON.stringify(spec) !== JSON.stringify(existing?.spec);
    const model = spec.model;
    solve.mutate(edited ? { spec } : {}, {
      onSuccess: (p) => {
        setSolvedModel(model);
        setPreviewId(p.id);
      },
    });
  }

  function previewScenarios() {
    // the ranges as they are on screen (an unsaved edit is sent along)
    const edited = JSON.stringify(spec) !== JSON.stringify(existing?.spec);
    sample.mutate(edited ? { n: 5, seed: 0, spec } : { n: 5, seed: 0 });
  }

  function onSave() {
    if (nameProblems(name).length) return; // named at the field; the API would refuse it too
    setSentKey(draftKey);
    const sent = draftKey;
    save.mutate(
      { name: cleanName(name), description, spec },
      {
        onSuccess: (saved) => {
          setBaseline(sent);
          navigate(`/tasks/${saved.id}`);
        },
      },
    );
  }

  return (
    <DefinitionEditor
      kind="task"
      noun="task"
      existing={existing}
      name={name}
      setName={setName}
      description={description}
      setDescription={setDescription}
      errors={view}
      checking={checking}
      failure={save.error}
      saving={save.isPending}
      onSave={onSave}
      actions={
        <>
          {!existing && (
            <>
              <label htmlFor="preset">Start from preset</label>
              <select id="preset" onChange={(e) => setSpec(structuredClone((presets.find((p) => p.key === e.target.value)?.spec ?? spec) as TaskSpecDraft))}>
                {presets.map((p) => (
                  <option key={p.key} value={p.key}>
                    {p.key}
                  </option>
                ))}
              </select>
            </>
          )}
          <button
            type="button"
            disabled={!existing || solving || view.problems.length > 0}
            title={existing ? "Solve the task as shown once with the auxiliary contact, on a worker" : "Create the task first; then edits can be previewed before saving"}
            onClick={solveOnce}
          >
            {solving ? "Solving…" : "Solve once"}
          </button>
        </>
      }
    >
      <section className="panel" aria-labelledby="model-title">
        <h2 id="model-title">Model</h2>
        <div className="model-with-drawing">
          <div>
            {modelSchema && root ? (
              <SchemaForm schema={{ ...modelSchema, $defs: root.$defs }} value={(spec.model ?? {}) as Record<string, unknown>} onChange={changeModel} errors={view} prefix="model" />
            ) : schema.isPending ? (
              <Loading />
            ) : (
              <p className="muted">The API offers no schema for the model; it is kept as in the preset.</p>
            )}
          </div>
          <div>
            {drawn ? (
              <ChainDrawing chain={drawn} q={initialPose(drawn, initialQ)} testId="model-drawing" label="The model at the initial pose" />
            ) : (
              <p className="muted" data-testid="model-drawing-missing">
                The drawing appears when every number of the model is given.
              </p>
            )}
            <p className="hint">At the initial pose (x forward to the right, z up): links and joints, the head with its occipital profile (blue), the headrest cushion (orange).</p>
          </div>
        </div>
        {chainSpec && root && <ChainEditor key={`chain-${jointsKey}`} chain={chainSpec} root={root} errors={view} onChange={(chain) => setSpec({ ...spec, model: { ...spec.model, chain } })} />}
      </section>
      <section className="panel" aria-labelledby="phases-title">
        <h2 id="phases-title">Phases</h2>
        <p className="hint">
          Running cost per phase: w_τ τᵀτ + w_T T (kinetic energy). Empty bounds use the model&apos;s joint range and torque limit. Total{" "}
          {phases.reduce((s, p) => s + (Number(p.duration) || 0), 0).toFixed(3)} s, {phases.reduce((s, p) => s + (Number(p.intervals) || 0), 0)} intervals.
        </p>
        <PhasesTable key={`phases-${jointsKey}`} phases={phases} onChange={(p) => setSpec({ ...spec, phases: p })} errors={view} />
      </section>
      <section className="panel" aria-labelledby="bc-title">
        <h2 id="bc-title">Start and end</h2>
        <div className="row" key={`bc-${jointsKey}`}>
          <BoundaryFields title="Initial state" value={(spec.initial ?? {}) as Record<string, unknown>} fields={["q", "qd"]} velocityOptions={["given", "free"]} errors={view} prefix="initial" onChange={(initial) => setSpec({ ...spec, initial })} />
          <BoundaryFields title="Final condition" value={(spec.final ?? {}) as Record<string, unknown>} fields={["q"]} velocityOptions={["rest", "free"]} errors={view} prefix="final" onChange={(final) => setSpec({ ...spec, final })} />
        </div>
      </section>
      <ScenarioRanges
        ranges={ranges}
        onChange={(r) => setSpec({ ...spec, ranges: r })}
        errors={view}
        preview={sample.data}
        previewing={sample.isPending}
        onPreview={previewScenarios}
        canPreview={!!existing && view.problems.length === 0}
        previewError={generalFailure(sample.error)}
      />
      <PreviewPanel<TaskPreviewResult>
        id={previewId}
        title="Solve once (auxiliary contact)"
        startError={generalFailure(solve.error) ? solve.error : undefined}
        render={(result) => <SolvePreview result={result} phases={phases} model={solvedModel ?? spec.model} />}
      />
    </DefinitionEditor>
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
  errors: ErrorView;
  prefix: string;
  onChange: (v: Record<string, unknown>) => void;
}) {
  return (
    <fieldset className="grow" style={{ border: "1px solid var(--line)", borderRadius: 6 }}>
      <legend>{title}</legend>
      <div className="field">
        <label htmlFor={`${prefix}-velocity`}>velocity</label>
        <select id={`${prefix}-velocity`} value={String(value.velocity ?? velocityOptions[0])} onChange={(e) => onChange({ ...value, velocity: e.target.value })} aria-invalid={errors.at(`${prefix}.velocity`).length > 0}>
          {velocityOptions.map((o) => (
            <option key={o}>{o}</option>
          ))}
        </select>
        <FieldMessages problems={errors.at(`${prefix}.velocity`)} />
      </div>
      {fields.map((f) => (
        <div className="field" key={f}>
          <label htmlFor={`${prefix}-${f}`}>{f} (blank: default)</label>
          <input
            id={`${prefix}-${f}`}
            defaultValue={Array.isArray(value[f]) ? (value[f] as number[]).join(", ") : ""}
            onBlur={(e) => onChange({ ...value, [f]: parseNumberList(e.target.value) })}
            aria-invalid={errors.at(`${prefix}.${f}`).length > 0}
          />
          <FieldMessages problems={errors.at(`${prefix}.${f}`)} item="joint" />
        </div>
      ))}
    </fieldset>
  );
}

/** The model's form: the head-neck-1dof preset's parameters (without the chain group, which
 * must stay null), or for a chain model the preset alone (the chain editor shows the chain; the
 * 1-DOF parameters do not apply). */
function modelFormSchema(schema: JsonSchema | null, preset: string): JsonSchema | null {
  if (!schema?.properties) return schema;
  if (preset === "head-neck-1dof") {
    const properties = { ...schema.properties };
    delete properties.chain;
    return { ...schema, properties };
  }
  return { ...schema, properties: { preset: schema.properties.preset } };
}

/** The task with every per-joint list back to its default (the number of joints changed). */
function withoutJointLists(spec: TaskSpecDraft): TaskSpecDraft {
  const clear = (o: unknown, keys: string[]) => (o && typeof o === "object" ? { ...(o as Record<string, unknown>), ...Object.fromEntries(keys.map((k) => [k, null])) } : o);
  return {
    ...spec,
    phases: (spec.phases ?? []).map((p) => clear(p, ["q_min", "q_max", "tau_max", "target_q"])),
    initial: clear(spec.initial, ["q", "qd"]),
    final: clear(spec.final, ["q"]),
    endpoint_cost: spec.endpoint_cost ? clear(spec.endpoint_cost, ["q_ref"]) : spec.endpoint_cost,
    ranges: Array.isArray(spec.ranges) ? spec.ranges.filter((r) => !/^(initial|final)\.q/.test(String((r as { parameter?: unknown }).parameter ?? ""))) : spec.ranges,
  };
}
