import { useJobs, useModelVersions, usePoolVersions } from "./queries";
import type { BatchJob } from "../api/types";
import { DownloadButton } from "../components/DownloadButton";
import { Empty, ErrorBox, Loading, StatusBadge } from "../components/States";
import { fmtDate, fmtDuration, fmtNumber } from "../lib/format";

export function JobsTable({ campaignId }: { campaignId: number }) {
  const jobs = useJobs(campaignId);
  if (jobs.isPending) return <Loading label="Loading jobs…" />;
  if (jobs.isError) return <ErrorBox error={jobs.error} retry={() => void jobs.refetch()} />;
  if (jobs.data.length === 0) return <Empty title="No jobs yet">Start the campaign to enqueue its first step.</Empty>;
  return (
    <table data-testid="jobs-table">
      <thead>
        <tr>
          <th className="num">k</th>
          <th>Step</th>
          <th>Status</th>
          <th>Worker</th>
          <th className="num">Attempts</th>
          <th>Started</th>
          <th className="num">Duration</th>
          <th title="an oracle call that runs as a batch-scheduler job: the scheduler, its job id and state">Scheduler job</th>
          <th>Error</th>
        </tr>
      </thead>
      <tbody>
        {jobs.data.map((j) => (
          <tr key={j.id}>
            <td className="num">{j.iteration}</td>
            <td>{j.step}</td>
            <td>
              <StatusBadge status={j.status} />
            </td>
            <td className="mono">{j.worker_name ?? "—"}</td>
            <td className="num">{j.attempts}</td>
            <td>{fmtDate(j.started_at)}</td>
            <td className="num">{fmtDuration(j.wall_time_s)}</td>
            <BatchJobCell jobs={j.batch_jobs ?? []} />
            <td className="error-text" title={j.error ?? undefined}>
              {j.error ? j.error.slice(0, 120) : ""}
            </td>
          </tr>
        ))}
      </tbody>
    </table>
  );
}

/** The latest scheduler job of a step (earlier attempts' jobs in its tooltip), with its times. */
function BatchJobCell({ jobs }: { jobs: BatchJob[] }) {
  if (jobs.length === 0) return <td>—</td>;
  const job = jobs[jobs.length - 1];
  const seconds = (a: string | null | undefined, b: string | null | undefined) =>
    a && b ? (new Date(b).getTime() - new Date(a).getTime()) / 1000 : null;
  const waited = seconds(job.submitted_at, job.started_at);
  const ran = seconds(job.started_at, job.ended_at);
  const title = [
    `submitted ${fmtDate(job.submitted_at)}`,
    waited !== null ? `queued ${fmtDuration(waited)}` : null,
    ran !== null ? `ran ${fmtDuration(ran)}` : null,
    job.worker_name ? `waited for by ${job.worker_name}` : null,
    `folder ${job.workdir}`,
    job.reason,
    jobs.length > 1 ? `earlier: ${jobs.slice(0, -1).map((j) => `${j.job_id} ${j.state}`).join(", ")}` : null,
  ]
    .filter(Boolean)
    .join("\n");
  return (
    <td className="mono" title={title} data-testid="batch-job">
      {job.scheduler} {job.job_id} · {job.state}
      {ran !== null ? ` · ${fmtDuration(ran)}` : ""}
    </td>
  );
}

export function VersionsPanel({ campaignId }: { campaignId: number }) {
  const pools = usePoolVersions(campaignId);
  const models = useModelVersions(campaignId);
  return (
    <div className="grid2">
      <section aria-labelledby="pool-title">
        <h3 id="pool-title">Pool versions</h3>
        {pools.isPending ? (
          <Loading />
        ) : pools.isError ? (
          <ErrorBox error={pools.error} />
        ) : pools.data.length === 0 ? (
          <Empty title="No pool yet" />
        ) : (
          <table data-testid="pool-table">
            <thead>
              <tr>
                <th className="num">Version</th>
                <th className="num">Parent</th>
                <th className="num">Data sets</th>
                <th className="num">Samples</th>
                <th>Created</th>
                <th>Download</th>
              </tr>
            </thead>
            <tbody>
              {pools.data.map((p) => (
                <tr key={p.id}>
                  <td className="num">v{p.version}</td>
                  <td className="num">{p.parent_version !== null ? `v${p.parent_version}` : "—"}</td>
                  <td className="num">{p.n_datasets}</td>
                  <td className="num">{p.n_samples}</td>
                  <td>{fmtDate(p.created_at)}</td>
                  <td>
                    <DownloadButton path={p.parquet_url} filename={`pool-c${campaignId}-v${p.version}.parquet`} label="Parquet" />
                    <DownloadButton path={p.csv_url} filename={`pool-c${campaignId}-v${p.version}.csv`} label="CSV" />
                  </td>
                </tr>
              ))}
            </tbody>
          </table>
        )}
      </section>
      <section aria-labelledby="model-title">
        <h3 id="model-title">Model versions</h3>
        {models.isPending ? (
          <Loading />
        ) : models.isError ? (
          <ErrorBox error={models.error} />
        ) : models.data.length === 0 ? (
          <Empty title="No model trained yet" />
        ) : (
          <table data-testid="model-table">
            <thead>
              <tr>
                <th className="num">Version</th>
                <th className="num">Pool</th>
                <th className="num">Warm start</th>
                <th title="the networks' inputs: the paper's 19 features of the state, or those and the history states (a contact model with memory); 'fx own layers': the normal force has hidden layers of its own">
                  Inputs
                </th>
                <th className="num">Test RMSE F</th>
                <th className="num">Test RMSE M</th>
                <th className="num">Epochs</th>
                <th>Download</th>
              </tr>
            </thead>
            <tbody>
              {models.data.map((m) => (
                <tr key={m.id}>
                  <td className="num">m{m.version}</td>
                  <td className="num">{m.pool_version !== null ? `v${m.pool_version}` : "—"}</td>
                  <td className="num">{m.parent_version !== null ? `m${m.parent_version}` : "—"}</td>
                  <td data-testid="model-features">{modelFeatures(m.architecture)}</td>
                  <td className="num">{fmtNumber(m.test_force_rmse)}</td>
                  <td className="num">{fmtNumber(m.test_moment_rmse)}</td>
                  <td className="num" data-stopped-improving={m.stopped_improving}>
                    {m.epochs ?? "—"}
                    {m.stopped_improving > 0 && (
                      <span
                        className="badge warn"
                        role="img"
                        aria-label={`${m.stopped_improving} ${m.stopped_improving === 1 ? "net" : "nets"} stopped at max_epochs while still improving`}
                        title={`${m.stopped_improving} ${m.stopped_improving === 1 ? "net" : "nets"} (over the ensemble's members) stopped at max_epochs while the validation loss was still improving: more epochs (max_epochs in the surrogate config) would likely lower the error`}
                      >
                        capped
                      </span>
                    )}
                  </td>
                  <td>
                    <DownloadButton path={m.artifact_url} filename={`model-c${campaignId}-m${m.version}.zip`} label="Artifact" />
                  </td>
                </tr>
              ))}
            </tbody>
          </table>
        )}
      </section>
    </div>
  );
}

/** The model's feature set as the table shows it (models recorded before feature sets: the paper's),
 * and whether the normal force has hidden layers of its own. */
function modelFeatures(architecture: Record<string, unknown>): string {
  const features = architecture.features === "history" ? "paper + history" : "paper";
  return architecture.normal_force === "own" ? `${features}; fx own layers` : features;
}
