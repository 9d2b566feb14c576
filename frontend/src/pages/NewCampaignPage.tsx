import { useEffect, useState, type FormEvent } from "react";
import { Link, useNavigate } from "react-router-dom";
import { useCreateCampaign, checkCampaign } from "../campaign/queries";
import { errorMessage, type FieldError } from "../api/errors";
import { useOpenApi, useOracles, useSurrogateConfigs, useTasks } from "../api/definitions";
import { ErrorBox, Loading } from "../components/States";
import { FieldMessages, numberProblem } from "../components/SchemaForm";
import { NumberInput, type NumberText } from "../components/NumberInput";
import { ErrorCount, FormErrors, serverProblems } from "../components/FormErrors";
import { cleanName, errorView, nameProblems } from "../lib/formErrors";
import { ConfigSections, configFieldPaths, configLabel, configLocalErrors, useConfigDefaults, type ConfigDraft } from "../campaign/ConfigSections";
import { EXPLORATION_PATHS, ExplorationSection, explorationErrors } from "../campaign/ExplorationSection";
import { useTitle } from "../lib/title";
import { useUnsavedWarning } from "../lib/unsaved";

/** A copy of a request without the values at the given dotted paths (an item of a list takes its whole list). */
export function withoutFields(body: Record<string, unknown>, paths: string[]): Record<string, unknown> {
  const out = structuredClone(body);
  for (const path of paths) {
    const parts = path.split(".");
    let parent: unknown = out;
    let i = 0;
    for (; i < parts.length - 1; i++) {
      const next: unknown = (parent as Record<string, unknown>)[parts[i]];
      if (Array.isArray(next) || next === null || typeof next !== "object") break;
      parent = next;
    }
    if (parent && typeof parent === "object") delete (parent as Record<string, unknown>)[parts[i]];
  }
  return out;
}

export function NewCampaignPage() {
  useTitle("New campaign");
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
  const [seed, setSeed] = useState<NumberText>(0);
  const [edited, setConfig] = useState<ConfigDraft | null>(null);
  const [startNow, setStartNow] = useState(true);
  const taskId = chosenTask === "" ? (tasks.data?.[0]?.id ?? "") : chosenTask;
  const oracleId = chosenOracle === "" ? (oracles.data?.[0]?.id ?? "") : chosenOracle;
  const config = edited ?? defaults;
  // a form with anything typed or changed asks before a link leaves it (creating it navigates without asking)
  useUnsavedWarning(name !== "" || edited !== null || seed !== 0 || chosenTask !== "" || chosenOracle !== "" || surrogateId !== "");

  const openapi = useOpenApi();
  const own: Record<string, string> = { name: "Name", seed: "Seed", task_id: "Task", oracle_id: "Oracle", surrogate_config_id: "Surrogate configuration" };
  const seedProblem = numberProblem(seed, { minimum: 0 }, true) ?? (seed === undefined ? "a whole number is needed" : null);
  const local = [
    ...nameProblems(name),
    ...(seedProblem ? [{ field: "seed", message: seedProblem }] : []),
    ...(config ? [...configLocalErrors(openapi.data, config), ...explorationErrors(config)] : []),
  ];
  // the request as it would be sent, without the values the form already names: the API checks all the rest (its rules across a section's fields need the section valid)
  const body = { name: cleanName(name), ...(taskId === "" ? {} : { task_id: taskId }), ...(oracleId === "" ? {} : { oracle_id: oracleId }), surrogate_config_id: surrogateId === "" ? null : surrogateId, seed, start: startNow, ...config };
  const draftKey = JSON.stringify(withoutFields(body, local.map((e) => e.field)));
  // Checked while typing: the API (which knows the definitions and the rules across settings) answers 400 ms after the last edit, with every problem at once.
  const [checked, setChecked] = useState<{ key: string; errors: FieldError[] } | null>(null);
  const ready = config !== null && !tasks.isPending && !oracles.isPending;
  useEffect(() => {
    if (!ready) return;
    let current = true;
    const timer = setTimeout(() => {
      checkCampaign(JSON.parse(draftKey) as Record<string, unknown>)
        .then((errors) => current && setChecked({ key: draftKey, errors }))
        .catch((err) => current && setChecked({ key: draftKey, errors: [{ field: "", message: errorMessage(err) }] }));
    }, 400);
    return () => {
      current = false;
      clearTimeout(timer);
    };
  }, [draftKey, ready]);
  const checking = ready && checked?.key !== draftKey;
  // the request as the last create sent it: the server's refusal applies while the form still shows it
  const [sentKey, setSentKey] = useState<string | null>(null);
  const known = [...Object.keys(own), ...configFieldPaths(openapi.data)];
  const view = errorView([local, checked?.errors ?? [], sentKey === draftKey ? serverProblems(create.error) : []], known, (p) => own[p] ?? configLabel(openapi.data, p));

  function submit(e: FormEvent) {
    e.preventDefault();
    if (taskId === "" || oracleId === "" || !config || local.length || typeof seed !== "number") return;
    setSentKey(draftKey);
    create.mutate(
      { name: cleanName(name), task_id: taskId, oracle_id: oracleId, surrogate_config_id: surrogateId === "" ? null : surrogateId, seed, start: startNow, ...config },
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
        {config && <ErrorCount view={view} checking={checking} />}
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
            <input id="campaign-name" value={name} onChange={(e) => setName(e.target.value)} required maxLength={200} aria-invalid={view.at("name").length > 0} />
            {err("name")}
          </div>
          <div className="field">
            <label htmlFor="campaign-seed">Seed</label>
            <NumberInput id="campaign-seed" inputMode="numeric" value={seed} onChange={setSeed} aria-invalid={view.at("seed").length > 0} />
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
      {config && <ExplorationSection value={config} onChange={setConfig} errors={view} />}
      {config && <ConfigSections value={config} onChange={setConfig} errors={view} omit={EXPLORATION_PATHS} />}
    </form>
  );
}
