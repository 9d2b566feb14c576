import { useEffect, useState, type FormEvent } from "react";
import { Link, useNavigate } from "react-router-dom";
import { componentSchema, startCampaign, useCreateCampaign, useOpenApi, useOracles, useSurrogateConfigs, useTasks } from "../api/hooks";
import { ApiError, errorMessage } from "../api/errors";
import { ErrorBox, Loading } from "../components/States";
import { SchemaForm, schemaDefaults } from "../components/SchemaForm";

/** Editable campaign settings, each a form generated from the API's own schema. */
const SECTIONS = [
  ["preliminary", "PreliminaryConfig", "Preliminary data (pool version 0)"],
  ["stopping", "StoppingRules", "Stopping rules"],
  ["settings", "RunSettings", "Run settings"],
  ["policies", "Policies", "Failure policies"],
] as const;

export type ConfigDraft = Record<string, Record<string, unknown>>;

export function ConfigSections({
  value,
  onChange,
  errors,
  prefix = "",
  only,
}: {
  value: ConfigDraft;
  onChange: (v: ConfigDraft) => void;
  errors: Record<string, string>;
  prefix?: string;
  only?: string[];
}) {
  const openapi = useOpenApi();
  if (openapi.isPending) return <Loading label="Loading settings form…" />;
  if (openapi.isError) return <ErrorBox error={openapi.error} />;
  return (
    <>
      {SECTIONS.filter(([key]) => !only || only.includes(key)).map(([key, schemaName, title]) => {
        const schema = componentSchema(openapi.data, schemaName);
        if (!schema) return null;
        const sectionErrors = Object.fromEntries(
          Object.entries(errors)
            .filter(([f]) => f.startsWith(`${prefix}${key}.`))
            .map(([f, m]) => [f.slice(prefix.length + key.length + 1), m]),
        );
        const body = <SchemaForm schema={schema} value={value[key] ?? {}} onChange={(v) => onChange({ ...value, [key]: v })} errors={sectionErrors} />;
        return key === "policies" ? (
          <details key={key} className="panel">
            <summary>{title}</summary>
            {body}
          </details>
        ) : (
          <section key={key} className="panel" aria-label={title}>
            <h2>{title}</h2>
            {body}
          </section>
        );
      })}
    </>
  );
}

export function useConfigDefaults(): ConfigDraft | null {
  const openapi = useOpenApi();
  if (!openapi.data) return null;
  const out: ConfigDraft = {};
  for (const [key, schemaName] of SECTIONS) {
    const schema = componentSchema(openapi.data, schemaName);
    if (schema) out[key] = schemaDefaults(schema);
  }
  return out;
}

export function NewCampaignPage() {
  const navigate = useNavigate();
  const tasks = useTasks();
  const oracles = useOracles();
  const surrogates = useSurrogateConfigs();
  const create = useCreateCampaign();
  const defaults = useConfigDefaults();
  const [name, setName] = useState("");
  const [taskVersion, setTaskVersion] = useState<number | "">("");
  const [oracleVersion, setOracleVersion] = useState<number | "">("");
  const [surrogateVersion, setSurrogateVersion] = useState<number | "">("");
  const [seed, setSeed] = useState(0);
  const [config, setConfig] = useState<ConfigDraft | null>(null);
  const [startNow, setStartNow] = useState(true);
  const [startError, setStartError] = useState<string | null>(null);

  useEffect(() => {
    if (taskVersion === "" && tasks.data?.length) setTaskVersion(tasks.data[0].version_id);
  }, [tasks.data, taskVersion]);
  useEffect(() => {
    if (oracleVersion === "" && oracles.data?.length) setOracleVersion(oracles.data[0].version_id);
  }, [oracles.data, oracleVersion]);
  useEffect(() => {
    if (surrogateVersion === "" && surrogates.data?.length) setSurrogateVersion(surrogates.data[0].version_id);
  }, [surrogates.data, surrogateVersion]);
  useEffect(() => {
    if (config === null && defaults) setConfig(defaults);
  }, [defaults, config]);

  const fieldErrors = create.error instanceof ApiError ? Object.fromEntries(create.error.fieldErrors.map((e) => [e.field, e.message])) : {};

  async function submit(e: FormEvent) {
    e.preventDefault();
    if (taskVersion === "" || oracleVersion === "" || surrogateVersion === "" || !config) return;
    const created = await create.mutateAsync({
      name,
      task_version_id: taskVersion,
      oracle_version_id: oracleVersion,
      surrogate_config_version_id: surrogateVersion,
      seed,
      ...config,
    });
    if (startNow) {
      try {
        await startCampaign(created.id);
      } catch (err) {
        setStartError(errorMessage(err));
        return;
      }
    }
    navigate(`/campaigns/${created.id}`);
  }

  if (tasks.isPending || oracles.isPending || surrogates.isPending) return <Loading />;
  const failed = [tasks, oracles, surrogates].find((q) => q.isError);
  if (failed) return <ErrorBox error={failed.error} />;
  const t = tasks.data ?? [];
  const o = oracles.data ?? [];
  const s = surrogates.data ?? [];
  const err = (f: string) => fieldErrors[f] && <small className="field-error">{fieldErrors[f]}</small>;

  return (
    <form onSubmit={submit} style={{ maxWidth: 1100 }}>
      <div className="toolbar">
        <h1 style={{ margin: 0 }}>New campaign</h1>
        <span className="spacer" />
        <label className="field-inline">
          <input type="checkbox" checked={startNow} onChange={(e) => setStartNow(e.target.checked)} /> Start right away
        </label>
        <button type="submit" className="primary" disabled={create.isPending || !config}>
          Create campaign
        </button>
        <Link to="/campaigns">Cancel</Link>
      </div>
      {(t.length === 0 || o.length === 0) && (
        <p className="error-text">
          A campaign needs a <Link to="/tasks/new">task</Link> and an <Link to="/oracles/new">oracle</Link> first.
        </p>
      )}
      {create.isError && (
        <p className="error-text" role="alert">
          {errorMessage(create.error)}
        </p>
      )}
      {startError && (
        <p className="error-text" role="alert">
          Created, but not started: {startError}
        </p>
      )}
      <section className="panel">
        <div className="row">
          <div className="field grow">
            <label htmlFor="campaign-name">Name</label>
            <input id="campaign-name" value={name} onChange={(e) => setName(e.target.value)} required maxLength={200} />
            {err("name")}
          </div>
          <div className="field">
            <label htmlFor="campaign-seed">Seed</label>
            <input id="campaign-seed" type="number" min={0} value={seed} onChange={(e) => setSeed(Number(e.target.value))} />
            {err("seed")}
          </div>
        </div>
        <div className="row">
          <div className="field grow">
            <label htmlFor="campaign-task">Task</label>
            <select id="campaign-task" value={taskVersion} onChange={(e) => setTaskVersion(Number(e.target.value))} required>
              {t.map((x) => (
                <option key={x.id} value={x.version_id}>
                  {x.name} (v{x.version})
                </option>
              ))}
            </select>
            {err("task_version_id")}
          </div>
          <div className="field grow">
            <label htmlFor="campaign-oracle">Oracle</label>
            <select id="campaign-oracle" value={oracleVersion} onChange={(e) => setOracleVersion(Number(e.target.value))} required>
              {o.map((x) => (
                <option key={x.id} value={x.version_id}>
                  {x.name} · {x.type} (v{x.version})
                </option>
              ))}
            </select>
            {err("oracle_version_id")}
          </div>
          <div className="field grow">
            <label htmlFor="campaign-surrogate">Surrogate configuration</label>
            <select id="campaign-surrogate" value={surrogateVersion} onChange={(e) => setSurrogateVersion(Number(e.target.value))} required>
              {s.map((x) => (
                <option key={x.id} value={x.version_id}>
                  {x.name} (v{x.version})
                </option>
              ))}
            </select>
            {err("surrogate_config_version_id")}
          </div>
        </div>
      </section>
      {config && <ConfigSections value={config} onChange={setConfig} errors={fieldErrors} />}
    </form>
  );
}
