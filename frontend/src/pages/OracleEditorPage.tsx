import { useEffect, useMemo, useRef, useState, type FormEvent } from "react";
import { useNavigate, useParams } from "react-router-dom";
import { columns, isPreviewFinal, useCreateOraclePreview, useOracle, useOracleTypes, usePreview, useSaveOracle, validateOracle, type OraclePreviewResult } from "../api/hooks";
import { ApiError, errorMessage, type FieldError } from "../api/errors";
import { SchemaForm, schemaDefaults } from "../components/SchemaForm";
import { ErrorBox, Loading } from "../components/States";
import { Plot, type Trace } from "../components/Plot";
import { PreviewPanel } from "../components/PreviewPanel";

function errorsByField(error: unknown, prefix: string): Record<string, string> {
  if (!(error instanceof ApiError)) return {};
  const out: Record<string, string> = {};
  for (const e of error.fieldErrors) {
    const f = e.field.startsWith(prefix) ? e.field.slice(prefix.length) : e.field;
    out[f] = e.message;
  }
  return out;
}

const FORCE = ["fx", "fy", "fz"] as const;
const MOMENT = ["mx", "my", "mz"] as const;
const Y2 = { yaxis2: { title: { text: "moment [N m]" }, overlaying: "y" as const, side: "right" as const }, margin: { l: 64, r: 72, t: 32, b: 44 } };
const seconds = (s: number) => (s < 0.1 ? `${(s * 1000).toFixed(0)} ms` : `${s.toFixed(2)} s`);

function TestPreview({ result }: { result: OraclePreviewResult }) {
  const motion: Trace[] = useMemo(() => {
    const q = columns(result.trajectory.q as number[][]);
    return q.map((y, j) => ({ x: result.trajectory.t, y, name: q.length > 1 ? `θ_${j} [rad]` : "θ [rad]", mode: "lines", type: "scatter" }));
  }, [result]);
  const wrench: Trace[] = useMemo(() => {
    if (!result.t) return [];
    const t = result.t;
    // components that are zero throughout (e.g. fy, mx, mz of a planar oracle) are left out
    const nonzero = (y: (number | null)[] | null | undefined): y is (number | null)[] => Boolean(y?.some((v) => v !== null && v !== 0));
    return [
      ...FORCE.filter((c) => nonzero(result[c])).map((c): Trace => ({ x: t, y: result[c] as number[], name: `${c} [N]`, mode: "lines", type: "scatter" })),
      ...MOMENT.filter((c) => nonzero(result[c])).map((c): Trace => ({ x: t, y: result[c] as number[], name: `${c} [N m]`, mode: "lines", type: "scatter", line: { dash: "dot" }, yaxis: "y2" })),
    ];
  }, [result]);
  return (
    <div data-testid="oracle-test-result">
      <p className={result.ok ? "muted" : "error-text"} data-testid="oracle-test-summary">
        {result.ok ? "The oracle ran" : `The oracle failed: ${result.failure_reason ?? "no reason given"}`} in {seconds(result.wall_time_s)} on the sample trajectory (the FE
        reference head motion: clear of the headrest, into the cushion and back)
        {result.peak_force_n !== null && result.peak_force_n !== undefined ? `; peak force ${result.peak_force_n.toFixed(1)} N` : ""}.
      </p>
      <div className="grid2">
        <Plot testId="oracle-test-motion" traces={motion} xTitle="t [s]" yTitle="joint angle θ [rad]" exportName="oracle-test-motion" height={280} />
        {wrench.length > 0 ? (
          <Plot testId="oracle-test-plot" traces={wrench} xTitle="t [s]" yTitle="force on the head [N]" exportName="oracle-test" height={280} extraLayout={Y2} />
        ) : (
          <p className="muted">No force and moment: the run failed.</p>
        )}
      </div>
    </div>
  );
}

export function OracleEditorPage() {
  const { id } = useParams();
  const editing = id !== undefined;
  const navigate = useNavigate();
  const types = useOracleTypes();
  const existing = useOracle(editing ? Number(id) : null);
  const save = useSaveOracle(editing ? Number(id) : null);
  const test = useCreateOraclePreview(editing ? Number(id) : null);
  const [previewId, setPreviewId] = useState<number | null>(null);
  const preview = usePreview(previewId);
  const testing = test.isPending || (previewId !== null && !isPreviewFinal(preview.data));
  const [name, setName] = useState("");
  const [description, setDescription] = useState("");
  const [type, setType] = useState("");
  const [params, setParams] = useState<Record<string, unknown>>({});
  const [validation, setValidation] = useState<FieldError[]>([]);
  const seq = useRef(0);

  // Inline validation by the API, 400 ms after the last edit.
  useEffect(() => {
    if (!type) return;
    const mine = ++seq.current;
    const timer = setTimeout(() => {
      validateOracle({ type, params })
        .then((errors) => mine === seq.current && setValidation(errors))
        .catch((err) => mine === seq.current && setValidation([{ field: "", message: errorMessage(err) }]));
    }, 400);
    return () => clearTimeout(timer);
  }, [type, params]);

  useEffect(() => {
    if (existing.data) {
      setName(existing.data.name);
      setDescription(existing.data.description ?? "");
      setType(existing.data.type);
      setParams(existing.data.params ?? {});
    }
  }, [existing.data]);

  const typeInfo = types.data?.find((t) => t.name === type);
  useEffect(() => {
    if (!editing && !type && types.data?.length) {
      const first = types.data.find((t) => t.available) ?? types.data[0];
      setType(first.name);
      setParams(schemaDefaults(first.schema));
    }
  }, [types.data, type, editing]);

  const fieldErrors = {
    ...Object.fromEntries(validation.map((e) => [e.field.replace(/^params\./, ""), e.message])),
    ...errorsByField(save.error, "params."),
    ...errorsByField(test.error, "params."),
  };

  async function submit(e: FormEvent) {
    e.preventDefault();
    const saved = await save.mutateAsync({ name, description, type, params });
    navigate(`/oracles/${saved.id}`);
  }

  if (types.isPending || (editing && existing.isPending)) return <Loading />;
  if (types.isError) return <ErrorBox error={types.error} retry={() => void types.refetch()} />;
  if (existing.isError) return <ErrorBox error={existing.error} />;

  return (
    <form onSubmit={submit}>
      <div className="toolbar">
        <h1 style={{ margin: 0 }}>{editing ? `Oracle: ${name}` : "New oracle"}</h1>
        {existing.data?.version !== undefined && <span className="badge">version {existing.data.version}</span>}
        <span className="spacer" />
        <span className={validation.length ? "badge bad" : "badge ok"} data-testid="validation-state" aria-live="polite">
          {validation.length ? `${validation.length} problem(s)` : "valid"}
        </span>
        <button
          type="button"
          disabled={!editing || testing || validation.length > 0}
          title={editing ? "Run the oracle with the parameters as shown on a sample trajectory, on a worker" : "Create the oracle first; then edits can be tested before saving"}
          onClick={() => {
            setPreviewId(null);
            // the parameters as shown; unchanged ones: the saved version
            const edited = JSON.stringify(params) !== JSON.stringify(existing.data?.params ?? {});
            test.mutate(edited ? { params } : {}, { onSuccess: (p) => setPreviewId(p.id) });
          }}
        >
          {testing ? "Testing…" : "Test on a sample trajectory"}
        </button>
        <button type="submit" className="primary" disabled={save.isPending}>
          {editing ? "Save (new version if used)" : "Create oracle"}
        </button>
      </div>
      {save.isError && (
        <p className="error-text" role="alert">
          {errorMessage(save.error)}
        </p>
      )}
      {validation.some((e) => !e.field.startsWith("params.")) && (
        <ul className="error-text" role="alert">
          {validation
            .filter((e) => !e.field.startsWith("params."))
            .map((e, i) => (
              <li key={i}>
                {e.field ? `${e.field}: ` : ""}
                {e.message}
              </li>
            ))}
        </ul>
      )}
      <section className="panel">
        <div className="row">
          <div className="field grow">
            <label htmlFor="oracle-name">Name</label>
            <input id="oracle-name" value={name} onChange={(e) => setName(e.target.value)} required maxLength={200} aria-invalid={Boolean(fieldErrors["name"])} />
            {fieldErrors["name"] && <small className="field-error">{fieldErrors["name"]}</small>}
          </div>
          <div className="field">
            <label htmlFor="oracle-type">Type</label>
            <select
              id="oracle-type"
              value={type}
              disabled={editing}
              onChange={(e) => {
                setType(e.target.value);
                const t = types.data.find((x) => x.name === e.target.value);
                setParams(t ? schemaDefaults(t.schema) : {});
              }}
            >
              {types.data.map((t) => (
                <option key={t.name} value={t.name} disabled={!t.available}>
                  {t.name}
                  {t.kind === "command" ? " (command)" : ""}
                  {t.available ? "" : " — unavailable"}
                </option>
              ))}
            </select>
          </div>
        </div>
        {typeInfo?.description && <p className="muted">{typeInfo.description}</p>}
        <div className="field">
          <label htmlFor="oracle-description">Description</label>
          <textarea id="oracle-description" rows={2} value={description} onChange={(e) => setDescription(e.target.value)} />
        </div>
      </section>
      <section className="panel" aria-labelledby="params-title">
        <h2 id="params-title">Parameters</h2>
        {typeInfo ? <SchemaForm schema={typeInfo.schema} value={params} onChange={setParams} errors={fieldErrors} /> : <p className="muted">Choose a type.</p>}
      </section>
      <PreviewPanel<OraclePreviewResult> id={previewId} title="Test on a sample trajectory" startError={test.error} render={(result) => <TestPreview result={result} />} />
    </form>
  );
}
