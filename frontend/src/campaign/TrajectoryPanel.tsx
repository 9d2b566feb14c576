import { useMemo, useState } from "react";
import { useQuery } from "@tanstack/react-query";
import type { Annotation, Layout, Shape } from "plotly.js-dist-min";
import { Plot, type Trace } from "../components/Plot";
import { iterationQuery, trajectoryQuery } from "./queries";
import { useTaskVersion } from "../api/definitions";
import { ChainPlayer, sampleAt } from "../components/ChainPlayer";
import { resolveModel } from "../lib/kinematics";
import { iterationModel } from "./ForcesPanel";
import type { IterationCurves, Phase, WholeTrajectory } from "../api/types";
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

/**
 * The oracle's contact force (fx, fz in H) at the OCP grid's times: the replayed sample at or
 * before each time within the replayed part, none (null) after it.
 */
export function forceOnGrid(t: readonly number[], replayEnd: number, curves: Pick<IterationCurves, "t" | "truth"> | undefined): { fx: (number | null)[]; fz: (number | null)[] } | null {
  if (!curves?.t.length) return null;
  const eps = 1e-9 * Math.max(1, Math.abs(replayEnd));
  const at = t.map((time) => (time <= replayEnd + eps ? sampleAt(curves.t, time) : -1));
  return { fx: at.map((i) => (i < 0 ? null : curves.truth.fx[i])), fz: at.map((i) => (i < 0 ? null : curves.truth.fz[i])) };
}

export function TrajectoryPanel({ campaignId, iteration, task }: { campaignId: number; iteration: number | null; task?: { id: number; version: number } }) {
  const q = useQuery({ ...trajectoryQuery(campaignId, iteration ?? 0), enabled: iteration !== null });
  // the playback: the task version's model (with the iteration's scenario), the oracle's force where it replayed
  const version = useTaskVersion(task?.id, task?.version);
  const curves = useQuery({ ...iterationQuery(campaignId, iteration ?? 0), enabled: iteration !== null && iteration > 0 });
  const scenario = q.data?.scenario;
  const spec = version.data?.spec as { model?: Record<string, unknown> } | undefined;
  const chain = useMemo(() => resolveModel(iterationModel(spec?.model, scenario)), [spec, scenario]);
  const rows = useMemo(() => (q.data ? q.data.t.map((_, i) => q.data.q.map((col) => col[i])) : []), [q.data]);
  const force = useMemo(() => (q.data ? forceOnGrid(q.data.t, q.data.replay_t_end, curves.data) : null), [q.data, curves.data]);
  const [played, setPlayed] = useState<{ k: number | null; index: number }>({ k: null, index: 0 });
  const index = played.k === iteration ? played.index : 0;
  const cursor = chain && q.data?.t.length ? q.data.t[Math.min(index, q.data.t.length - 1)] : null;
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
        <Plot testId="angle-plot" traces={angle} shapes={shapes} extraLayout={layout} xTitle="t [s]" yTitle="joint angle θ [rad]" exportName={`angle-k${iteration}`} height={280} cursorX={cursor} />
        <Plot testId="torque-plot" traces={torque} shapes={shapes} extraLayout={layout} xTitle="t [s]" yTitle="joint torque τ [N m]" exportName={`torque-k${iteration}`} height={280} cursorX={cursor} />
      </div>
      {chain && (
        <div className="grid2" style={{ marginTop: 10 }}>
          <ChainPlayer chain={chain} t={d.t} q={rows} force={force} index={index} setIndex={(i) => setPlayed({ k: iteration, index: i })} testId="trajectory-player" label={`Iteration ${iteration}'s OCP solution`} />
          <p className="hint">
            Iteration {iteration}&apos;s whole OCP solution played back: the chain, the head&apos;s occipital profile and the headrest cushion at each node; the arrow is the oracle&apos;s contact force on the head where the oracle replayed the motion (t ≤ {fmtNumber(d.replay_t_end, 3)} s). The slider and playback move the red cursor on the angle and torque plots.
          </p>
        </div>
      )}
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
