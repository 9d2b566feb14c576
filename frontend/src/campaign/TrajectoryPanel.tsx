import { useMemo } from "react";
import { useQuery } from "@tanstack/react-query";
import type { Shape } from "plotly.js-dist-min";
import { Plot, type Trace } from "../components/Plot";
import { iterationQuery, type IterationCurves, type Phase } from "../api/hooks";
import { Empty, ErrorBox, Loading } from "../components/States";

const PHASE_FILLS = ["rgba(47,91,211,0.07)", "rgba(211,102,47,0.09)", "rgba(29,122,69,0.08)", "rgba(138,63,252,0.07)"];

export function phaseShapes(phases: Phase[]): Partial<Shape>[] {
  return phases.map((p, i) => ({
    type: "rect",
    xref: "x",
    yref: "paper",
    x0: p.t_start,
    x1: p.t_end,
    y0: 0,
    y1: 1,
    fillcolor: PHASE_FILLS[i % PHASE_FILLS.length],
    line: { width: 0 },
    layer: "below",
    label: { text: p.name ?? `phase ${i + 1}`, textposition: "top center", font: { size: 11, color: "#6b7385" } },
  })) as Partial<Shape>[];
}

function seriesTraces(c: IterationCurves, which: "q" | "tau", unit: string): Trace[] {
  const rows = which === "q" ? c.q : c.tau;
  const t = which === "q" ? c.t : (c.t_tau ?? c.t);
  return rows.map((y, j) => ({ x: t, y, name: `${which}_${j} [${unit}]`, mode: "lines", type: "scatter" }));
}

export function TrajectoryPanel({ campaignId, iteration }: { campaignId: number; iteration: number | null }) {
  const q = useQuery({ ...iterationQuery(campaignId, iteration ?? 0), enabled: iteration !== null });
  const shapes = useMemo(() => phaseShapes(q.data?.phases ?? []), [q.data]);
  const angle = useMemo(() => (q.data ? seriesTraces(q.data, "q", "rad") : []), [q.data]);
  const torque = useMemo(() => (q.data ? seriesTraces(q.data, "tau", "N m") : []), [q.data]);
  if (iteration === null) return <Empty title="No trajectory yet" />;
  if (q.isPending) return <Loading label="Loading trajectory…" />;
  if (q.isError) return <ErrorBox error={q.error} retry={() => void q.refetch()} />;
  if (!q.data.t.length) return <Empty title={`Iteration ${iteration} has no OCP trajectory`}>The OCP step failed or has not run yet.</Empty>;
  return (
    <div className="grid2" data-testid="trajectory-panel">
      <Plot testId="angle-plot" traces={angle} shapes={shapes} xTitle="t [s]" yTitle="joint angle θ [rad]" exportName={`angle-k${iteration}`} height={280} />
      <Plot testId="torque-plot" traces={torque} shapes={shapes} xTitle="t [s]" yTitle="joint torque τ [N m]" exportName={`torque-k${iteration}`} height={280} />
    </div>
  );
}
