import { useState, type FormEvent } from "react";
import { Link, useNavigate } from "react-router-dom";
import { useCreateCampaign } from "../api/campaigns";
import { componentSchema, useOpenApi, useOracles, useSurrogateConfigs, useTasks, type OpenApiDocument } from "../api/definitions";
import type { FieldError } from "../api/errors";
import { ErrorBox, Loading } from "../components/States";
import { FieldMessages, SchemaForm, schemaDefaults, schemaFieldPaths, schemaLocalErrors } from "../components/SchemaForm";
import { ErrorCount, FormErrors, serverProblems } from "../components/FormErrors";
import { errorView, noErrors, schemaLabel, type ErrorView } from "../lib/formErrors";

/** Editable campaign settings, each a form generated from the API's own schema. */
const SECTIONS = [
  ["preliminary", "PreliminaryConfig", "Preliminary data (pool version 0)"],
  ["stopping", "StoppingRules", "Stopping rules"],
  ["settings", "RunSettings", "Run settings"],
  ["policies", "Policies", "Failure policies"],
] as const;

export type ConfigDraft = Record<string, Record<string, unknown>>;

export type ConfigKey = (typeof SECTIONS)[number][0];

function sections(only?: readonly string[]) {
  return SECTIONS.filter(([key]) => !only || only.includes(key));
}

/** The field paths the config sections show ("stopping.max_iterations", ...), for placing errors. */
export function configFieldPaths(doc: OpenApiDocument | undefined, only?: readonly string[]): string[] {
  return sections(only).flatMap(([key, name]) => {
    const schema = componentSchema(doc, name);
    return schema ? schemaFieldPaths(schema, schema, key) : [];
  });
}

/** The form's own checks of the config (numbers, whole numbers, the schemas' bounds). */
export function configLocalErrors(doc: OpenApiDocument | undefined, value: ConfigDraft, only?: readonly string[]): FieldError[] {
  return sections(only).flatMap(([key, name]) => {
    const schema = componentSchema(doc, name);
    return schema ? schemaLocalErrors(schema, value[key], schema, key) : [];
  });
}

/** The label of a config path, from the schemas' titles and descriptions. */
export function configLabel(doc: OpenApiDocument | undefined, path: string): string {
  const [key, ...rest] = path.split(".");
  const section = SECTIONS.find(([k]) => k === key);
  const schema = section ? componentSchema(doc, section[1]) : null;
  return schema ? `${section![2]} › ${schemaLabel(schema, rest.join("."))}` : path;
}

export function ConfigSections({
  value,
  onChange,
  errors = noErrors,
  only,
}: {
  value: ConfigDraft;
  onChange: (v: ConfigDraft) => void;
  errors?: ErrorView;
  only?: readonly string[];
}) {
  const openapi = useOpenApi();
  if (openapi.isPending) return <Loading label="Loading settings form…" />;
  if (openapi.isError) return <ErrorBox error={openapi.error} />;
  return (
    <>
      {sections(only).map(([key, schemaName, title]) => {
        const schema = componentSchema(openapi.data, schemaName);
        if (!schema) return null;
        const body = <SchemaForm schema={schema} value={value[key] ?? {}} onChange={(v) => onChange({ ...value, [key]: v })} errors={errors} prefix={key} />;
        return key === "policies" ? (
          <details key={key} className="panel" open={errors.problems.some((p) => p.field?.startsWith("policies."))}>
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
  // until chosen: the first task and oracle, the schemas' defaults
  const [chosenTask, setTaskId] = useState<number | "">("");
  const [chosenOracle, setOracleId] = useState<number | "">("");
  const [surrogateId, setSurrogateId] = useState<number | "">("");
  const [seed, setSeed] = useState(0);
  const [edited, setConfig] = useState<ConfigDraft | null>(null);
  const [startNow, setStartNow] = useState(true);
  const taskId = chosenTask === "" ? (tasks.data?.[0]?.id ?? "") : chosenTask;
  const oracleId = chosenOracle === "" ? (oracles.data?.[0]?.id ?? "") : chosenOracle;
  const config = edited ?? defaults;

  const openapi = useOpenApi();
  const [submitted, setSubmitted] = useState(false);
  const own = ["name", "seed", "task_id", "oracle_id", "surrogate_config_id"];
  const local = config ? configLocalErrors(openapi.data, config) : [];
  const view = errorView([submitted ? local : [], serverProblems(create.error)], [...own, ...configFieldPaths(openapi.data)], (p) =>
    own.includes(p) ? p : configLabel(openapi.data, p),
  );

  function submit(e: FormEvent) {
    e.preventDefault();
    setSubmitted(true);
    if (taskId === "" || oracleId === "" || !config || local.length) return;
    create.mutate(
      { name, task_id: taskId, oracle_id: oracleId, surrogate_config_id: surrogateId === "" ? null : surrogateId, seed, start: startNow, ...config },
      { onSuccess: (created) => navigate(`/campaigns/${created.id}`) },
    );
  }

  if (tasks.isPending || oracles.isPending) return <Loading />;
  const failed = [tasks, oracles, surrogates].find((q) => q.isError);
  if (failed) return <ErrorBox error={failed.error} />;
  const t = tasks.data ?? [];
  const o = oracles.data ?? [];
  const s = surrogates.data ?? [];
  const err = (f: string) => <FieldMessages problems={view.at(f)} />;

  return (
    <form onSubmit={submit} style={{ maxWidth: 1100 }} noValidate>
      <div className="toolbar">
        <h1 style={{ margin: 0 }}>New campaign</h1>
        {view.problems.length > 0 && <ErrorCount view={view} />}
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
      <FormErrors view={view} failure={create.error} />
      <section className="panel">
        <div className="row">
          <div className="field grow">
            <label htmlFor="campaign-name">Name</label>
            <input id="campaign-name" value={name} onChange={(e) => setName(e.target.value)} required maxLength={200} />
            {err("name")}
          </div>
          <div className="field">
            <label htmlFor="campaign-seed">Seed</label>
            <input id="campaign-seed" type="number" min={0} step={1} value={seed} onChange={(e) => setSeed(Number(e.target.value))} />
            {err("seed")}
          </div>
        </div>
        <div className="row">
          <div className="field grow">
            <label htmlFor="campaign-task">Task</label>
            <select id="campaign-task" value={taskId} onChange={(e) => setTaskId(Number(e.target.value))} required>
              {t.map((x) => (
                <option key={x.id} value={x.id}>
                  {x.name} (v{x.version})
                </option>
              ))}
            </select>
            {err("task_id")}
          </div>
          <div className="field grow">
            <label htmlFor="campaign-oracle">Oracle</label>
            <select id="campaign-oracle" value={oracleId} onChange={(e) => setOracleId(Number(e.target.value))} required>
              {o.map((x) => (
                <option key={x.id} value={x.id}>
                  {x.name} · {x.type} (v{x.version})
                </option>
              ))}
            </select>
            {err("oracle_id")}
          </div>
          <div className="field grow">
            <label htmlFor="campaign-surrogate">Surrogate configuration</label>
            <select id="campaign-surrogate" value={surrogateId} onChange={(e) => setSurrogateId(e.target.value === "" ? "" : Number(e.target.value))}>
              <option value="">the paper's default</option>
              {s.map((x) => (
                <option key={x.id} value={x.id}>
                  {x.name} (v{x.version})
                </option>
              ))}
            </select>
            {err("surrogate_config_id")}
          </div>
        </div>
      </section>
      {config && <ConfigSections value={config} onChange={setConfig} errors={view} />}
    </form>
  );
}
