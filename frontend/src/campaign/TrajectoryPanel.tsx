import { useMemo } from "react";
import { useQuery } from "@tanstack/react-query";
import type { Shape } from "plotly.js-dist-min";
import { Plot, type Trace } from "../components/Plot";
import { iterationQuery, type Phase } from "../api/hooks";
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

function seriesTraces(t: number[], rows: number[][], name: string, unit: string): Trace[] {
  return rows.map((y, j) => ({ x: t, y, name: rows.length > 1 ? `${name}_${j} [${unit}]` : `${name} [${unit}]`, mode: "lines", type: "scatter" }));
}

/**
 * The phases within the time range of the curves, clipped to it: the oracle replays only the
 * first phase(s) of the OCP trajectory (settings.replay_phases), so later phases would only
 * stretch the time axis over an empty plot.
 */
export function clipPhases(phases: Phase[], t: number[]): Phase[] {
  if (!t.length) return phases;
  const lo = t[0];
  const hi = t[t.length - 1];
  const eps = 1e-9 * Math.max(1, Math.abs(hi));
  return phases
    .filter((p) => p.t_end > lo + eps && p.t_start < hi - eps)
    .map((p) => ({ ...p, t_start: Math.max(p.t_start, lo), t_end: Math.min(p.t_end, hi) }));
}

/** Phase spans [t_start, t_end] from the phase durations of a task spec. */
export function phaseSpans(phases: { name?: string; duration?: unknown }[]): Phase[] {
  let t = 0;
  return phases.map((p, i) => {
    const span = { name: p.name || `phase ${i + 1}`, t_start: t, t_end: t + (Number(p.duration) || 0) };
    t = span.t_end;
    return span;
  });
}

export function TrajectoryPanel({ campaignId, iteration, phases }: { campaignId: number; iteration: number | null; phases: Phase[] }) {
  const q = useQuery({ ...iterationQuery(campaignId, iteration ?? 0), enabled: iteration !== null });
  const allPhases = q.data?.phases.length ? q.data.phases : phases;
  const shown = useMemo(() => clipPhases(allPhases, q.data?.t ?? []), [allPhases, q.data]);
  const shapes = useMemo(() => phaseShapes(shown), [shown]);
  const angle = useMemo(() => (q.data ? seriesTraces(q.data.t, q.data.q, "θ", "rad") : []), [q.data]);
  const hasTorque = Boolean(q.data?.tau.length);
  const second = useMemo(
    () => (q.data ? (hasTorque ? seriesTraces(q.data.t_tau ?? q.data.t, q.data.tau, "τ", "N m") : seriesTraces(q.data.t, q.data.qd, "θ̇", "rad/s")) : []),
    [q.data, hasTorque],
  );
  if (iteration === null) return <Empty title="No trajectory yet" />;
  if (q.isPending) return <Loading label="Loading trajectory…" />;
  if (q.isError) return <ErrorBox error={q.error} retry={() => void q.refetch()} />;
  if (!q.data.t.length) return <Empty title={`Iteration ${iteration} has no OCP trajectory`}>The OCP step failed or has not run yet.</Empty>;
  const notReplayed = allPhases.length - shown.length;
  return (
    <div data-testid="trajectory-panel">
      {notReplayed > 0 && (
        <p className="hint" data-testid="phases-not-replayed">
          The motion the oracle replayed (t ≤ {q.data.t[q.data.t.length - 1].toFixed(3)} s): {shown.map((p) => p.name).join(", ")}. The
          task's later {notReplayed === 1 ? "phase is" : `${notReplayed} phases are`} not replayed.
        </p>
      )}
      <div className="grid2">
        <Plot testId="angle-plot" traces={angle} shapes={shapes} xTitle="t [s]" yTitle="joint angle θ [rad]" exportName={`angle-k${iteration}`} height={280} />
        {hasTorque ? (
          <Plot testId="torque-plot" traces={second} shapes={shapes} xTitle="t [s]" yTitle="joint torque τ [N m]" exportName={`torque-k${iteration}`} height={280} />
        ) : (
          <div>
            <Plot testId="velocity-plot" traces={second} shapes={shapes} xTitle="t [s]" yTitle="joint velocity θ̇ [rad/s]" exportName={`velocity-k${iteration}`} height={280} />
            <p className="hint">No joint torque for this iteration (iteration 0 has no oracle run); showing the joint velocity.</p>
          </div>
        )}
      </div>
    </div>
  );
}
