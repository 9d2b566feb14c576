import { Link, useParams } from "react-router-dom";
import { useQueryClient } from "@tanstack/react-query";
import { maxIterations, progressText, useCampaign } from "../campaign/queries";
import { useMetrics } from "../api/series";
import { useCampaignLive, type Live } from "../api/live";
import { useOracle, useTask } from "../api/definitions";
import { isLive } from "../api/types";
import { Empty, ErrorBox, Loading, StatusBadge } from "../components/States";
import { CalibrationPlot, hasCalibration, RmsePlot, RmseQuantitySelect, useRmseQuantity } from "../campaign/RmsePlot";
import { loadPlotly } from "../components/Plot";
import { ForcesPanel } from "../campaign/ForcesPanel";
import { TrajectoryPanel } from "../campaign/TrajectoryPanel";
import { CandidatesPanel } from "../campaign/CandidatesPanel";
import { XAxisSwitch } from "../components/XAxisSwitch";
import { isXAxis } from "../lib/xaxis";
import { JobsTable, VersionsPanel } from "../campaign/JobsAndVersions";
import { Controls } from "../campaign/Controls";
import { fmtDate, fmtDuration, fmtNumber } from "../lib/format";
import { useBoolParam, useIntListParam, useSetParams, useStringParam } from "../lib/urlState";
import { useTitle } from "../lib/title";

const TABS = [
  ["forces", "Forces & moments"],
  ["trajectory", "Trajectory"],
  ["candidates", "Candidates & picks"],
  ["jobs", "Jobs"],
  ["versions", "Pool & models"],
] as const;

function LiveBadge({ live, running }: { live: Live; running: boolean }) {
  if (live.state === "live") return <span className="muted" data-testid="live-state" data-state="live" aria-live="polite">{running ? "live" : "watching for changes"}</span>;
  if (live.state === "down")
    return (
      <span className="muted" data-testid="live-state" data-state="down" aria-live="polite">
        live updates interrupted, reconnecting · checking every {Math.round(Number(live.poll) / 1000)} s
      </span>
    );
  if (live.state === "connecting") return <span className="muted" data-testid="live-state" data-state="connecting">connecting…</span>;
  return null;
}

/** What the suite's motions are beside its scored core: the stress part and the best-possible line's replays. */
function suiteParts(v: { n_motions: number; n_stress_motions?: number; ranges?: Record<string, number[]> }): string {
  const stress = v.n_stress_motions ?? 0;
  const parts = [stress ? `${stress} beyond the task's reach, scored apart` : "", v.ranges?.release ? "with unloads and re-loads" : ""].filter(Boolean);
  return parts.length ? ` (${parts.join("; ")})` : "";
}

export function CampaignPage() {
  void loadPlotly(); // fetch and parse plotly.js while the campaign's data loads
  const id = Number(useParams().id);
  const qc = useQueryClient();
  const statusGuess = qc.getQueryData<{ campaign: { status: string } }>(["campaign", id])?.campaign.status;
  const live = useCampaignLive(id, statusGuess);
  const campaign = useCampaign(id);
  const c = campaign.data;
  useTitle(c ? `Campaign ${c.campaign.name}` : `Campaign ${Number.isInteger(id) ? id : ""}`);
  const metrics = useMetrics(id, { inherited: c?.campaign.source_campaign_id != null, latest: c?.latest_metrics?.iteration_index ?? null, qc });
  const [logY, setLogY] = useBoolParam("log", true);
  const [selected, setSelected] = useIntListParam("k");
  const [overlay, setOverlay] = useStringParam("overlay");
  const [tab, setTab] = useStringParam("tab", "forces");
  const [xRaw, setXAxis] = useStringParam("x", "iteration");
  const [quantity, setQuantity] = useRmseQuantity();
  const xAxis = isXAxis(xRaw) ? xRaw : "iteration";
  const setParams = useSetParams();
  const oracle = useOracle(c?.oracle_id ?? null);
  const task = useTask(c?.task_id ?? null);

  if (!Number.isInteger(id)) return <ErrorBox error="invalid campaign id" />;
  if (campaign.isPending) return <Loading label="Loading campaign…" />;
  if (campaign.isError || !c) return <ErrorBox error={campaign.error} retry={() => void campaign.refetch()} />;
  const r = c.campaign;
  const running = isLive(r.status);
  const points = metrics.data ?? [];
  const own = points.filter((p) => !p.inherited);
  const last = own.length ? own[own.length - 1].iteration : (r.source_iteration ?? -1);
  const k = selected[0] ?? null;
  const trajectoryK = k ?? (own.filter((p) => p.iteration > 0 && p.force_rmse !== null).pop()?.iteration ?? null);
  const max = maxIterations(c);

  return (
    <>
      <div className="toolbar">
        <h1 style={{ margin: 0 }}>{r.name}</h1>
        <StatusBadge status={r.status} title={r.wait_reason ?? undefined} />
        {r.wait_reason && (
          <span className="muted" data-testid="wait-reason">
            {r.wait_reason}
          </span>
        )}
        <LiveBadge live={live} running={running} />
        <span className="spacer" />
        <Controls campaign={c} lastIteration={last} />
      </div>
      <div className="panel">
        <dl className="kv" style={{ gridTemplateColumns: "max-content 1fr max-content 1fr max-content 1fr" }}>
          <dt>Iteration</dt>
          <dd data-testid="iteration-progress">
            {progressText(r.current_iteration, max)} {running && r.current_step ? `(${r.current_step})` : ""}
          </dd>
          <dt>Task</dt>
          <dd>
            <Link to={`/tasks/${c.task_id}`}>
              {task.data?.name ?? `task ${c.task_id}`} v{c.task_version}
            </Link>
          </dd>
          <dt>Oracle</dt>
          <dd>
            <Link to={`/oracles/${c.oracle_id}`}>{oracle.data ? `${oracle.data.name} (${oracle.data.type})` : `oracle ${c.oracle_id}`}</Link>
          </dd>
          <dt>Force RMSE</dt>
          <dd data-testid="latest-force-rmse" data-iteration={c.latest_metrics?.iteration_index ?? ""}>
            {fmtNumber(c.latest_metrics?.force_rmse)} N
          </dd>
          <dt>Moment RMSE</dt>
          <dd>{fmtNumber(c.latest_metrics?.moment_rmse)} N m</dd>
          {c.latest_metrics?.calibration != null && (
            <>
              <dt title="fraction of the latest iteration's oracle values inside the ensemble's mean ± 2 std (nominal 95.4 %)">Calibration</dt>
              <dd data-testid="latest-calibration">{fmtNumber(100 * c.latest_metrics.calibration, 3)} % inside ± 2σ</dd>
            </>
          )}
          <dt>Owner</dt>
          <dd>{c.owner}</dd>
          <dt>Started</dt>
          <dd>{fmtDate(r.started_at)}</dd>
          <dt>ETA</dt>
          <dd>{running ? fmtDuration(c.eta_s) : r.finished_at ? `finished ${fmtDate(r.finished_at)}` : "—"}</dd>
          <dt>Stop reason</dt>
          <dd>{r.stop_reason ?? "—"}</dd>
          {r.source_campaign_id != null && (
            <>
              <dt>Forked from</dt>
              <dd>
                <Link to={`/campaigns/${r.source_campaign_id}`}>campaign {r.source_campaign_id}</Link> at k = {r.source_iteration}
              </dd>
            </>
          )}
        </dl>
        {r.error && (
          <p className="error-text" role="alert">
            {r.error}
          </p>
        )}
      </div>
      <section className="panel" aria-labelledby="rmse-title">
        <div className="toolbar">
          <h2 id="rmse-title" style={{ margin: 0 }}>
            RMSE per {xAxis === "iteration" ? "iteration" : xAxis === "oracle" ? "oracle call" : "wall time"}
          </h2>
          <span className="muted" data-testid="rmse-count">
            {own.filter((p) => p.force_rmse !== null).length} iterations with metrics
            {points.length > own.length ? ` (and ${points.length - own.length} inherited from the source, grey)` : ""}
          </span>
          {c.validation ? (
            <span className="muted" data-testid="validation-suite" data-status={c.validation.status} title="Every model version is evaluated on these held-out motions (never in the pool); dashed lines.">
              held-out suite: {c.validation.status}, {c.validation.motions_done}/{c.validation.n_motions} motions
              {suiteParts(c.validation)}
              {c.validation.shared_by > 1 ? `, shared by ${c.validation.shared_by} campaigns` : ""}
              {c.validation.error ? ` (${c.validation.error})` : ""}
            </span>
          ) : null}
          <span className="spacer" />
          <RmseQuantitySelect value={quantity} onChange={setQuantity} />
          <XAxisSwitch value={xAxis} onChange={setXAxis} />
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
            {r.status === "draft" ? "Start the campaign to run its first iteration." : "The RMSE of each iteration appears here as soon as it is evaluated."}
          </Empty>
        ) : (
          <div className={hasCalibration(points) ? "rmse-with-calibration" : undefined}>
            <RmsePlot
              points={points}
              logY={logY}
              xAxis={xAxis}
              quantity={quantity}
              auxLaw={metrics.auxLaw}
              bestPossible={metrics.bestPossible}
              onSelect={(it) => {
                // one navigation for both: the clicked iteration on the forces tab
                if (own.some((p) => p.iteration === it)) setParams({ k: String(it), tab: null });
              }}
            />
            {hasCalibration(points) && <CalibrationPlot points={points} xAxis={xAxis} />}
          </div>
        )}
        {points.length > 0 && (
          <small className="hint" data-testid="rmse-plot-key">
            Solid: the new oracle data of each iteration; dashed: the held-out suite{hasCalibration(points) ? "; calibration: the share of oracle values inside the ensemble's mean ± 2σ" : ""}.
          </small>
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
          {tab === "forces" && <ForcesPanel campaignId={id} points={points} iteration={k} setIteration={(it) => setSelected([it])} overlay={overlay} setOverlay={setOverlay} task={{ id: c.task_id, version: c.task_version }} />}
          {tab === "candidates" && <CandidatesPanel campaignId={id} iteration={trajectoryK} last={r.current_iteration} setIteration={(it) => setSelected([it])} />}
          {tab === "trajectory" && <TrajectoryPanel campaignId={id} iteration={trajectoryK} task={{ id: c.task_id, version: c.task_version }} />}
          {tab === "jobs" && <JobsTable campaignId={id} />}
          {tab === "versions" && <VersionsPanel campaignId={id} />}
        </div>
      </section>
    </>
  );
}
