/**
 * The one wrapper around plotly.js. Every chart in the UI goes through it, so layout
 * defaults, PNG export (Plotly's modebar camera button) and the data attributes that tests
 * read (trace and point counts) live here.
 */
import { useEffect, useRef } from "react";
import { logTicks, traceValues } from "../lib/logTicks";
import type { Config, Data, Layout, PlotlyHTMLElement, PlotMouseEvent, ScatterData, Shape } from "plotly.js-dist-min";

export type Trace = Partial<ScatterData> & { x?: unknown[]; y?: unknown[] };

export interface PlotProps {
  traces: Trace[];
  title?: string;
  xTitle?: string;
  yTitle?: string;
  logY?: boolean;
  height?: number;
  shapes?: Partial<Shape>[];
  /** file name (without extension) for the PNG export */
  exportName?: string;
  testId?: string;
  onPointClick?: (x: number, curveNumber: number) => void;
  extraLayout?: Partial<Layout>;
  /** extra data-* attributes for tests (e.g. {iterations: "1,2,3"} -> data-iterations) */
  data?: Record<string, string>;
  /** a vertical cursor line at this x (a playback's time); moved without redrawing the traces */
  cursorX?: number | null;
}

/** The vertical cursor line at x (in data x, over the whole plot height). */
export function cursorShape(x: number): Partial<Shape> {
  return { type: "line", xref: "x", yref: "paper", x0: x, x1: x, y0: 0, y1: 1, line: { color: "#b3261e", width: 1.5 }, layer: "above" } as Partial<Shape>;
}

function withCursor(shapes: Partial<Shape>[] | undefined, x: number | null | undefined): Partial<Shape>[] | undefined {
  return x === null || x === undefined || !Number.isFinite(x) ? shapes : [...(shapes ?? []), cursorShape(x)];
}

/**
 * Plotly's configuration for every chart: PNG export stays (camera button), and nothing links
 * to or sends data to another host. plotly.js 4 shows a "send chart to cloud" button by default
 * (showSendToCloud, plotlyServerURL = cloud.plotly.com); both are switched off and the button is
 * removed. (showLink, linkText and showEditInChartStudio of older versions no longer exist.)
 */
export const PLOT_CONFIG: Partial<Config> = {
  responsive: true,
  displaylogo: false,
  showSendToCloud: false,
  plotlyServerURL: "",
  modeBarButtonsToRemove: ["sendChartToCloud"],
};

type PlotlyModule = typeof import("plotly.js-dist-min").default;
let plotlyModule: Promise<PlotlyModule> | null = null;

/**
 * plotly.js is large: load it once, in its own chunk, in parallel with the page's data.
 * The partial bundle `plotly.js-basic-dist-min` (scatter, bar, pie: about 1.2 MB instead of
 * 4.6 MB) has everything the charts use: log axes, layout shapes (phase shading), the modebar
 * with PNG export. The types come from the full bundle (same API; dev dependency only).
 */
export function loadPlotly(): Promise<PlotlyModule> {
  plotlyModule ??= import("plotly.js-basic-dist-min").then((m) => {
    performance.mark("alcove:plotly-loaded");
    return m.default;
  });
  return plotlyModule;
}

/** Explicit 1-2-5 ticks with whole-value labels on a log axis (see lib/logTicks). */
function logAxisTicks(traces: Trace[]): Partial<Layout["yaxis"]> {
  const ticks = logTicks(traceValues(traces));
  return ticks ? { tickmode: "array", tickvals: ticks.tickvals, ticktext: ticks.ticktext } : {};
}

export function pointCount(traces: Trace[]): number {
  return traces.reduce((n, t) => n + (t.x?.length ?? t.y?.length ?? 0), 0);
}

export function Plot({
  traces,
  title,
  xTitle,
  yTitle,
  logY = false,
  height = 320,
  shapes,
  exportName = "alcove-plot",
  testId,
  onPointClick,
  extraLayout,
  data,
  cursorX,
}: PlotProps) {
  const ref = useRef<HTMLDivElement>(null);
  const clickRef = useRef(onPointClick);
  const cursorRef = useRef(cursorX);
  const shapesRef = useRef(shapes);
  useEffect(() => {
    clickRef.current = onPointClick;
    cursorRef.current = cursorX;
    shapesRef.current = shapes;
  });

  useEffect(() => {
    const el = ref.current;
    if (!el) return;
    const layout: Partial<Layout> = {
      // the title is a heading above the plot (not Plotly's): a legend of several rows above the plot area never runs into it
      height,
      margin: { l: 64, r: 16, t: 32, b: 44 },
      xaxis: { title: { text: xTitle ?? "" }, zeroline: false },
      yaxis: { title: { text: yTitle ?? "" }, type: logY ? "log" : "linear", exponentformat: "power", ...(logY ? logAxisTicks(traces) : {}) },
      legend: { orientation: "h", x: 0, y: 1.02, xanchor: "left", yanchor: "bottom" },
      shapes: withCursor(shapes, cursorRef.current),
      paper_bgcolor: "rgba(0,0,0,0)",
      plot_bgcolor: "#fff",
      font: { family: "system-ui, sans-serif", size: 12 },
      uirevision: "keep",
      ...extraLayout,
    };
    const config: Partial<Config> = { ...PLOT_CONFIG, toImageButtonOptions: { format: "png", filename: exportName, scale: 2 } };
    let cancelled = false;
    const started = performance.now();
    performance.mark(`alcove:plot-effect:${testId ?? "plot"}`);
    void loadPlotly()
      .then((Plotly) => (cancelled ? undefined : Plotly.react(el, traces as Data[], layout, config)))
      .then(() => {
      if (cancelled) return;
      el.dataset.rendered = "true";
      el.dataset.renderMs = (performance.now() - started).toFixed(0);
      performance.mark(`alcove:plot-rendered:${testId ?? "plot"}`);
      const plotEl = el as unknown as PlotlyHTMLElement;
      if (typeof plotEl.removeAllListeners === "function") plotEl.removeAllListeners("plotly_click");
      if (typeof plotEl.on === "function")
        plotEl.on("plotly_click", (ev: PlotMouseEvent) => {
          const p = ev.points?.[0];
          if (p && clickRef.current) clickRef.current(Number(p.x), p.curveNumber);
        });
    });
    return () => {
      cancelled = true;
    };
  }, [traces, title, xTitle, yTitle, logY, height, shapes, exportName, extraLayout, testId]);

  // the cursor alone: a relayout of the shapes once the plot is drawn (the traces stay)
  useEffect(() => {
    const el = ref.current;
    if (!el || el.dataset.rendered !== "true") return;
    void loadPlotly().then((Plotly) => Plotly.relayout(el, { shapes: withCursor(shapesRef.current, cursorX) ?? [] }));
  }, [cursorX]);

  useEffect(() => {
    const el = ref.current;
    return () => {
      if (el) void loadPlotly().then((Plotly) => Plotly.purge(el));
    };
  }, []);

  const plot = (
    <div
      ref={ref}
      className="plot"
      data-testid={testId}
      data-traces={traces.length}
      data-points={pointCount(traces)}
      data-shapes={shapes?.length ?? 0}
      data-cursor={cursorX === null || cursorX === undefined ? "" : String(cursorX)}
      data-log-y={logY ? "true" : "false"}
      {...Object.fromEntries(Object.entries(data ?? {}).map(([k, v]) => [`data-${k}`, v]))}
      // a group, not an image: the plot holds Plotly's toolbar buttons, and an image may not contain controls
      role="group"
      aria-label={title ?? yTitle ?? "plot"}
    />
  );
  if (!title) return plot;
  return (
    <div className="plot-with-title">
      <p className="plot-title">{title}</p>
      {plot}
    </div>
  );
}
