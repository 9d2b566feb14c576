import { Link, useParams } from "react-router-dom";
import { isLive, useCampaign, useMetrics, useOracle, useTask } from "../api/hooks";
import { Empty, ErrorBox, Loading, StatusBadge } from "../components/States";
import { RmsePlot } from "../campaign/RmsePlot";
import { loadPlotly } from "../components/Plot";
import { ForcesPanel } from "../campaign/ForcesPanel";
import { TrajectoryPanel } from "../campaign/TrajectoryPanel";
import { JobsTable, VersionsPanel } from "../campaign/JobsAndVersions";
import { Controls } from "../campaign/Controls";
import { fmtDate, fmtDuration, fmtNumber } from "../lib/format";
import { useBoolParam, useIntListParam, useStringParam } from "../lib/urlState";

const TABS = [
  ["forces", "Forces & moments"],
  ["trajectory", "Trajectory"],
  ["jobs", "Jobs"],
  ["versions", "Pool & models"],
] as const;

export function CampaignPage() {
  void loadPlotly(); // fetch and parse plotly.js while the campaign's data loads
  const id = Number(useParams().id);
  const campaign = useCampaign(id);
  const live = campaign.data ? isLive(campaign.data.status) : false;
  const metrics = useMetrics(id, live);
  const [logY, setLogY] = useBoolParam("log", true);
  const [selected, setSelected] = useIntListParam("k");
  const [overlay, setOverlay] = useIntListParam("overlay");
  const [tab, setTab] = useStringParam("tab", "forces");
  const oracle = useOracle(campaign.data?.oracle_id ?? null);
  const task = useTask(campaign.data?.task_id ?? null);

  if (!Number.isInteger(id)) return <ErrorBox error="invalid campaign id" />;
  if (campaign.isPending) return <Loading label="Loading campaign…" />;
  if (campaign.isError) return <ErrorBox error={campaign.error} retry={() => void campaign.refetch()} />;
  const c = campaign.data;
  const points = metrics.data ?? [];
  const last = points.length ? points[points.length - 1].iteration : -1;
  const k = selected[0] ?? null;
  const trajectoryK = k ?? (points.filter((p) => p.iteration > 0 && p.force_rmse !== null).pop()?.iteration ?? null);

  return (
    <>
      <div className="toolbar">
        <h1 style={{ margin: 0 }}>{c.name}</h1>
        <StatusBadge status={c.status} />
        {live && (
          <span className="muted" aria-live="polite">
            live · updates every 2 s
          </span>
        )}
        <span className="spacer" />
        <Controls campaign={c} lastIteration={last} />
      </div>
      <div className="panel">
        <dl className="kv" style={{ gridTemplateColumns: "max-content 1fr max-content 1fr max-content 1fr" }}>
          <dt>Iteration</dt>
          <dd data-testid="iteration-progress">
            {c.iteration}
            {c.max_iterations ? ` / ${c.max_iterations}` : ""} {c.current_step ? `(${c.current_step})` : ""}
          </dd>
          <dt>Task</dt>
          <dd>
            {c.task_id ? (
              <Link to={`/tasks/${c.task_id}`}>
                {task.data?.name ?? `task ${c.task_id}`} v{c.task_version}
              </Link>
            ) : (
              "—"
            )}
          </dd>
          <dt>Oracle</dt>
          <dd>{c.oracle_id ? <Link to={`/oracles/${c.oracle_id}`}>{oracle.data ? `${oracle.data.name} (${oracle.data.type})` : `oracle ${c.oracle_id}`}</Link> : "—"}</dd>
          <dt>Force RMSE</dt>
          <dd>{fmtNumber(c.force_rmse)} N</dd>
          <dt>Moment RMSE</dt>
          <dd>{fmtNumber(c.moment_rmse)} N m</dd>
          <dt>Owner</dt>
          <dd>{c.owner ?? "—"}</dd>
          <dt>Started</dt>
          <dd>{fmtDate(c.started_at)}</dd>
          <dt>ETA</dt>
          <dd>{live ? fmtDuration(c.eta_s) : c.finished_at ? `finished ${fmtDate(c.finished_at)}` : "—"}</dd>
          <dt>Stop reason</dt>
          <dd>{c.stop_reason ?? "—"}</dd>
          {c.source_campaign_id !== null && c.source_campaign_id !== undefined && (
            <>
              <dt>Forked from</dt>
              <dd>
                <Link to={`/campaigns/${c.source_campaign_id}`}>campaign {c.source_campaign_id}</Link> at k = {c.source_iteration}
              </dd>
            </>
          )}
        </dl>
        {c.error && (
          <p className="error-text" role="alert">
            {c.error}
          </p>
        )}
      </div>
      <section className="panel" aria-labelledby="rmse-title">
        <div className="toolbar">
          <h2 id="rmse-title" style={{ margin: 0 }}>
            RMSE per iteration
          </h2>
          <span className="muted" data-testid="rmse-count">
            {points.filter((p) => p.force_rmse !== null).length} iterations with metrics
          </span>
          <span className="spacer" />
          <label className="field-inline">
            <input type="checkbox" checked={logY} onChange={(e) => setLogY(e.target.checked)} /> log axis
          </label>
        </div>
        {metrics.isError ? (
          <ErrorBox error={metrics.error} retry={() => void metrics.refetch()} />
        ) : metrics.isPending ? (
          <Loading label="Loading metrics…" />
        ) : points.length === 0 ? (
          <Empty title="No iteration has finished yet">
            {c.status === "draft" ? "Start the campaign to run its first iteration." : "The RMSE of each iteration appears here as soon as it is evaluated."}
          </Empty>
        ) : (
          <RmsePlot points={points} logY={logY} onSelect={(it) => { setSelected([it]); setTab("forces"); }} />
        )}
      </section>
      <section className="panel">
        <div
          className="tabs"
          role="tablist"
          aria-label="Campaign details"
          onKeyDown={(e) => {
            // arrow keys move between tabs (WAI-ARIA tabs pattern)
            if (e.key !== "ArrowRight" && e.key !== "ArrowLeft") return;
            const i = TABS.findIndex(([key]) => key === tab);
            const next = TABS[(i + (e.key === "ArrowRight" ? 1 : TABS.length - 1)) % TABS.length][0];
            setTab(next);
            document.getElementById(`tab-${next}`)?.focus();
          }}
        >
          {TABS.map(([key, label]) => (
            <button
              key={key}
              type="button"
              role="tab"
              id={`tab-${key}`}
              aria-selected={tab === key}
              aria-controls={`panel-${key}`}
              tabIndex={tab === key ? 0 : -1}
              onClick={() => setTab(key)}
            >
              {label}
            </button>
          ))}
        </div>
        <div role="tabpanel" id={`panel-${tab}`} aria-labelledby={`tab-${tab}`}>
          {tab === "forces" && <ForcesPanel campaignId={id} points={points} iteration={k} setIteration={(it) => setSelected([it])} overlay={overlay} setOverlay={setOverlay} />}
          {tab === "trajectory" && <TrajectoryPanel campaignId={id} iteration={trajectoryK} />}
          {tab === "jobs" && <JobsTable campaignId={id} live={live} />}
          {tab === "versions" && <VersionsPanel campaignId={id} live={live} />}
        </div>
      </section>
    </>
  );
}
