import { useEffect, useState, type FormEvent } from "react";
import { Link, useNavigate } from "react-router-dom";
import { startCampaign, useCreateCampaign, useOracles, useTasks } from "../api/hooks";
import { ApiError, errorMessage } from "../api/errors";
import { ErrorBox, Loading } from "../components/States";

export function NewCampaignPage() {
  const navigate = useNavigate();
  const tasks = useTasks();
  const oracles = useOracles();
  const create = useCreateCampaign();
  const [name, setName] = useState("");
  const [taskId, setTaskId] = useState<number | "">("");
  const [oracleId, setOracleId] = useState<number | "">("");
  const [maxIterations, setMaxIterations] = useState(20);
  const [preliminary, setPreliminary] = useState(200);
  const [seed, setSeed] = useState(0);
  const [startNow, setStartNow] = useState(true);
  const [startError, setStartError] = useState<string | null>(null);

  useEffect(() => {
    if (taskId === "" && tasks.data?.length) setTaskId(tasks.data[0].id);
  }, [tasks.data, taskId]);
  useEffect(() => {
    if (oracleId === "" && oracles.data?.length) setOracleId(oracles.data[0].id);
  }, [oracles.data, oracleId]);

  const fieldErrors = create.error instanceof ApiError ? Object.fromEntries(create.error.fieldErrors.map((e) => [e.field, e.message])) : {};

  async function submit(e: FormEvent) {
    e.preventDefault();
    if (taskId === "" || oracleId === "") return;
    const created = await create.mutateAsync({ name, task_id: taskId, oracle_id: oracleId, max_iterations: maxIterations, n_preliminary: preliminary, seed });
    if (startNow) {
      try {
        await startCampaign(created.id);
      } catch (err) {
        setStartError(errorMessage(err));
      }
    }
    navigate(`/campaigns/${created.id}`);
  }

  if (tasks.isPending || oracles.isPending) return <Loading />;
  if (tasks.isError) return <ErrorBox error={tasks.error} />;
  if (oracles.isError) return <ErrorBox error={oracles.error} />;

  const err = (f: string) => fieldErrors[f] && <small className="field-error">{fieldErrors[f]}</small>;

  return (
    <form onSubmit={submit} className="panel" style={{ maxWidth: 720 }}>
      <h1>New campaign</h1>
      {tasks.data.length === 0 || oracles.data.length === 0 ? (
        <p className="error-text">
          A campaign needs a <Link to="/tasks/new">task</Link> and an <Link to="/oracles/new">oracle</Link> first.
        </p>
      ) : null}
      <div className="field">
        <label htmlFor="campaign-name">Name</label>
        <input id="campaign-name" value={name} onChange={(e) => setName(e.target.value)} required maxLength={200} />
        {err("name")}
      </div>
      <div className="row">
        <div className="field grow">
          <label htmlFor="campaign-task">Task</label>
          <select id="campaign-task" value={taskId} onChange={(e) => setTaskId(Number(e.target.value))} required>
            {tasks.data.map((t) => (
              <option key={t.id} value={t.id}>
                {t.name}
                {t.version ? ` (v${t.version})` : ""}
              </option>
            ))}
          </select>
          {err("task_id")}
        </div>
        <div className="field grow">
          <label htmlFor="campaign-oracle">Oracle</label>
          <select id="campaign-oracle" value={oracleId} onChange={(e) => setOracleId(Number(e.target.value))} required>
            {oracles.data.map((o) => (
              <option key={o.id} value={o.id}>
                {o.name} · {o.type}
              </option>
            ))}
          </select>
          {err("oracle_id")}
        </div>
      </div>
      <div className="row">
        <div className="field grow">
          <label htmlFor="campaign-max">Max iterations</label>
          <input id="campaign-max" type="number" min={1} value={maxIterations} onChange={(e) => setMaxIterations(Number(e.target.value))} />
          {err("max_iterations")}
        </div>
        <div className="field grow">
          <label htmlFor="campaign-prelim">Preliminary samples</label>
          <input id="campaign-prelim" type="number" min={0} value={preliminary} onChange={(e) => setPreliminary(Number(e.target.value))} />
          {err("n_preliminary")}
        </div>
        <div className="field grow">
          <label htmlFor="campaign-seed">Seed</label>
          <input id="campaign-seed" type="number" min={0} value={seed} onChange={(e) => setSeed(Number(e.target.value))} />
          {err("seed")}
        </div>
      </div>
      <label className="field-inline">
        <input type="checkbox" checked={startNow} onChange={(e) => setStartNow(e.target.checked)} /> Start right away
      </label>
      {create.isError && (
        <p className="error-text" role="alert">
          {errorMessage(create.error)}
        </p>
      )}
      {startError && <p className="error-text">{startError}</p>}
      <div className="toolbar" style={{ marginTop: 12 }}>
        <button type="submit" className="primary" disabled={create.isPending}>
          Create campaign
        </button>
        <Link to="/campaigns">Cancel</Link>
      </div>
    </form>
  );
}
