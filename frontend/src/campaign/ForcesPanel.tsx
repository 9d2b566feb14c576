import { useMemo, useState } from "react";
import { useQueries, useQuery } from "@tanstack/react-query";
import type { Dash } from "plotly.js-dist-min";
import { Plot, type Trace } from "../components/Plot";
import { candidateTrajectoryQuery, iterationQuery, pickCurvesQuery, trajectoryQuery } from "./queries";
import { useTaskVersion } from "../api/definitions";
import { ChainPlayer } from "../components/ChainPlayer";
import { resolveModel } from "../lib/kinematics";
import type { IterationCurves } from "../api/types";
import { ErrorBox, Empty, Loading } from "../components/States";
import type { MetricPoint } from "../lib/metrics";
import { everyKth, formatSelection, lastN, parseSelection } from "../lib/selection";
import { iterationColor, PLOTLY_SCALE } from "../lib/colors";
import { batchPicks, PickChooser } from "./PickChooser";

const FORCE_COMPONENTS = ["fx", "fy", "fz"] as const;
const MOMENT_COMPONENTS = ["mx", "my", "mz"] as const;
type Component = (typeof FORCE_COMPONENTS)[number] | (typeof MOMENT_COMPONENTS)[number];
/** One iteration: components by colour. */
const COMPONENT_COLOR: Record<Component, string> = { fx: "#2f5bd3", fy: "#1d7a45", fz: "#d3662f", mx: "#8a3ffc", my: "#b3261e", mz: "#007d79" };
const COMPONENT_DASH: Record<Component, Dash> = { fx: "solid", fy: "dashdot", fz: "longdash", mx: "solid", my: "solid", mz: "longdash" };

/** Half-width of the ensemble band in standard deviations (the calibration metric's: mean +- 2 std). */
export const BAND_K = 2;

/** mean - k std and mean + k std, sample by sample. */
export function band(mean: number[], std: number[], k: number): [number[], number[]] {
  return [mean.map((m, i) => m - k * std[i]), mean.map((m, i) => m + k * std[i])];
}

/** A #rrggbb colour with an alpha, for fills. */
export function translucent(color: string, alpha: number): string {
  const [r, g, b] = [1, 3, 5].map((i) => Number.parseInt(color.slice(i, i + 2), 16));
  return `rgba(${r},${g},${b},${alpha})`;
}

/**
 * The traces of the force (or moment) plot. One iteration: a colour per component, oracle
 * solid, surrogate dashed (an ensemble's mean, in a shaded band of mean ± 2 std), a small legend. Several: the colour is the iteration on a sequential
 * scale (one colorbar, no legend entry per iteration, so the plot keeps its size), the
 * component is the line style, the surrogate a thinner dotted line.
 */
export function wrenchTraces(curves: IterationCurves[], components: readonly Component[]): Trace[] {
  const traces: Trace[] = [];
  if (curves.length <= 1) {
    for (const c of curves)
      for (const comp of components) {
        const color = COMPONENT_COLOR[comp];
        const std = c.std?.[comp];
        // the ensemble's +-2 std band around its mean, drawn first (below the lines): the lower
        // edge, then the upper edge filled down to it
        if (std?.length === c.t.length) {
          const [lo, hi] = band(c.predicted[comp], std, BAND_K);
          traces.push({ x: c.t, y: lo, name: `${comp} −2σ`, mode: "lines", type: "scatter", line: { width: 0, color }, showlegend: false, hoverinfo: "skip" });
          traces.push({ x: c.t, y: hi, name: `${comp} surrogate ±2σ`, mode: "lines", type: "scatter", line: { width: 0, color }, fill: "tonexty", fillcolor: translucent(color, 0.18), hoverinfo: "skip" });
        }
        traces.push({ x: c.t, y: c.truth[comp], name: `${comp} oracle`, mode: "lines", type: "scatter", line: { color, width: 2 } });
        traces.push({ x: c.t, y: c.predicted[comp], name: std ? `${comp} surrogate (ensemble mean)` : `${comp} surrogate`, mode: "lines", type: "scatter", line: { color, width: 1.5, dash: "dash" } });
      }
    return traces;
  }
  const ks = curves.map((c) => c.iteration);
  const lo = Math.min(...ks);
  const hi = Math.max(...ks);
  for (const c of curves)
    for (const comp of components) {
      const color = iterationColor(c.iteration, lo, hi);
      const dash = COMPONENT_DASH[comp];
      const name = `k=${c.iteration} ${comp}`;
      traces.push({ x: c.t, y: c.truth[comp], name: `${name} oracle`, mode: "lines", type: "scatter", line: { color, width: 1.8, dash }, showlegend: false });
      traces.push({ x: c.t, y: c.predicted[comp], name: `${name} surrogate`, mode: "lines", type: "scatter", line: { color, width: 1, dash: "dot" }, showlegend: false, opacity: 0.8 });
    }
  // the colorbar: an invisible marker trace carrying the scale from the first to the last iteration
  traces.push({
    x: [null],
    y: [null],
    name: "iteration",
    mode: "markers",
    type: "scatter",
    hoverinfo: "skip",
    showlegend: false,
    marker: { color: [lo], cmin: lo, cmax: hi, colorscale: PLOTLY_SCALE, showscale: true, colorbar: { title: { text: "k" }, thickness: 12, len: 0.9, outlinewidth: 0 } },
  } as Trace);
  return traces;
}

export const MAX_OVERLAY = 200;

/** A warning when iteration k's OCP solution relies on force outside the surrogate's data. */
/** The history states of a model with memory along one motion, in mm and mm/s (one axis). */
export function historyTraces(curves: IterationCurves): Trace[] {
  const h = curves.history;
  if (!h) return [];
  const col = (j: number, scale: number) => h.map((row) => (row[j] ?? 0) * scale);
  return [
    { x: curves.t, y: col(0, 1e3), type: "scatter", mode: "lines", name: "largest indentation so far [mm]", line: { color: "#2f5bd3" } },
    { x: curves.t, y: col(2, 1e3), type: "scatter", mode: "lines", name: "slip velocity z, low-pass [mm/s]", line: { color: "#d3662f", dash: "longdash" } },
  ];
}

export function TrustBadge({ point }: { point: MetricPoint | undefined }) {
  if (!point || point.ocp_trusted !== false) return null;
  const reasons = point.trust_reasons?.length ? point.trust_reasons : ["relies on force outside the data"];
  return (
    <span className="badge warn" role="status" data-testid="trust-badge" title={reasons.join("\n")}>
      ⚠ OCP solution not trusted: {reasons.join("; ")}
    </span>
  );
}

/**
 * The model iteration k solved with: the task version's model with the iteration's scenario
 * values of model parameters set (strategy random-scenarios moves e.g. the headrest).
 */
export function iterationModel(model: Record<string, unknown> | undefined, scenario: unknown): Record<string, unknown> | undefined {
  const values = ((scenario as { values?: Record<string, number> } | null | undefined)?.values ?? {}) as Record<string, number>;
  const own = Object.entries(values).filter(([path]) => path.startsWith("model."));
  if (!model || !own.length) return model;
  const out = structuredClone(model);
  for (const [path, value] of own) {
    const parts = path.split(".").slice(1);
    let node: Record<string, unknown> = out;
    for (const part of parts.slice(0, -1)) node = (node[part] ??= {}) as Record<string, unknown>;
    node[parts[parts.length - 1]] = value;
  }
  return out;
}

/** Iteration k played back: the chain moving along the replayed trajectory, the oracle's force as an arrow.
 * ``slot``: a batch pick's candidate (its scenario's model); none: the iteration's trajectory. */
function IterationPlayback({ campaignId, curves, task, index, setIndex, slot }: { campaignId: number; curves: IterationCurves; task: { id: number; version: number } | undefined; index: number; setIndex: (i: number) => void; slot?: number }) {
  const version = useTaskVersion(task?.id, task?.version);
  const own = useQuery({ ...trajectoryQuery(campaignId, curves.iteration), enabled: Boolean(task) && slot === undefined });
  const picked = useQuery({ ...candidateTrajectoryQuery(campaignId, curves.iteration, slot ?? 0), enabled: Boolean(task) && slot !== undefined });
  const trajectory = slot === undefined ? own : picked;
  const spec = version.data?.spec as { model?: Record<string, unknown> } | undefined;
  const scenario = trajectory.data?.scenario;
  const chain = useMemo(() => resolveModel(iterationModel(spec?.model, scenario)), [spec, scenario]);
  const force = useMemo(() => ({ fx: curves.truth.fx, fz: curves.truth.fz }), [curves]);
  if (!chain || (task && trajectory.isPending)) return null;
  return (
    <div className="grid2" style={{ marginTop: 10 }}>
      <ChainPlayer chain={chain} t={curves.t} q={curves.q} force={force} index={index} setIndex={setIndex} testId="iteration-player" label={`Iteration ${curves.iteration}'s motion`} />
      <p className="hint">
        Iteration {curves.iteration}&apos;s motion as the oracle replayed it: the chain, the head&apos;s occipital profile and the headrest cushion (the profile overlapping the cushion is how far it is pressed in); the arrow is the oracle&apos;s contact force on the head, drawn at the profile point nearest the headrest. The slider and playback move the red cursor on the force and moment plots.
      </p>
    </div>
  );
}

export function ordinal(n: number): string {
  const tens = n % 100;
  const suffix = tens >= 11 && tens <= 13 ? "th" : ({ 1: "st", 2: "nd", 3: "rd" } as Record<number, string>)[n % 10] ?? "th";
  return `${n}${suffix}`;
}

export function ForcesPanel({
  campaignId,
  points,
  iteration,
  setIteration,
  overlay,
  setOverlay,
  task,
}: {
  campaignId: number;
  /** the campaign's task version (the model the playback draws) */
  task?: { id: number; version: number };
  points: MetricPoint[];
  iteration: number | null;
  setIteration: (k: number) => void;
  /** the overlay as written in the URL, e.g. "1-5, 8" */
  overlay: string;
  setOverlay: (spec: string) => void;
}) {
  // iterations with oracle data (failed ones have no curves); a fork's inherited ones are its source's
  const available = useMemo(() => points.filter((p) => p.iteration > 0 && p.force_rmse !== null && !p.inherited).map((p) => p.iteration), [points]);
  const k = iteration !== null && available.includes(iteration) ? iteration : (available[available.length - 1] ?? null);
  const inherited = useMemo(() => points.filter((p) => p.inherited && p.iteration > 0).map((p) => p.iteration), [points]);
  const [draft, setDraft] = useState<string | null>(null);
  // what the last typed overlay left out, each with its reason, and what it read otherwise than written (the overlay keeps the rest)
  const [dropped, setDropped] = useState<string[]>([]);
  const selection = useMemo(() => parseSelection(overlay, available, inherited), [overlay, available, inherited]);
  const shown = useMemo(() => {
    if (k === null) return [];
    const extra = selection.iterations.filter((x) => x !== k);
    return [...new Set([...extra, k])].sort((a, b) => a - b).slice(-MAX_OVERLAY);
  }, [k, selection.iterations]);
  const overlaid = shown.length > 1;
  // a batch iteration's picks: the one shown (pick 0 = the first, the iteration's own curves); none in an overlay
  const point = points.find((p) => p.iteration === k);
  const picks = overlaid ? [] : batchPicks(point);
  const [chosen, setChosen] = useState<{ k: number | null; pick: number }>({ k: null, pick: 0 });
  const pick = chosen.k === k && picks.some((p) => p.pick === chosen.pick) ? chosen.pick : 0;
  const pickSlot = picks.find((p) => p.pick === pick)?.slot;
  const [forceComps, setForceComps] = useState<Component[]>(["fx", "fz"]);
  const [momentComps, setMomentComps] = useState<Component[]>(["my"]);
  const results = useQueries({ queries: shown.map((it) => (it === k && pick > 0 ? pickCurvesQuery(campaignId, it, pick) : iterationQuery(campaignId, it))) });
  const loaded = results.map((r) => r.data).filter((d): d is IterationCurves => Boolean(d));
  const loadedKey = `${loaded.map((c) => c.iteration).join()}|${pick}`;
  // eslint-disable-next-line react-hooks/exhaustive-deps -- the curves are immutable: the loaded iterations identify them
  const curves = useMemo(() => loaded, [loadedKey]);
  const forceTraces = useMemo(() => wrenchTraces(curves, forceComps), [curves, forceComps]);
  const momentTraces = useMemo(() => wrenchTraces(curves, momentComps), [curves, momentComps]);
  const hasBand = !overlaid && curves.some((c) => c.std !== null);
  // the playback's sample, per iteration (a new iteration starts at its beginning)
  const [played, setPlayed] = useState<{ k: number | null; index: number }>({ k: null, index: 0 });
  const index = played.k === k ? played.index : 0;
  const single = !overlaid && curves.length === 1 && curves[0].iteration === k ? curves[0] : null;
  const cursor = single ? single.t[Math.min(index, single.t.length - 1)] : null;

  if (available.length === 0) return <Empty title="No iteration has oracle data yet">Forces appear when the first iteration's oracle step is done.</Empty>;
  const error = results.find((r) => r.isError)?.error;
  const choose = (ks: number[], leftOut: string[] = []) => {
    setDraft(null);
    setDropped(leftOut);
    setOverlay(formatSelection(ks, available));
  };
  const chooseTyped = (typed: string) => {
    const s = parseSelection(typed, available, inherited);
    choose(s.iterations, [...s.errors.map((m) => `left out ${m}`), ...s.notes]);
  };
  const overlayProblems = [...new Set([...selection.errors.map((m) => `left out ${m}`), ...dropped])];
  const text = draft ?? overlay;
  // about 10 iterations of the whole campaign
  const every = Math.ceil(available.length / 10);

  const compToggle = (list: Component[], set: (v: Component[]) => void, all: readonly Component[]) =>
    all.map((c) => (
      <label key={c} className="field-inline">
        <input type="checkbox" checked={list.includes(c)} onChange={() => set(list.includes(c) ? list.filter((x) => x !== c) : [...list, c])} /> {c}
      </label>
    ));

  return (
    <div data-testid="forces-panel" data-iteration={k ?? ""} data-shown={shown.join(",")} data-pick={picks.length ? pick : ""}>
      <div className="slider">
        <label htmlFor="iteration-slider">Iteration</label>
        <input
          id="iteration-slider"
          type="range"
          min={available[0]}
          max={available[available.length - 1]}
          step={1}
          value={k ?? 0}
          onChange={(e) => {
            // snap to the nearest iteration with oracle data (failed ones leave gaps)
            const want = Number(e.target.value);
            setIteration(available.reduce((best, it) => (Math.abs(it - want) < Math.abs(best - want) ? it : best), available[0]));
          }}
          aria-valuetext={`iteration ${k}`}
        />
        <output htmlFor="iteration-slider" data-testid="iteration-value">
          k = {k}
        </output>
        {/* the metrics row's OCP figures are slot 0's */}
        {(pickSlot === undefined || pickSlot === 0) && <TrustBadge point={point} />}
        {k !== null && <PickChooser campaignId={campaignId} iteration={k} picks={picks} pick={pick} setPick={(p) => setChosen({ k, pick: p })} />}
      </div>
      <form
        className="toolbar"
        onSubmit={(e) => {
          e.preventDefault();
          chooseTyped(text);
        }}
      >
        <label htmlFor="overlay-input">Overlay iterations</label>
        <input
          id="overlay-input"
          value={text}
          placeholder="e.g. 1-5, 8, 12-20"
          size={22}
          onChange={(e) => setDraft(e.target.value)}
          onBlur={() => draft !== null && chooseTyped(draft)}
          aria-describedby={overlayProblems.length ? "overlay-hint overlay-problems" : "overlay-hint"}
          aria-invalid={overlayProblems.length > 0}
        />
        <button type="submit">Show</button>
        <span role="group" aria-label="Quick choices" className="toolbar">
          <button type="button" className="link" onClick={() => choose(lastN(available, 5))}>
            last 5
          </button>
          <button type="button" className="link" onClick={() => choose(lastN(available, 20))}>
            last 20
          </button>
          {every > 1 && (
            <button type="button" className="link" onClick={() => choose(everyKth(available, every))}>
              every {ordinal(every)}
            </button>
          )}
          <button type="button" className="link" onClick={() => choose(available)}>
            all ({available.length})
          </button>
          {overlay && (
            <button type="button" className="link" onClick={() => choose([])}>
              clear
            </button>
          )}
        </span>
        <small id="overlay-hint" className="hint" data-testid="overlay-summary">
          {overlaid ? `${shown.length} iterations shown, coloured by k (${shown[0]}–${shown[shown.length - 1]})` : "ranges and lists, e.g. 1-5, 8, 12-20"}
        </small>
      </form>
      {overlayProblems.length > 0 && (
        <div id="overlay-problems" className="field-error" role="alert" data-testid="overlay-problems">
          {overlayProblems.map((m) => (
            <p key={m} style={{ margin: 0 }}>
              Overlay: {m}
            </p>
          ))}
        </div>
      )}
      {error ? <ErrorBox error={error} /> : null}
      {results.some((r) => r.isPending) && curves.length === 0 ? (
        <Loading label="Loading iteration curves…" />
      ) : (
        <div className="grid2">
          <div>
            <div className="toolbar" role="group" aria-label="Force components">
              {compToggle(forceComps, setForceComps, FORCE_COMPONENTS)}
            </div>
            <Plot testId="force-plot" traces={forceTraces} xTitle="t [s]" yTitle="force [N]" exportName={`forces-k${k}${picks.length ? `-pick${pick + 1}` : ""}`} height={300} data={{ band: hasBand ? "2std" : "" }} cursorX={cursor} />
          </div>
          <div>
            <div className="toolbar" role="group" aria-label="Moment components">
              {compToggle(momentComps, setMomentComps, MOMENT_COMPONENTS)}
            </div>
            <Plot testId="moment-plot" traces={momentTraces} xTitle="t [s]" yTitle="moment [N m]" exportName={`moments-k${k}${picks.length ? `-pick${pick + 1}` : ""}`} height={300} data={{ band: hasBand ? "2std" : "" }} cursorX={cursor} />
          </div>
        </div>
      )}
      {single?.history && (
        <div>
          <h4>History states of model {single.iteration}</h4>
          <Plot testId="history-plot" traces={historyTraces(single)} xTitle="t [s]" yTitle="mm, mm/s" exportName={`history-k${k}${picks.length ? `-pick${pick + 1}` : ""}`} height={240} cursorX={cursor} />
          <p className="hint">
            What the model remembers of the motion so far (its inputs beside the state): the deepest the head has pressed into the headrest, and the slip of the contact point along it, filtered over the last tens of milliseconds. The friction force depends on them.
          </p>
        </div>
      )}
      {single && <IterationPlayback key={pick} campaignId={campaignId} curves={single} task={task} slot={pickSlot} index={index} setIndex={(i) => setPlayed({ k: single.iteration, index: i })} />}
      <p className="hint">
        {overlaid
          ? "Colour: iteration k (dark: early, light: late). Thick line: oracle (truth); thin dotted: surrogate model k's prediction. Components: fx solid, fy dash-dot, fz long dash (moments likewise)."
          : `Solid: oracle (truth). Dashed: prediction of surrogate model k (trained on pool version k−1, the contact model of iteration k's OCP) on the same trajectory, data it has not seen.${
              picks.length ? ` Iteration ${k} replayed ${picks.length} picked trajectories: this is pick ${pick + 1}'s.` : ""
            }${
              hasBand ? " Shaded: the ensemble's mean ± 2 standard deviations (where the members disagree, the model is not sure)." : ""
            }`}{" "}
        Forces and moments act on the head, in the headrest frame.
      </p>
    </div>
  );
}
