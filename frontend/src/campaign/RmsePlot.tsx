import { useMemo } from "react";
import { Plot, type Trace } from "../components/Plot";
import { isMarked, type MetricPoint } from "../lib/metrics";

const INHERITED = "#a3a9b6";

/**
 * Force and moment RMSE per iteration (of the error vector, docs/concepts.md), and the same over
 * the samples in contact (dotted, where given); failed and quarantined iterations as red x. A
 * fork's inherited iterations (its source's, up to the fork point) are drawn grey, its own in colour.
 * Beside them, dashed: model k's generalisation error on the held-out validation suite.
 */
export function rmseTraces(points: MetricPoint[], name = ""): Trace[] {
  const own = points.filter((p) => !isMarked(p) && !p.inherited);
  const inherited = points.filter((p) => !isMarked(p) && p.inherited);
  const marked = points.filter(isMarked);
  const prefix = name ? `${name}: ` : "";
  const traces: Trace[] = [];
  if (inherited.length) {
    // joined to the first own iteration, so the line continues across the fork point
    const bridge = own.length ? [...inherited, own[0]] : inherited;
    traces.push(
      { x: bridge.map((p) => p.iteration), y: bridge.map((p) => p.force_rmse), name: `${prefix}force RMSE [N], inherited`, mode: "lines+markers", type: "scatter", line: { color: INHERITED }, marker: { color: INHERITED, symbol: "circle-open" } },
      { x: bridge.map((p) => p.iteration), y: bridge.map((p) => p.moment_rmse), name: `${prefix}moment RMSE [N m], inherited`, mode: "lines+markers", type: "scatter", line: { color: INHERITED, dash: "dot" }, marker: { color: INHERITED, symbol: "square-open" } },
    );
  }
  traces.push(
    { x: own.map((p) => p.iteration), y: own.map((p) => p.force_rmse), name: `${prefix}force RMSE [N]`, mode: "lines+markers", type: "scatter", line: { color: "#2f5bd3" } },
    { x: own.map((p) => p.iteration), y: own.map((p) => p.moment_rmse), name: `${prefix}moment RMSE [N m]`, mode: "lines+markers", type: "scatter", line: { color: "#d3662f" } },
  );
  const validated = own.filter((p) => p.validation_force_rmse != null);
  if (validated.length)
    traces.push(
      { x: validated.map((p) => p.iteration), y: validated.map((p) => p.validation_force_rmse ?? null), name: `${prefix}force RMSE, held-out suite [N]`, mode: "lines+markers", type: "scatter", line: { color: "#2f5bd3", dash: "dash" }, marker: { color: "#2f5bd3", symbol: "diamond-open" } },
      { x: validated.map((p) => p.iteration), y: validated.map((p) => p.validation_moment_rmse ?? null), name: `${prefix}moment RMSE, held-out suite [N m]`, mode: "lines+markers", type: "scatter", line: { color: "#d3662f", dash: "dash" }, marker: { color: "#d3662f", symbol: "diamond-open" } },
    );
  if (own.some((p) => p.force_rmse_contact != null))
    traces.push(
      { x: own.map((p) => p.iteration), y: own.map((p) => p.force_rmse_contact ?? null), name: `${prefix}force RMSE in contact [N]`, mode: "lines", type: "scatter", line: { color: "#2f5bd3", dash: "dot" } },
      { x: own.map((p) => p.iteration), y: own.map((p) => p.moment_rmse_contact ?? null), name: `${prefix}moment RMSE in contact [N m]`, mode: "lines", type: "scatter", line: { color: "#d3662f", dash: "dot" } },
    );
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
  const own = points.filter((p) => !p.inherited);
  return (
    <Plot
      testId="rmse-plot"
      traces={traces}
      xTitle="iteration k"
      yTitle="RMSE: new oracle data (solid), held-out suite (dashed)"
      logY={logY}
      exportName="rmse"
      onPointClick={(x) => onSelect?.(x)}
      height={300}
      extraLayout={xLayout}
      data={{ iterations: own.filter((p) => p.force_rmse !== null).map((p) => p.iteration).join(","), inherited: points.filter((p) => p.inherited).map((p) => p.iteration).join(","), validation: own.filter((p) => p.validation_force_rmse != null).map((p) => p.iteration).join(",") }}
    />
  );
}
