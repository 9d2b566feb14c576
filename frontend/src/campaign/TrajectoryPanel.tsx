import { useMemo } from "react";
import { useQuery } from "@tanstack/react-query";
import type { Annotation, Layout, Shape } from "plotly.js-dist-min";
import { Plot, type Trace } from "../components/Plot";
import { trajectoryQuery } from "../api/campaigns";
import type { Phase, WholeTrajectory } from "../api/types";
import { ApiError } from "../api/errors";
import { Empty, ErrorBox, Loading, StatusBadge } from "../components/States";
import { fmtNumber } from "../lib/format";

const PHASE_FILLS = ["rgba(47,91,211,0.07)", "rgba(211,102,47,0.09)", "rgba(29,122,69,0.08)", "rgba(138,63,252,0.07)"];
const REPLAY_COLOR = "#1f3d99";
/** Room above the plot area for the "replayed by the oracle" bracket; a legend (several joints) goes to the right. */
export const TRAJECTORY_MARGIN = { l: 64, r: 16, t: 52, b: 44 };

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
    label: { text: p.name || `phase ${i + 1}`, textposition: "top center", font: { size: 11, color: "#6b7385" } },
  })) as Partial<Shape>[];
}

function seriesTraces(t: number[], rows: number[][], name: string, unit: string): Trace[] {
  return rows.map((y, j) => ({ x: t, y, name: rows.length > 1 ? `${name}_${j} [${unit}]` : `${name} [${unit}]`, mode: "lines", type: "scatter" }));
}

/**
 * The phases within a time range, clipped to it (e.g. to the part of the OCP trajectory
 * the oracle replayed).
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

/**
 * A bracket above the plot area over the part [t0, t1] of the time axis the oracle replayed,
 * labelled (outside the data, so it hides no curve): three line shapes (in data x, paper y)
 * and one annotation. The plot needs a top margin for it ({@link TRAJECTORY_MARGIN}).
 */
export function replayMarks(t0: number, t1: number): { shapes: Partial<Shape>[]; annotations: Partial<Annotation>[] } {
  const line = { color: REPLAY_COLOR, width: 1.5 };
  const y = 1.05;
  const tick = 1.0;
  const base = { type: "line", xref: "x", yref: "paper", line, layer: "above" } as const;
  return {
    shapes: [
      { ...base, x0: t0, x1: t1, y0: y, y1: y },
      { ...base, x0: t0, x1: t0, y0: y, y1: tick },
      { ...base, x0: t1, x1: t1, y0: y, y1: tick },
    ] as Partial<Shape>[],
    annotations: [
      {
        x: (t0 + t1) / 2,
        xref: "x",
        y,
        yref: "paper",
        yanchor: "bottom",
        showarrow: false,
        text: "replayed by the oracle",
        font: { size: 11, color: REPLAY_COLOR },
      },
    ] as Partial<Annotation>[],
  };
}

/** The phases of the whole trajectory: names (or "phase i"), spans; which the oracle replayed. */
export function trajectoryPhases(data: Pick<WholeTrajectory, "phases">): (Phase & { replayed: boolean })[] {
  return data.phases.map((p, i) => ({ name: p.name || `phase ${i + 1}`, t_start: p.t_start, t_end: p.t_end, replayed: p.replayed }));
}

/** The scenario an iteration solved (strategy random-scenarios), in words; null: the task as written. */
export function scenarioText(scenario: WholeTrajectory["scenario"]): string | null {
  const values = (scenario?.values ?? {}) as Record<string, number>;
  const keys = Object.keys(values);
  if (!scenario || !keys.length) return null;
  return `Scenario (seed ${String(scenario.seed)}, draw ${String(scenario.iteration)}): ${keys.map((k) => `${k} = ${fmtNumber(values[k], 4)}`).join(", ")}`;
}

/** The solver summary as label/value rows. */
export function solverRows(s: WholeTrajectory["solver"]): [string, string][] {
  return [
    ["Status", s.status],
    ["Converged", s.converged ? "yes" : "no"],
    ["IPOPT iterations", s.iterations === null || s.iterations === undefined ? "—" : String(s.iterations)],
    ["Cost", fmtNumber(s.cost, 4)],
    ["Wall time", s.wall_time_s === null || s.wall_time_s === undefined ? "—" : `${fmtNumber(s.wall_time_s, 3)} s`],
    ["Attempt", `${s.attempt} (initial guess: ${s.initial_guess})`],
  ];
}

/** What the oracle replayed, in words. */
export function replayText(data: Pick<WholeTrajectory, "phases" | "replay_t_end" | "replay_dt">): string {
  const phases = trajectoryPhases(data);
  const replayed = phases.filter((p) => p.replayed).map((p) => p.name);
  const rest = phases.length - replayed.length;
  const grid = data.replay_dt ? `resampled every ${fmtNumber(data.replay_dt * 1000, 3)} ms` : "on the OCP grid";
  const tail = rest > 0 ? ` The task's later ${rest === 1 ? "phase is" : `${rest} phases are`} not replayed.` : "";
  return `The oracle replayed ${replayed.join(", ")} (t ≤ ${fmtNumber(data.replay_t_end, 3)} s, ${grid}).${tail}`;
}

export function TrajectoryPanel({ campaignId, iteration }: { campaignId: number; iteration: number | null }) {
  const q = useQuery({ ...trajectoryQuery(campaignId, iteration ?? 0), enabled: iteration !== null });
  const phases = useMemo(() => (q.data ? trajectoryPhases(q.data) : []), [q.data]);
  const marks = useMemo(() => (q.data && q.data.t.length ? replayMarks(q.data.t[0], q.data.replay_t_end) : null), [q.data]);
  const shapes = useMemo(() => [...phaseShapes(phases), ...(marks?.shapes ?? [])], [phases, marks]);
  const layout = useMemo<Partial<Layout>>(
    () => ({ annotations: marks?.annotations ?? [], margin: TRAJECTORY_MARGIN, legend: { orientation: "h", x: 1, xanchor: "right", y: 1.02, yanchor: "bottom" } }),
    [marks],
  );
  const angle = useMemo(() => (q.data ? seriesTraces(q.data.t, q.data.q, "θ", "rad") : []), [q.data]);
  const torque = useMemo(() => (q.data ? seriesTraces(q.data.t, q.data.tau, "τ", "N m") : []), [q.data]);
  if (iteration === null) return <Empty title="No trajectory yet">The first iteration's OCP has not been solved yet.</Empty>;
  if (q.isPending) return <Loading label="Loading trajectory…" />;
  if (q.isError) {
    if (q.error instanceof ApiError && q.error.status === 404)
      return (
        <Empty title={`Iteration ${iteration} has no OCP trajectory`}>
          {iteration === 0 ? "Iteration 0 is the preliminary data set: it solves no OCP." : "Its OCP step has not run yet."}
        </Empty>
      );
    return <ErrorBox error={q.error} retry={() => void q.refetch()} />;
  }
  const d = q.data;
  if (!d.t.length) return <Empty title={`Iteration ${iteration} has an empty OCP trajectory`} />;
  return (
    <div data-testid="trajectory-panel" data-phases={phases.length} data-replayed-phases={d.replay_phases}>
      <p className="hint" data-testid="phases-replayed">
        Iteration {iteration}'s OCP solution over the whole task ({fmtNumber(d.duration, 3)} s, {d.t.length} nodes; phases {phases.map((p) => p.name).join(" → ")}).{" "}
        {replayText(d)}
      </p>
      {scenarioText(d.scenario) && (
        <p className="hint" data-testid="iteration-scenario">
          {scenarioText(d.scenario)}
        </p>
      )}
      <div className="grid2">
        <Plot testId="angle-plot" traces={angle} shapes={shapes} extraLayout={layout} xTitle="t [s]" yTitle="joint angle θ [rad]" exportName={`angle-k${iteration}`} height={280} />
        <Plot testId="torque-plot" traces={torque} shapes={shapes} extraLayout={layout} xTitle="t [s]" yTitle="joint torque τ [N m]" exportName={`torque-k${iteration}`} height={280} />
      </div>
      <h3 style={{ margin: "12px 0 6px", fontSize: 14 }}>
        OCP solve <StatusBadge status={d.solver.converged ? "succeeded" : "failed"} />
      </h3>
      <dl className="kv" data-testid="solver-summary" style={{ gridTemplateColumns: "max-content 1fr max-content 1fr max-content 1fr" }}>
        {solverRows(d.solver).map(([label, value]) => (
          <div key={label} style={{ display: "contents" }}>
            <dt>{label}</dt>
            <dd>{value}</dd>
          </div>
        ))}
      </dl>
      {d.solver.message && <p className="hint">{d.solver.message}</p>}
    </div>
  );
}
