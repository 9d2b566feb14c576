import { useMemo } from "react";
import type { Layout } from "plotly.js-dist-min";
import { Plot, type Trace } from "../components/Plot";
import { componentUnit, isMarked, isRmseQuantity, RMSE_QUANTITIES, type BestPossible, type MetricPoint, type RmseQuantity, type SuiteReference } from "../lib/metrics";
import { useStringParam } from "../lib/urlState";
import { iterationAt, xOf, xTitle, type XAxis } from "../lib/xaxis";

const INHERITED = "#a3a9b6";

/**
 * Force and moment RMSE per iteration (of the error vector, docs/concepts.md), and the same over
 * the samples in contact (dotted, where given); failed and quarantined iterations as red x. A
 * fork's inherited iterations (its source's, up to the fork point) are drawn grey, its own in colour.
 * Beside them, dashed: model k's generalisation error on the held-out validation suite.
 */
const REFERENCE = "#6b7385";

/**
 * A horizontal line at ``value`` across the x range of ``points`` (a reference's error on the suite).
 */
function referenceLine(points: MetricPoint[], axis: XAxis, value: number | null | undefined, name: string): Trace[] {
  const xs = points.map((p) => xOf(p, axis)).filter((x): x is number => x != null);
  if (value == null || !xs.length) return [];
  const x0 = Math.min(...xs);
  const x1 = Math.max(...xs);
  return [{ x: [x0, x1 > x0 ? x1 : x0 + 1], y: [value, value], name, mode: "lines", type: "scatter", line: { color: REFERENCE, dash: "longdash", width: 1.5 }, hoverinfo: "name+y" }];
}

/**
 * The auxiliary law's error on the suite as reference lines: the force and moment vectors, or one
 * quantity (``force``, ``moment`` or a component, fx .. mz). ``suite`` names the suite where several
 * are drawn (the compare page: one line per distinct suite).
 */
export function auxLawTraces(points: MetricPoint[], auxLaw: SuiteReference | null | undefined, axis: XAxis = "iteration", component?: string, suite = ""): Trace[] {
  if (!auxLaw) return [];
  const own = points.filter((p) => !isMarked(p) && !p.inherited);
  const line = (c: string) =>
    referenceLine(own, axis, c === "force" ? auxLaw.force_rmse : c === "moment" ? auxLaw.moment_rmse : auxLaw.components[c], `auxiliary law, held-out suite${suite ? ` of ${suite}` : ""}: ${c} [${componentUnit(c)}]`);
  return component ? line(component) : [...line("force"), ...line("moment")];
}

/**
 * Where budget ``budget`` (oracle calls) sits on ``axis``: at that many calls; on the iteration
 * axis at the model trained on them (the iteration after the first one whose cumulative calls
 * reach it; not drawn before the campaign got there); not on the wall-time axis.
 */
export function budgetX(points: MetricPoint[], axis: XAxis, budget: number): number | null {
  if (axis === "oracle") return budget;
  if (axis !== "iteration") return null;
  const reached = points.find((p) => !p.inherited && (p.cumulative_oracle_calls ?? -1) >= budget);
  return reached ? reached.iteration + 1 : null;
}

/**
 * The suite's best-possible line (dash-dot grey, with markers): at each oracle budget, the error
 * of a model trained from scratch on that many replays of motions spread over the suite's range.
 * The force and moment vectors, or one quantity (as :func:`auxLawTraces`).
 */
export function bestPossibleTraces(points: MetricPoint[], line: BestPossible | null | undefined, axis: XAxis = "iteration", component?: string): Trace[] {
  if (!line || !line.points.length) return [];
  const one = (c: string): Trace[] => {
    const xs: number[] = [];
    const ys: number[] = [];
    for (const p of line.points) {
      const x = budgetX(points, axis, p.budget);
      const y = c === "force" ? p.force_rmse : c === "moment" ? p.moment_rmse : p.components[c];
      if (x == null || y == null) continue;
      xs.push(x);
      ys.push(y);
    }
    if (!xs.length) return [];
    return [{ x: xs, y: ys, name: `best possible at that many oracle calls, held-out suite: ${c} [${componentUnit(c)}]`, mode: "lines+markers", type: "scatter", line: { color: REFERENCE, dash: "dashdot", width: 1.5 }, marker: { symbol: "diamond-open", size: 7, color: REFERENCE }, hoverinfo: "name+x+y" }];
  };
  return component ? one(component) : [...one("force"), ...one("moment")];
}

export function rmseTraces(points: MetricPoint[], name = "", axis: XAxis = "iteration"): Trace[] {
  const X = (p: MetricPoint) => xOf(p, axis);
  const own = points.filter((p) => !isMarked(p) && !p.inherited);
  const inherited = points.filter((p) => !isMarked(p) && p.inherited);
  const marked = points.filter(isMarked);
  const prefix = name ? `${name}: ` : "";
  const traces: Trace[] = [];
  if (inherited.length) {
    // joined to the first own iteration, so the line continues across the fork point
    const bridge = own.length ? [...inherited, own[0]] : inherited;
    traces.push(
      { x: bridge.map(X), y: bridge.map((p) => p.force_rmse), name: `${prefix}force RMSE [N], inherited`, mode: "lines+markers", type: "scatter", line: { color: INHERITED }, marker: { color: INHERITED, symbol: "circle-open" } },
      { x: bridge.map(X), y: bridge.map((p) => p.moment_rmse), name: `${prefix}moment RMSE [N m], inherited`, mode: "lines+markers", type: "scatter", line: { color: INHERITED, dash: "dot" }, marker: { color: INHERITED, symbol: "square-open" } },
    );
  }
  traces.push(
    { x: own.map(X), y: own.map((p) => p.force_rmse), name: `${prefix}force RMSE [N]`, mode: "lines+markers", type: "scatter", line: { color: "#2f5bd3" } },
    { x: own.map(X), y: own.map((p) => p.moment_rmse), name: `${prefix}moment RMSE [N m]`, mode: "lines+markers", type: "scatter", line: { color: "#d3662f" } },
  );
  const validated = own.filter((p) => p.validation_force_rmse != null);
  if (validated.length)
    traces.push(
      { x: validated.map(X), y: validated.map((p) => p.validation_force_rmse ?? null), name: `${prefix}force RMSE, held-out suite [N]`, mode: "lines+markers", type: "scatter", line: { color: "#2f5bd3", dash: "dash" }, marker: { color: "#2f5bd3", symbol: "diamond-open" } },
      { x: validated.map(X), y: validated.map((p) => p.validation_moment_rmse ?? null), name: `${prefix}moment RMSE, held-out suite [N m]`, mode: "lines+markers", type: "scatter", line: { color: "#d3662f", dash: "dash" }, marker: { color: "#d3662f", symbol: "diamond-open" } },
    );
  if (own.some((p) => p.force_rmse_contact != null))
    traces.push(
      { x: own.map(X), y: own.map((p) => p.force_rmse_contact ?? null), name: `${prefix}force RMSE in contact [N]`, mode: "lines", type: "scatter", line: { color: "#2f5bd3", dash: "dot" } },
      { x: own.map(X), y: own.map((p) => p.moment_rmse_contact ?? null), name: `${prefix}moment RMSE in contact [N m]`, mode: "lines", type: "scatter", line: { color: "#d3662f", dash: "dot" } },
    );
  const picks = own.flatMap((p) => (p.picks ?? []).map((pk) => ({ x: X(p), k: p.iteration, ...pk })));
  if (picks.length)
    traces.push({
      x: picks.map((p) => p.x),
      y: picks.map((p) => p.force_rmse ?? null),
      text: picks.map((p) => `k = ${p.k}, pick ${p.pick + 1} (slot ${p.slot})`),
      name: `${prefix}force RMSE per pick [N]`,
      mode: "markers",
      type: "scatter",
      marker: { color: "#2f5bd3", size: 5, opacity: 0.5 },
    });
  if (marked.length)
    traces.push({
      x: marked.map(X),
      y: marked.map((p) => p.force_rmse ?? p.moment_rmse ?? null),
      text: marked.map((p) => (p.quarantined ? "quarantined" : p.status)),
      name: "failed / quarantined",
      mode: "markers",
      type: "scatter",
      marker: { symbol: "x", size: 11, color: "#b3261e" },
    });
  return traces;
}

/** The colour of a component's curves on the campaign page. */
function componentColor(c: string): string {
  return c === "fx" ? "#2f5bd3" : c === "fz" ? "#7a3fb8" : c === "my" ? "#d3662f" : "#1d7a45";
}

/**
 * One wrench component's RMSE per iteration (``c`` in fx .. mz): over the new oracle data (solid), over
 * its samples in contact (dotted) and on the held-out suite (dashed; dash-dot in contact). The
 * normal force fx is learnable from any pool; fz (friction) depends on the motion's history, so
 * the split shows which part of the force error a campaign can still lower. An iteration stored
 * before the components were recorded is a gap in the line (null), not a zero.
 * ``name`` prefixes the legend entries and ``color`` replaces the component's colour (the compare
 * page: one colour a campaign); ``contact: false`` leaves the in-contact curves out.
 */
export function componentTraces(points: MetricPoint[], c: string, axis: XAxis = "iteration", { name = "", color = componentColor(c), contact = true }: { name?: string; color?: string; contact?: boolean } = {}): Trace[] {
  const X = (p: MetricPoint) => xOf(p, axis);
  const own = points.filter((p) => !isMarked(p) && !p.inherited);
  const inherited = points.filter((p) => !isMarked(p) && p.inherited && p.components != null);
  const unit = componentUnit(c);
  const prefix = name ? `${name}: ` : "";
  const value = (v: Record<string, number | null> | null | undefined, key: string) => v?.[key] ?? null;
  const traces: Trace[] = [];
  if (inherited.length)
    traces.push({ x: inherited.map(X), y: inherited.map((p) => value(p.components, c)), name: `${prefix}${c} RMSE [${unit}], inherited`, mode: "lines+markers", type: "scatter", line: { color: INHERITED }, marker: { color: INHERITED, symbol: "circle-open" } });
  traces.push({ x: own.map(X), y: own.map((p) => value(p.components, c)), name: `${prefix}${c} RMSE [${unit}]`, mode: "lines+markers", type: "scatter", line: { color } });
  if (contact) traces.push({ x: own.map(X), y: own.map((p) => value(p.components, `${c}_contact`)), name: `${prefix}${c} RMSE in contact [${unit}]`, mode: "lines", type: "scatter", line: { color, dash: "dot" } });
  // the iterations evaluated on the suite; one evaluated before its components were recorded is a gap
  const validated = own.filter((p) => p.validation_components != null || p.validation_force_rmse != null);
  if (validated.length) {
    traces.push({ x: validated.map(X), y: validated.map((p) => value(p.validation_components, c)), name: `${prefix}${c} RMSE, held-out suite [${unit}]`, mode: "lines+markers", type: "scatter", line: { color, dash: "dash" }, marker: { color, symbol: "diamond-open" } });
    if (contact)
      traces.push({ x: validated.map(X), y: validated.map((p) => value(p.validation_components, `${c}_contact`)), name: `${prefix}${c} RMSE in contact, held-out suite [${unit}]`, mode: "lines", type: "scatter", line: { color, dash: "dashdot" } });
  }
  return traces;
}

/** What the RMSE plots show, in the URL (``rmse=``; the force and moment vectors when absent or unknown). */
export function useRmseQuantity(): [RmseQuantity, (v: string) => void] {
  const [raw, set] = useStringParam("rmse", "vector");
  return [isRmseQuantity(raw) ? raw : "vector", set];
}

/** The "RMSE of" select: the force and moment vectors or one wrench component. */
export function RmseQuantitySelect({ value, onChange }: { value: RmseQuantity; onChange: (v: string) => void }) {
  return (
    <label className="field-inline">
      RMSE of{" "}
      <select data-testid="rmse-quantity" value={value} onChange={(e) => onChange(e.target.value)}>
        {RMSE_QUANTITIES.map(([key, label]) => (
          <option key={key} value={key}>
            {label}
          </option>
        ))}
      </select>
    </label>
  );
}

export function RmsePlot({ points, logY, onSelect, xAxis = "iteration", quantity = "vector", auxLaw = null, bestPossible = null }: { points: MetricPoint[]; logY: boolean; onSelect?: (k: number) => void; xAxis?: XAxis; quantity?: RmseQuantity; auxLaw?: SuiteReference | null; bestPossible?: BestPossible | null }) {
  const traces = useMemo(
    () => [
      ...(quantity === "vector" ? rmseTraces(points, "", xAxis) : componentTraces(points, quantity, xAxis)),
      ...auxLawTraces(points, auxLaw, xAxis, quantity === "vector" ? undefined : quantity),
      ...bestPossibleTraces(points, bestPossible, xAxis, quantity === "vector" ? undefined : quantity),
    ],
    [points, xAxis, quantity, auxLaw, bestPossible],
  );
  const few = xAxis === "iteration" && points.length > 0 && points[points.length - 1].iteration <= 12;
  const xLayout = useMemo(() => ({ xaxis: { title: { text: xTitle(xAxis) }, dtick: few ? 1 : undefined, zeroline: false } }), [few, xAxis]);
  const own = points.filter((p) => !p.inherited);
  return (
    <Plot
      testId="rmse-plot"
      traces={traces}
      xTitle={xTitle(xAxis)}
      yTitle="RMSE"
      logY={logY}
      exportName="rmse"
      onPointClick={(x) => {
        const k = iterationAt(points, xAxis, x);
        if (k !== null) onSelect?.(k);
      }}
      height={300}
      extraLayout={xLayout}
      data={{ xaxis: xAxis, quantity, "aux-law": auxLaw ? "true" : "false", "best-possible": bestPossible?.points.map((p) => p.budget).join(",") ?? "", iterations: own.filter((p) => p.force_rmse !== null).map((p) => p.iteration).join(","), inherited: points.filter((p) => p.inherited).map((p) => p.iteration).join(","), validation: own.filter((p) => p.validation_force_rmse != null).map((p) => p.iteration).join(",") }}
    />
  );
}

/** For normally distributed errors, the share inside mean +- 2 std (the calibration's nominal value). */
export const NOMINAL_COVERAGE = 0.9545;

/**
 * The ensemble's calibration per iteration: the fraction of iteration k's oracle values that
 * lie inside model k's mean +- 2 std (docs/concepts.md). Near the nominal 95 %: the band is
 * honest; far below: the ensemble is over-confident. Null (K = 1) iterations are left out.
 * Beside it, dashed: model k's calibration on the held-out validation suite (where evaluated).
 */
export function calibrationTraces(points: MetricPoint[], axis: XAxis = "iteration"): Trace[] {
  const X = (p: MetricPoint) => xOf(p, axis);
  const own = points.filter((p) => !isMarked(p) && !p.inherited && p.calibration != null);
  const inherited = points.filter((p) => !isMarked(p) && p.inherited && p.calibration != null);
  const traces: Trace[] = [];
  if (inherited.length)
    traces.push({ x: inherited.map(X), y: inherited.map((p) => 100 * (p.calibration ?? 0)), name: "inherited", mode: "lines+markers", type: "scatter", line: { color: INHERITED }, marker: { color: INHERITED, symbol: "circle-open" } });
  traces.push({ x: own.map(X), y: own.map((p) => 100 * (p.calibration ?? 0)), name: "inside mean ± 2σ [%]", mode: "lines+markers", type: "scatter", line: { color: "#1d7a45" } });
  const validated = points.filter((p) => !isMarked(p) && !p.inherited && p.validation_calibration != null);
  if (validated.length)
    traces.push({ x: validated.map(X), y: validated.map((p) => 100 * (p.validation_calibration ?? 0)), name: "inside mean ± 2σ, held-out suite [%]", mode: "lines+markers", type: "scatter", line: { color: "#1d7a45", dash: "dash" }, marker: { color: "#1d7a45", symbol: "diamond-open" } });
  return traces;
}

export function hasCalibration(points: MetricPoint[]): boolean {
  return points.some((p) => p.calibration != null || p.validation_calibration != null);
}

export function CalibrationPlot({ points, xAxis = "iteration" }: { points: MetricPoint[]; xAxis?: XAxis }) {
  const traces = useMemo(() => calibrationTraces(points, xAxis), [points, xAxis]);
  const layout = useMemo<Partial<Layout>>(
    () => ({
      yaxis: { title: { text: "oracle values inside mean ± 2σ [%]" }, range: [0, 102] as [number, number], zeroline: false },
      xaxis: { title: { text: xTitle(xAxis) }, zeroline: false },
      showlegend: false,
      annotations: [{ xref: "paper" as const, x: 1, xanchor: "right" as const, y: 100 * NOMINAL_COVERAGE, yanchor: "bottom" as const, text: "nominal 95.4 %", showarrow: false, font: { size: 11, color: "#6b7385" } }],
    }),
    [xAxis],
  );
  const shapes = useMemo(() => [{ type: "line" as const, xref: "paper" as const, x0: 0, x1: 1, y0: 100 * NOMINAL_COVERAGE, y1: 100 * NOMINAL_COVERAGE, line: { color: "#6b7385", dash: "dot" as const, width: 1 } }], []);
  const own = points.filter((p) => !p.inherited && p.calibration != null);
  return (
    <Plot
      testId="calibration-plot"
      traces={traces}
      shapes={shapes}
      xTitle={xTitle(xAxis)}
      yTitle="oracle values inside mean ± 2σ [%]"
      exportName="calibration"
      height={300}
      extraLayout={layout}
      data={{ xaxis: xAxis, iterations: own.map((p) => p.iteration).join(","), validation: points.filter((p) => !p.inherited && p.validation_calibration != null).map((p) => p.iteration).join(",") }}
    />
  );
}
