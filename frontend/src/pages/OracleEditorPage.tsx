import { useEffect, useMemo, useRef, useState, type FormEvent } from "react";
import { useNavigate, useParams } from "react-router-dom";
import { hasRoute, useOpenApi, useOracle, useOracleTypes, useSaveOracle, useTestOracle, validateOracle, ORACLE_TEST_ROUTE, type OracleTestResult } from "../api/hooks";
import { ApiError, errorMessage, type FieldError } from "../api/errors";
import { SchemaForm, schemaDefaults } from "../components/SchemaForm";
import { ErrorBox, Loading } from "../components/States";
import { Plot, type Trace } from "../components/Plot";

function errorsByField(error: unknown, prefix: string): Record<string, string> {
  if (!(error instanceof ApiError)) return {};
  const out: Record<string, string> = {};
  for (const e of error.fieldErrors) {
    const f = e.field.startsWith(prefix) ? e.field.slice(prefix.length) : e.field;
    out[f] = e.message;
  }
  return out;
}

function TestPreview({ result }: { result: OracleTestResult }) {
  const traces: Trace[] = useMemo(
    () =>
      (["fx", "fz", "my"] as const)
        .filter((c) => result.wrench[c])
        .map((c) => ({ x: result.t, y: result.wrench[c], name: c === "my" ? "my [N m]" : `${c} [N]`, mode: "lines", type: "scatter", yaxis: c === "my" ? "y2" : "y" })),
    [result],
  );
  return (
    <div data-testid="oracle-test-result">
      <p className="muted">
        Ran in {result.wall_time_s?.toFixed(2) ?? "?"} s on the sample trajectory. {result.message}
      </p>
      <Plot
        testId="oracle-test-plot"
        traces={traces}
        xTitle="t [s]"
        yTitle="force on the head [N]"
        exportName="oracle-test"
        extraLayout={{ yaxis2: { title: { text: "moment [N m]" }, overlaying: "y", side: "right" } }}
      />
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
  const test = useTestOracle();
  const [name, setName] = useState("");
  const [description, setDescription] = useState("");
  const [type, setType] = useState("");
  const [params, setParams] = useState<Record<string, unknown>>({});
  const [validation, setValidation] = useState<FieldError[]>([]);
  const seq = useRef(0);
  const openapi = useOpenApi();
  const canTest = hasRoute(openapi.data, "post", ORACLE_TEST_ROUTE);

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
        {canTest && (
          <button type="button" disabled={test.isPending || !type} onClick={() => test.mutate({ type, params })}>
            {test.isPending ? "Testing…" : "Test on a sample trajectory"}
          </button>
        )}
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
      {(test.data || test.isError) && (
        <section className="panel" aria-labelledby="test-title">
          <h2 id="test-title">Test run</h2>
          {test.isError ? <ErrorBox error={test.error} /> : test.data ? <TestPreview result={test.data} /> : null}
        </section>
      )}
    </form>
  );
}
