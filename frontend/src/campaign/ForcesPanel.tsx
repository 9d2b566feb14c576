import { useMemo, useState } from "react";
import { useQueries } from "@tanstack/react-query";
import { Plot, type Trace } from "../components/Plot";
import { iterationQuery, type IterationCurves } from "../api/hooks";
import { ErrorBox, Empty, Loading } from "../components/States";
import type { MetricPoint } from "../lib/metrics";

const FORCE_COMPONENTS = ["fx", "fy", "fz"] as const;
const MOMENT_COMPONENTS = ["mx", "my", "mz"] as const;
type Component = (typeof FORCE_COMPONENTS)[number] | (typeof MOMENT_COMPONENTS)[number];
const PALETTE = ["#2f5bd3", "#d3662f", "#1d7a45", "#8a3ffc", "#b3261e", "#007d79", "#a86500", "#6b7385"];

export function wrenchTraces(curves: IterationCurves[], components: readonly Component[]): Trace[] {
  const traces: Trace[] = [];
  curves.forEach((c, i) => {
    components.forEach((comp, j) => {
      const color = PALETTE[(i * components.length + j) % PALETTE.length];
      const label = curves.length > 1 ? `k=${c.iteration} ${comp}` : comp;
      const truth = c.truth?.[comp];
      const pred = c.predicted?.[comp];
      if (truth) traces.push({ x: c.force_t, y: truth, name: `${label} oracle`, mode: "lines", type: "scatter", line: { color, width: 2 } });
      if (pred) traces.push({ x: c.force_t, y: pred, name: `${label} surrogate`, mode: "lines", type: "scatter", line: { color, width: 1.5, dash: "dash" } });
    });
  });
  return traces;
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
  overlay: number[];
  setOverlay: (ks: number[]) => void;
}) {
  // iterations with oracle data (failed ones have no curves)
  const available = points.filter((p) => p.iteration > 0 && p.force_rmse !== null).map((p) => p.iteration);
  const k = iteration ?? available[available.length - 1] ?? null;
  const shown = useMemo(() => (k === null ? [] : [k, ...overlay.filter((x) => x !== k)]), [k, overlay]);
  const [forceComps, setForceComps] = useState<Component[]>(["fx", "fz"]);
  const [momentComps, setMomentComps] = useState<Component[]>(["my"]);
  const results = useQueries({ queries: shown.map((it) => iterationQuery(campaignId, it)) });
  const curves = results.map((r) => r.data).filter((d): d is IterationCurves => Boolean(d));
  const forceTraces = useMemo(() => wrenchTraces(curves, forceComps), [curves.map((c) => c.iteration).join(), forceComps]);
  const momentTraces = useMemo(() => wrenchTraces(curves, momentComps), [curves.map((c) => c.iteration).join(), momentComps]);

  if (available.length === 0) return <Empty title="No iteration has oracle data yet">Forces appear when the first iteration's oracle step is done.</Empty>;
  const error = results.find((r) => r.isError)?.error;

  const compToggle = (list: Component[], set: (v: Component[]) => void, all: readonly Component[]) =>
    all.map((c) => (
      <label key={c} className="field-inline">
        <input type="checkbox" checked={list.includes(c)} onChange={() => set(list.includes(c) ? list.filter((x) => x !== c) : [...list, c])} /> {c}
      </label>
    ));

  return (
    <div data-testid="forces-panel">
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
      </div>
      <div className="toolbar">
        <span>Overlay:</span>
        <div className="checks" role="group" aria-label="Overlay iterations">
          {available.slice(-40).map((it) => (
            <label key={it} className="field-inline">
              <input type="checkbox" checked={overlay.includes(it)} disabled={it === k} onChange={() => setOverlay(overlay.includes(it) ? overlay.filter((x) => x !== it) : [...overlay, it].slice(-6))} />
              {it}
            </label>
          ))}
        </div>
        {overlay.length > 0 && (
          <button type="button" className="link" onClick={() => setOverlay([])}>
            clear
          </button>
        )}
      </div>
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
      <p className="hint">Solid: oracle (truth). Dashed: prediction of surrogate model k (trained on pool version k−1, the contact model of iteration k's OCP) on the same trajectory, data it has not seen. Forces and moments act on the head, in the headrest frame.</p>
    </div>
  );
}
