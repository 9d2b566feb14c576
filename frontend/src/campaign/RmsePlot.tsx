import { useMemo } from "react";
import { Plot, type Trace } from "../components/Plot";
import { isMarked, type MetricPoint } from "../lib/metrics";

export function rmseTraces(points: MetricPoint[], name = ""): Trace[] {
  const ok = points.filter((p) => !isMarked(p));
  const marked = points.filter(isMarked);
  const prefix = name ? `${name}: ` : "";
  const traces: Trace[] = [
    { x: ok.map((p) => p.iteration), y: ok.map((p) => p.force_rmse), name: `${prefix}force RMSE [N]`, mode: "lines+markers", type: "scatter", line: { color: "#2f5bd3" } },
    { x: ok.map((p) => p.iteration), y: ok.map((p) => p.moment_rmse), name: `${prefix}moment RMSE [N m]`, mode: "lines+markers", type: "scatter", line: { color: "#d3662f" } },
  ];
  if (marked.length)
    traces.push({
      x: marked.map((p) => p.iteration),
      y: marked.map((p) => p.force_rmse ?? p.moment_rmse ?? null),
      text: marked.map((p) => (p.quarantined ? "quarantined" : p.status)),
      name: "failed / quarantined",
      mode: "markers",
      type: "scatter",
      marker: { symbol: "x", size: 11, color: "#b3261e" },
    });
  return traces;
}

export function RmsePlot({ points, logY, onSelect }: { points: MetricPoint[]; logY: boolean; onSelect?: (k: number) => void }) {
  const traces = useMemo(() => rmseTraces(points), [points]);
  const few = points.length > 0 && points[points.length - 1].iteration <= 12;
  const xLayout = useMemo(() => ({ xaxis: { title: { text: "iteration k" }, dtick: few ? 1 : undefined, zeroline: false } }), [few]);
  return (
    <Plot
      testId="rmse-plot"
      traces={traces}
      xTitle="iteration k"
      yTitle="RMSE on the new oracle data"
      logY={logY}
      exportName="rmse"
      onPointClick={(x) => onSelect?.(x)}
      height={300}
      extraLayout={xLayout}
    />
  );
}
