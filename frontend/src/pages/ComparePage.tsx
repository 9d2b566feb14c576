import { useMemo } from "react";
import { useQueries } from "@tanstack/react-query";
import { Link } from "react-router-dom";
import { useCampaigns } from "../api/campaigns";
import { metricsQuery } from "../api/series";
import { Plot, type Trace } from "../components/Plot";
import { Empty, ErrorBox, Loading } from "../components/States";
import { isMarked } from "../lib/metrics";
import { useBoolParam, useIntListParam, useStringParam } from "../lib/urlState";
import { isXAxis, xOf, xTitle } from "../lib/xaxis";
import { XAxisSwitch } from "../components/XAxisSwitch";

const COLORS = ["#2f5bd3", "#d3662f", "#1d7a45", "#8a3ffc"];

export function ComparePage() {
  const [ids, setIds] = useIntListParam("ids");
  const [logY, setLogY] = useBoolParam("log", true);
  const [xRaw, setXAxis] = useStringParam("x", "iteration");
  const xAxis = isXAxis(xRaw) ? xRaw : "iteration";
  const campaigns = useCampaigns({});
  const series = useQueries({ queries: ids.map((id) => metricsQuery(id)) });
  const names = useMemo(() => new Map((campaigns.data ?? []).map((c) => [c.id, c.name])), [campaigns.data]);
  const data = series.map((s) => s.data);
  const dataKey = series.map((s) => s.dataUpdatedAt).join();
  // eslint-disable-next-line react-hooks/exhaustive-deps -- the series change only when some query's data updated
  const seriesData = useMemo(() => data, [dataKey]);

  const [force, moment] = useMemo(() => {
    const f: Trace[] = [];
    const m: Trace[] = [];
    ids.forEach((id, i) => {
      const pts = (seriesData[i] ?? []).filter((p) => !isMarked(p));
      const name = names.get(id) ?? `campaign ${id}`;
      const line = { color: COLORS[i % COLORS.length] };
      f.push({ x: pts.map((p) => xOf(p, xAxis)), y: pts.map((p) => p.force_rmse), name, mode: "lines+markers", type: "scatter", line });
      m.push({ x: pts.map((p) => xOf(p, xAxis)), y: pts.map((p) => p.moment_rmse), name, mode: "lines+markers", type: "scatter", line });
      const held = pts.filter((p) => p.validation_force_rmse != null);
      if (held.length) {
        const dashed = { ...line, dash: "dash" as const };
        f.push({ x: held.map((p) => xOf(p, xAxis)), y: held.map((p) => p.validation_force_rmse ?? null), name: `${name}, held-out suite`, mode: "lines+markers", type: "scatter", line: dashed });
        m.push({ x: held.map((p) => xOf(p, xAxis)), y: held.map((p) => p.validation_moment_rmse ?? null), name: `${name}, held-out suite`, mode: "lines+markers", type: "scatter", line: dashed });
      }
    });
    return [f, m];
  }, [ids, seriesData, names, xAxis]);

  const toggle = (id: number) => setIds(ids.includes(id) ? ids.filter((x) => x !== id) : ids.length >= 4 ? ids : [...ids, id]);

  return (
    <>
      <h1>Compare campaigns</h1>
      <div className="panel">
        <p className="muted">Select 2 to 4 campaigns.</p>
        {campaigns.isPending ? (
          <Loading />
        ) : campaigns.isError ? (
          <ErrorBox error={campaigns.error} />
        ) : campaigns.data.length === 0 ? (
          <Empty title="No campaigns to compare">
            <Link to="/campaigns/new">Create a campaign</Link>
          </Empty>
        ) : (
          <div className="checks" role="group" aria-label="Campaigns to compare" style={{ maxHeight: 120 }}>
            {campaigns.data.map((c) => (
              <label key={c.id} className="field-inline">
                <input type="checkbox" checked={ids.includes(c.id)} disabled={!ids.includes(c.id) && ids.length >= 4} onChange={() => toggle(c.id)} />
                {c.name} <span className="muted">#{c.id}</span>
              </label>
            ))}
          </div>
        )}
      </div>
      {ids.length < 2 ? (
        <Empty title="Pick at least two campaigns" />
      ) : (
        <div className="panel">
          <div className="toolbar">
            <span className="spacer" />
            <XAxisSwitch value={xAxis} onChange={setXAxis} />
            <label className="field-inline">
              <input type="checkbox" checked={logY} onChange={(e) => setLogY(e.target.checked)} /> log axis
            </label>
          </div>
          {series.find((s) => s.isError) && <ErrorBox error={series.find((s) => s.isError)!.error} />}
          <div className="grid2">
            <Plot testId="compare-force" traces={force} title="Force RMSE [N]" xTitle={xTitle(xAxis)} yTitle="RMSE [N]" logY={logY} exportName="compare-force" />
            <Plot testId="compare-moment" traces={moment} title="Moment RMSE [N m]" xTitle={xTitle(xAxis)} yTitle="RMSE [N m]" logY={logY} exportName="compare-moment" />
          </div>
        </div>
      )}
    </>
  );
}
