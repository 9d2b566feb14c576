import { useEffect, useMemo, useState } from "react";
import { useNavigate, useParams } from "react-router-dom";
import { useOracle, useOracleTypes, useSaveOracle, checkOracle } from "../api/definitions";
import { isPreviewFinal, useCreateOraclePreview, usePreview } from "../api/previews";
import { columns, type Oracle, type OraclePreviewResult, type OracleType } from "../api/types";
import { errorMessage, type FieldError } from "../api/errors";
import { FieldMessages, SchemaForm, schemaDefaults, schemaFieldPaths, schemaLocalErrors, type JsonSchema } from "../components/SchemaForm";
import { ErrorBox, Loading } from "../components/States";
import { Plot, type Trace } from "../components/Plot";
import { PreviewPanel } from "../components/PreviewPanel";
import { DefinitionEditor } from "../components/DefinitionEditor";
import { generalFailure, serverProblems } from "../components/FormErrors";
import { cleanName, errorView, nameProblems, schemaLabel } from "../lib/formErrors";
import { useUnsavedWarning } from "../lib/unsaved";

const typeSchema = (t: OracleType | undefined) => (t?.params_schema ?? {}) as JsonSchema;

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
  const types = useOracleTypes();
  const existing = useOracle(editing ? Number(id) : null);
  if (types.isPending || (editing && existing.isPending)) return <Loading />;
  if (types.isError) return <ErrorBox error={types.error} retry={() => void types.refetch()} />;
  if (existing.isError) return <ErrorBox error={existing.error} />;
  return <OracleEditor key={existing.data?.id ?? "new"} existing={existing.data} types={types.data} />;
}

function OracleEditor({ existing, types }: { existing: Oracle | undefined; types: OracleType[] }) {
  const navigate = useNavigate();
  const oracleId = existing?.id ?? null;
  const save = useSaveOracle(oracleId);
  const test = useCreateOraclePreview(oracleId);
  const [previewId, setPreviewId] = useState<number | null>(null);
  const preview = usePreview(previewId);
  const testing = test.isPending || (previewId !== null && !isPreviewFinal(preview.data));
  const first = types.find((t) => t.available) ?? types[0];
  const [name, setName] = useState(existing?.name ?? "");
  const [description, setDescription] = useState(existing?.description ?? "");
  const [type, setType] = useState(existing?.type ?? first?.name ?? "");
  const [params, setParams] = useState<Record<string, unknown>>(() => existing?.params ?? (first ? schemaDefaults(typeSchema(first)) : {}));
  const [checked, setChecked] = useState<{ key: string; errors: FieldError[] } | null>(null);
  // the draft the last save sent: its refused problems apply while the form still shows that draft
  const [sentKey, setSentKey] = useState<string | null>(null);
  const typeInfo = types.find((t) => t.name === type);
  const schema = typeSchema(typeInfo);

  // Inline checks by the API, 400 ms after the last edit.
  const draftKey = JSON.stringify([type, params]);
  // the form as loaded or last saved: anything else is an unsaved edit, and leaving the page asks first
  const formKey = JSON.stringify([name, description, type, params]);
  const [baseline, setBaseline] = useState(formKey);
  useUnsavedWarning(formKey !== baseline);
  useEffect(() => {
    if (!type) return;
    let current = true;
    const timer = setTimeout(() => {
      checkOracle({ type, params })
        .then((errors) => current && setChecked({ key: draftKey, errors }))
        .catch((err) => current && setChecked({ key: draftKey, errors: [{ field: "", message: errorMessage(err) }] }));
    }, 400);
    return () => {
      current = false;
      clearTimeout(timer);
    };
  }, [draftKey, type, params]);

  const view = useMemo(() => {
    const known = ["name", "description", "type", ...schemaFieldPaths(schema, schema, "params")];
    const label = (p: string) => (p.startsWith("params.") ? schemaLabel(schema, p.slice(7)) : p[0]?.toUpperCase() + p.slice(1));
    const local = [...nameProblems(name), ...schemaLocalErrors(schema, params, schema, "params")];
    const sent = sentKey === JSON.stringify([name, description, type, params]) ? serverProblems(save.error) : [];
    return errorView([local, checked?.errors ?? [], sent, serverProblems(test.error)], known, label);
  }, [name, description, type, schema, params, checked, sentKey, save.error, test.error]);

  function onSave() {
    if (nameProblems(name).length) return; // named at the field; the API would refuse it too
    setSentKey(formKey);
    const sent = formKey;
    save.mutate(
      { name: cleanName(name), description, type, params },
      {
        onSuccess: (saved) => {
          setBaseline(sent);
          navigate(`/oracles/${saved.id}`);
        },
      },
    );
  }

  return (
    <DefinitionEditor
      kind="oracle"
      noun="oracle"
      existing={existing}
      name={name}
      setName={setName}
      description={description}
      setDescription={setDescription}
      errors={view}
      checking={checked?.key !== draftKey}
      failure={save.error}
      saving={save.isPending}
      onSave={onSave}
      actions={
        <button
          type="button"
          disabled={!existing || testing || view.problems.length > 0}
          title={existing ? "Run the oracle with the parameters as shown on a sample trajectory, on a worker" : "Create the oracle first; then edits can be tested before saving"}
          onClick={() => {
            setPreviewId(null);
            // the parameters as shown; unchanged ones: the saved version
            const edited = JSON.stringify(params) !== JSON.stringify(existing?.params ?? {});
            test.mutate(edited ? { params } : {}, { onSuccess: (p) => setPreviewId(p.id) });
          }}
        >
          {testing ? "Testing…" : "Test on a sample trajectory"}
        </button>
      }
    >
      <section className="panel" aria-labelledby="params-title">
        <div className="field">
          <label htmlFor="oracle-type">Type</label>
          <select
            id="oracle-type"
            value={type}
            disabled={Boolean(existing)}
            onChange={(e) => {
              setType(e.target.value);
              const t = types.find((x) => x.name === e.target.value);
              setParams(t ? schemaDefaults(typeSchema(t)) : {});
            }}
          >
            {types.map((t) => (
              <option key={t.name} value={t.name} disabled={!t.available}>
                {t.name}
                {t.kind === "command" ? " (command)" : ""}
                {t.available ? "" : " — unavailable"}
              </option>
            ))}
          </select>
          <FieldMessages problems={view.at("type")} />
        </div>
        {typeInfo && <p className="muted">{typeInfo.available ? typeInfo.description : `${typeInfo.description} (${typeInfo.unavailable_reason ?? "unavailable"})`}</p>}
        {typeInfo?.launcher && (
          <p className="muted" data-testid="oracle-launcher">
            Runs as {typeInfo.launcher} (set by the administrator).
          </p>
        )}
        <h2 id="params-title">Parameters</h2>
        {typeInfo ? <SchemaForm schema={schema} value={params} onChange={setParams} errors={view} prefix="params" /> : <p className="muted">Choose a type.</p>}
      </section>
      <PreviewPanel<OraclePreviewResult> id={previewId} title="Test on a sample trajectory" startError={generalFailure(test.error) ? test.error : undefined} render={(result) => <TestPreview result={result} />} />
    </DefinitionEditor>
  );
}
