import { useMemo, useState } from "react";
import { useQueries } from "@tanstack/react-query";
import type { Dash } from "plotly.js-dist-min";
import { Plot, type Trace } from "../components/Plot";
import { iterationQuery } from "../api/campaigns";
import type { IterationCurves } from "../api/types";
import { ErrorBox, Empty, Loading } from "../components/States";
import type { MetricPoint } from "../lib/metrics";
import { everyKth, formatSelection, lastN, parseSelection } from "../lib/selection";
import { iterationColor, PLOTLY_SCALE } from "../lib/colors";

const FORCE_COMPONENTS = ["fx", "fy", "fz"] as const;
const MOMENT_COMPONENTS = ["mx", "my", "mz"] as const;
type Component = (typeof FORCE_COMPONENTS)[number] | (typeof MOMENT_COMPONENTS)[number];
/** One iteration: components by colour. */
const COMPONENT_COLOR: Record<Component, string> = { fx: "#2f5bd3", fy: "#1d7a45", fz: "#d3662f", mx: "#8a3ffc", my: "#b3261e", mz: "#007d79" };
const COMPONENT_DASH: Record<Component, Dash> = { fx: "solid", fy: "dashdot", fz: "longdash", mx: "solid", my: "solid", mz: "longdash" };

/**
 * The traces of the force (or moment) plot. One iteration: a colour per component, oracle
 * solid, surrogate dashed, a small legend. Several: the colour is the iteration on a sequential
 * scale (one colorbar, no legend entry per iteration, so the plot keeps its size), the
 * component is the line style, the surrogate a thinner dotted line.
 */
export function wrenchTraces(curves: IterationCurves[], components: readonly Component[]): Trace[] {
  const traces: Trace[] = [];
  if (curves.length <= 1) {
    for (const c of curves)
      for (const comp of components) {
        const color = COMPONENT_COLOR[comp];
        traces.push({ x: c.t, y: c.truth[comp], name: `${comp} oracle`, mode: "lines", type: "scatter", line: { color, width: 2 } });
        traces.push({ x: c.t, y: c.predicted[comp], name: `${comp} surrogate`, mode: "lines", type: "scatter", line: { color, width: 1.5, dash: "dash" } });
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

/** A warning when iteration k's OCP solution relies on force outside the surrogate's data (issue 16). */
export function TrustBadge({ point }: { point: MetricPoint | undefined }) {
  if (!point || point.ocp_trusted !== false) return null;
  const reasons = point.trust_reasons?.length ? point.trust_reasons : ["relies on force outside the data"];
  return (
    <span className="badge warn" role="status" data-testid="trust-badge" title={reasons.join("\n")}>
      ⚠ OCP solution not trusted: {reasons.join("; ")}
    </span>
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
}: {
  campaignId: number;
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
  const [draft, setDraft] = useState<string | null>(null);
  const selection = useMemo(() => parseSelection(overlay, available), [overlay, available]);
  const shown = useMemo(() => {
    if (k === null) return [];
    const extra = selection.iterations.filter((x) => x !== k);
    return [...new Set([...extra, k])].sort((a, b) => a - b).slice(-MAX_OVERLAY);
  }, [k, selection.iterations]);
  const overlaid = shown.length > 1;
  const [forceComps, setForceComps] = useState<Component[]>(["fx", "fz"]);
  const [momentComps, setMomentComps] = useState<Component[]>(["my"]);
  const results = useQueries({ queries: shown.map((it) => iterationQuery(campaignId, it)) });
  const loaded = results.map((r) => r.data).filter((d): d is IterationCurves => Boolean(d));
  const loadedKey = loaded.map((c) => c.iteration).join();
  // eslint-disable-next-line react-hooks/exhaustive-deps -- the curves are immutable: the loaded iterations identify them
  const curves = useMemo(() => loaded, [loadedKey]);
  const forceTraces = useMemo(() => wrenchTraces(curves, forceComps), [curves, forceComps]);
  const momentTraces = useMemo(() => wrenchTraces(curves, momentComps), [curves, momentComps]);

  if (available.length === 0) return <Empty title="No iteration has oracle data yet">Forces appear when the first iteration's oracle step is done.</Empty>;
  const error = results.find((r) => r.isError)?.error;
  const choose = (ks: number[]) => {
    setDraft(null);
    setOverlay(formatSelection(ks, available));
  };
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
    <div data-testid="forces-panel" data-iteration={k ?? ""} data-shown={shown.join(",")}>
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
        <TrustBadge point={points.find((p) => p.iteration === k)} />
      </div>
      <form
        className="toolbar"
        onSubmit={(e) => {
          e.preventDefault();
          choose(parseSelection(text, available).iterations);
        }}
      >
        <label htmlFor="overlay-input">Overlay iterations</label>
        <input
          id="overlay-input"
          value={text}
          placeholder="e.g. 1-5, 8, 12-20"
          size={22}
          onChange={(e) => setDraft(e.target.value)}
          onBlur={() => draft !== null && choose(parseSelection(draft, available).iterations)}
          aria-describedby="overlay-hint"
          aria-invalid={selection.errors.length > 0}
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
      {selection.errors.map((m) => (
        <p key={m} className="field-error" role="alert">
          Overlay: {m}
        </p>
      ))}
      {error ? <ErrorBox error={error} /> : null}
      {results.some((r) => r.isPending) && curves.length === 0 ? (
        <Loading label="Loading iteration curves…" />
      ) : (
        <div className="grid2">
          <div>
            <div className="toolbar" role="group" aria-label="Force components">
              {compToggle(forceComps, setForceComps, FORCE_COMPONENTS)}
            </div>
            <Plot testId="force-plot" traces={forceTraces} xTitle="t [s]" yTitle="force [N]" exportName={`forces-k${k}`} height={300} />
          </div>
          <div>
            <div className="toolbar" role="group" aria-label="Moment components">
              {compToggle(momentComps, setMomentComps, MOMENT_COMPONENTS)}
            </div>
            <Plot testId="moment-plot" traces={momentTraces} xTitle="t [s]" yTitle="moment [N m]" exportName={`moments-k${k}`} height={300} />
          </div>
        </div>
      )}
      <p className="hint">
        {overlaid
          ? "Colour: iteration k (dark: early, light: late). Thick line: oracle (truth); thin dotted: surrogate model k's prediction. Components: fx solid, fy dash-dot, fz long dash (moments likewise)."
          : "Solid: oracle (truth). Dashed: prediction of surrogate model k (trained on pool version k−1, the contact model of iteration k's OCP) on the same trajectory, data it has not seen."}{" "}
        Forces and moments act on the head, in the headrest frame.
      </p>
    </div>
  );
}
