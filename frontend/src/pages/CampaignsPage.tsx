import { useMemo, useState } from "react";
import { Link, useNavigate } from "react-router-dom";
import { useQueries } from "@tanstack/react-query";
import { progressText, useCampaigns } from "../campaign/queries";
import { metricsQuery } from "../api/series";
import { useCampaignListLive } from "../api/live";
import type { CampaignSummary } from "../api/types";
import { isMarked } from "../lib/metrics";
import { Empty, ErrorBox, Loading, StatusBadge } from "../components/States";
import { Sparkline } from "../components/Sparkline";
import { fmtDate, fmtDuration, fmtNumber } from "../lib/format";
import { useStringParam } from "../lib/urlState";
import { useTitle } from "../lib/title";

const STATUSES = ["", "draft", "queued", "running", "pausing", "paused", "cancelling", "cancelled", "completed", "failed"];

type SortKey = "name" | "status" | "owner" | "current_iteration" | "force_rmse" | "moment_rmse" | "started_at";

export function sortCampaigns(rows: CampaignSummary[], key: SortKey, descending: boolean): CampaignSummary[] {
  const value = (r: CampaignSummary): string | number => {
    const v = r[key];
    if (v === null || v === undefined) return descending ? -Infinity : Infinity;
    return v as string | number;
  };
  return [...rows].sort((a, b) => {
    const va = value(a);
    const vb = value(b);
    const c = typeof va === "number" && typeof vb === "number" ? va - vb : String(va).localeCompare(String(vb));
    return descending ? -c : c;
  });
}

export function CampaignsPage() {
  useTitle("Campaigns");
  const navigate = useNavigate();
  const [status, setStatus] = useStringParam("status");
  const [search, setSearch] = useStringParam("q");
  const [sort, setSort] = useStringParam("sort", "-started_at");
  const [selected, setSelected] = useState<number[]>([]);
  const live = useCampaignListLive();
  const campaigns = useCampaigns({ status: status || undefined });

  const sortKey = sort.replace(/^-/, "") as SortKey;
  const descending = sort.startsWith("-");
  const rows = useMemo(() => {
    const all = campaigns.data ?? [];
    const q = search.trim().toLowerCase();
    const filtered = q ? all.filter((c) => [c.name, c.task, c.oracle, c.oracle_type, c.owner].some((s) => s?.toLowerCase().includes(q))) : all;
    return sortCampaigns(filtered, sortKey, descending);
  }, [campaigns.data, search, sortKey, descending]);

  const header = (key: SortKey, label: string, num = false) => (
    <th className={num ? "num" : undefined} aria-sort={sortKey === key ? (descending ? "descending" : "ascending") : "none"}>
      <button type="button" className="sort" onClick={() => setSort(sortKey === key && !descending ? `-${key}` : key)}>
        {label}
        {sortKey === key ? (descending ? " ▼" : " ▲") : ""}
      </button>
    </th>
  );

  // sparklines: the RMSE series of the first 50 rows, fetched once each and refreshed when the
  // live channel says a campaign evaluated an iteration (no polling of their own)
  const histories = useQueries({ queries: rows.slice(0, 50).map((r) => ({ ...metricsQuery(r.id), staleTime: Infinity })) });
  const historyOf = new Map(
    rows.slice(0, 50).map((r, i) => {
      const pts = (histories[i]?.data ?? []).filter((p) => !isMarked(p));
      return [r.id, { force: pts.map((p) => p.force_rmse ?? NaN), moment: pts.map((p) => p.moment_rmse ?? NaN) }];
    }),
  );

  const toggle = (id: number) => setSelected((s) => (s.includes(id) ? s.filter((x) => x !== id) : s.length >= 4 ? s : [...s, id]));

  return (
    <>
      <div className="toolbar">
        <h1 style={{ margin: 0 }}>Campaigns</h1>
        <span className="muted" data-testid="live-state" data-state={live.state}>
          {live.state === "live" ? "live" : live.state === "down" ? `live updates interrupted, checking every ${Math.round(Number(live.poll) / 1000)} s` : ""}
        </span>
        <span className="spacer" />
        <button type="button" disabled={selected.length < 2} onClick={() => navigate(`/compare?ids=${selected.join(",")}`)} title="Select 2 to 4 campaigns">
          Compare selected ({selected.length})
        </button>
        <Link className="button primary" to="/campaigns/new">
          New campaign
        </Link>
      </div>
      <div className="panel">
        <div className="toolbar">
          <label htmlFor="filter-status">Status</label>
          <select id="filter-status" value={status} onChange={(e) => setStatus(e.target.value)}>
            {STATUSES.map((s) => (
              <option key={s} value={s}>
                {s || "any"}
              </option>
            ))}
          </select>
          <label htmlFor="filter-q">Search</label>
          <input id="filter-q" type="search" placeholder="name, task, oracle, owner" value={search} onChange={(e) => setSearch(e.target.value)} />
        </div>
        {campaigns.isPending ? (
          <Loading />
        ) : campaigns.isError ? (
          <ErrorBox error={campaigns.error} retry={() => void campaigns.refetch()} />
        ) : rows.length === 0 ? (
          <Empty title={campaigns.data.length ? "No campaign matches these filters" : "No campaigns yet"}>
            {campaigns.data.length ? null : (
              <>
                Define a <Link to="/tasks/new">task</Link> and an <Link to="/oracles/new">oracle</Link>, then <Link to="/campaigns/new">start a campaign</Link>.
              </>
            )}
          </Empty>
        ) : (
          <table data-testid="campaigns-table">
            <thead>
              <tr>
                <th>
                  <span className="sr-only">Select</span>
                </th>
                {header("name", "Name")}
                {header("status", "Status")}
                {header("owner", "Owner")}
                <th>Task</th>
                <th>Oracle</th>
                {header("current_iteration", "Iteration", true)}
                {header("force_rmse", "Force RMSE", true)}
                {header("moment_rmse", "Moment RMSE", true)}
                {header("started_at", "Started")}
                <th>ETA</th>
              </tr>
            </thead>
            <tbody>
              {rows.map((c) => (
                <tr key={c.id} className="clickable" data-campaign-id={c.id} data-status={c.status}>
                  <td>
                    <input type="checkbox" aria-label={`Select ${c.name} for comparison`} checked={selected.includes(c.id)} onChange={() => toggle(c.id)} />
                  </td>
                  <td>
                    <Link to={`/campaigns/${c.id}`}>{c.name}</Link>
                  </td>
                  <td>
                    <StatusBadge status={c.status} title={c.wait_reason ?? undefined} />
                    {c.wait_reason && <span className="muted"> waiting for a free place</span>}
                  </td>
                  <td>{c.owner}</td>
                  <td>
                    {c.task} v{c.task_version}
                  </td>
                  <td>
                    {c.oracle} ({c.oracle_type})
                  </td>
                  <td className="num">{progressText(c.current_iteration, c.max_iterations)}</td>
                  <td className="num">
                    {fmtNumber(c.force_rmse)} <Sparkline values={historyOf.get(c.id)?.force ?? []} label={`force RMSE history of ${c.name}`} />
                  </td>
                  <td className="num">
                    {fmtNumber(c.moment_rmse)} <Sparkline values={historyOf.get(c.id)?.moment ?? []} label={`moment RMSE history of ${c.name}`} />
                  </td>
                  <td>{fmtDate(c.started_at)}</td>
                  <td>{c.eta_s !== null && c.eta_s !== undefined ? fmtDuration(c.eta_s) : "—"}</td>
                </tr>
              ))}
            </tbody>
          </table>
        )}
      </div>
    </>
  );
}
