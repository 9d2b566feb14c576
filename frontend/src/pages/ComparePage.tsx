import { useMemo } from "react";
import { useQueries } from "@tanstack/react-query";
import { Link } from "react-router-dom";
import { useCampaigns } from "../campaign/queries";
import { metricsQuery, validationQuery, withValidation } from "../api/series";
import { auxLawTraces, componentTraces, RmseQuantitySelect, useRmseQuantity } from "../campaign/RmsePlot";
import { Plot, type Trace } from "../components/Plot";
import { Empty, ErrorBox, Loading } from "../components/States";
import { componentUnit, isMarked, type MetricPoint, type RmseQuantity, type SuiteReference } from "../lib/metrics";
import { useBoolParam, useIntListParam, useStringParam } from "../lib/urlState";
import { isXAxis, xOf, xTitle, type XAxis } from "../lib/xaxis";
import { XAxisSwitch } from "../components/XAxisSwitch";
import { useTitle } from "../lib/title";

const COLORS = ["#2f5bd3", "#d3662f", "#1d7a45", "#8a3ffc"];

/** What one plot shows: the force or moment vector, or one wrench component (fx .. mz). */
type Plotted = "force" | "moment" | Exclude<RmseQuantity, "vector">;

/** One campaign's force or moment RMSE: over the new oracle data (solid) and on the held-out suite (dashed). */
function vectorTraces(pts: MetricPoint[], q: "force" | "moment", axis: XAxis, name: string, color: string): Trace[] {
  const loop = (p: MetricPoint) => (q === "force" ? p.force_rmse : p.moment_rmse);
  const suite = (p: MetricPoint) => (q === "force" ? p.validation_force_rmse : p.validation_moment_rmse) ?? null;
  const line = { color };
  const traces: Trace[] = [{ x: pts.map((p) => xOf(p, axis)), y: pts.map(loop), name, mode: "lines+markers", type: "scatter", line }];
  const held = pts.filter((p) => p.validation_force_rmse != null);
  if (held.length) traces.push({ x: held.map((p) => xOf(p, axis)), y: held.map(suite), name: `${name}, held-out suite`, mode: "lines+markers", type: "scatter", line: { ...line, dash: "dash" } });
  return traces;
}

function plotTitle(q: Plotted): string {
  return q === "force" ? "Force RMSE [N]" : q === "moment" ? "Moment RMSE [N m]" : `${q} RMSE [${componentUnit(q)}]`;
}

export function ComparePage() {
  useTitle("Compare campaigns");
  const [ids, setIds] = useIntListParam("ids");
  const [logY, setLogY] = useBoolParam("log", true);
  const [xRaw, setXAxis] = useStringParam("x", "iteration");
  const [quantity, setQuantity] = useRmseQuantity();
  const xAxis = isXAxis(xRaw) ? xRaw : "iteration";
  const campaigns = useCampaigns({});
  const series = useQueries({ queries: ids.map((id) => metricsQuery(id)) });
  // each model version's error on the held-out suite, and the auxiliary law's (as on the campaign page)
  const validations = useQueries({ queries: ids.map((id) => validationQuery(id)) });
  const names = useMemo(() => new Map((campaigns.data ?? []).map((c) => [c.id, c.name])), [campaigns.data]);
  const data = series.map((s) => s.data);
  const validationData = validations.map((v) => v.data);
  const dataKey = [...series, ...validations].map((s) => s.dataUpdatedAt).join();
  // eslint-disable-next-line react-hooks/exhaustive-deps -- the series change only when some query's data updated
  const [seriesData, suiteData] = useMemo(() => [data, validationData], [dataKey]);

  const plots = useMemo(() => {
    const points = ids.map((_, i) => withValidation((seriesData[i] ?? []).filter((p) => !isMarked(p)), suiteData[i]));
    const label = (id: number) => names.get(id) ?? `campaign ${id}`;
    // the auxiliary law's line once per distinct suite, across the iterations of the campaigns evaluated on it
    const suites = new Map<number, { auxLaw: SuiteReference; names: string[]; points: MetricPoint[] }>();
    ids.forEach((id, i) => {
      const v = suiteData[i];
      if (!v?.aux_law || !v.suite) return;
      const group = suites.get(v.suite.id) ?? { auxLaw: v.aux_law, names: [], points: [] };
      group.names.push(label(id));
      group.points.push(...points[i]);
      suites.set(v.suite.id, group);
    });
    const plotted: Plotted[] = quantity === "vector" ? ["force", "moment"] : [quantity];
    return plotted.map((q) => {
      const traces = ids.flatMap((id, i) => {
        const color = COLORS[i % COLORS.length];
        return q === "force" || q === "moment" ? vectorTraces(points[i], q, xAxis, label(id), color) : componentTraces(points[i], q, xAxis, { name: label(id), color, contact: false });
      });
      for (const group of suites.values()) traces.push(...auxLawTraces(group.points, group.auxLaw, xAxis, q, suites.size > 1 ? group.names.join(", ") : ""));
      return { q, traces };
    });
  }, [ids, seriesData, suiteData, names, xAxis, quantity]);

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
            <RmseQuantitySelect value={quantity} onChange={setQuantity} />
            <XAxisSwitch value={xAxis} onChange={setXAxis} />
            <label className="field-inline">
              <input type="checkbox" checked={logY} onChange={(e) => setLogY(e.target.checked)} /> log axis
            </label>
          </div>
          {series.find((s) => s.isError) && <ErrorBox error={series.find((s) => s.isError)!.error} />}
          <div className={plots.length > 1 ? "grid2" : undefined}>
            {plots.map(({ q, traces }) => (
              <Plot key={q} testId={`compare-${q}`} traces={traces} title={plotTitle(q)} xTitle={xTitle(xAxis)} yTitle={`RMSE [${componentUnit(q)}]`} logY={logY} exportName={`compare-${q}`} />
            ))}
          </div>
        </div>
      )}
    </>
  );
}
