/**
 * Clean tick labels for a log axis: Plotly's automatic log ticks label the minor steps with
 * bare digits ("2", "5", or "9, 8, 7 ..." on short ranges), which reads as clutter. These are
 * explicit ticks at 1-2-5 per decade (1-2-3-5-7 within one decade, decades only beyond four),
 * each labelled with its full value.
 */
const SUPERSCRIPT: Record<string, string> = { "-": "⁻", "0": "⁰", "1": "¹", "2": "²", "3": "³", "4": "⁴", "5": "⁵", "6": "⁶", "7": "⁷", "8": "⁸", "9": "⁹" };

/** 0.02, 0.5, 1, 20, 500, 2000; outside [1e-3, 1e4): 2×10⁻⁵, 10⁶. */
export function logTickLabel(mantissa: number, exponent: number): string {
  const v = Number(`${mantissa}e${exponent}`);
  if (exponent >= -3 && exponent < 4) return String(v);
  const power = `10${String(exponent).replace(/./g, (c) => SUPERSCRIPT[c] ?? c)}`;
  return mantissa === 1 ? power : `${mantissa}×${power}`;
}

export interface LogTicks {
  tickvals: number[];
  ticktext: string[];
}

/** Ticks covering the positive finite values (null without any). */
export function logTicks(values: Iterable<unknown>): LogTicks | null {
  let lo = Infinity;
  let hi = -Infinity;
  for (const v of values) {
    if (typeof v === "number" && Number.isFinite(v) && v > 0) {
      if (v < lo) lo = v;
      if (v > hi) hi = v;
    }
  }
  if (!(lo <= hi)) return null;
  // Plotly pads the autorange a little: tick the decades around the data
  const e0 = Math.floor(Math.log10(lo));
  const e1 = Math.floor(Math.log10(hi));
  const span = Math.log10(hi / lo);
  const mantissas = span <= 1 ? [1, 2, 3, 5, 7] : span <= 4 ? [1, 2, 5] : [1];
  const step = e1 - e0 > 12 ? Math.ceil((e1 - e0) / 12) : 1;
  const tickvals: number[] = [];
  const ticktext: string[] = [];
  for (let e = e0; e <= e1 + 1; e += 1) {
    if (mantissas.length === 1 && (e - e0) % step !== 0) continue;
    for (const m of mantissas) {
      tickvals.push(Number(`${m}e${e}`));
      ticktext.push(logTickLabel(m, e));
    }
  }
  return { tickvals, ticktext };
}

/** The y values of traces (arrays, typed arrays or nested 2-D) for {@link logTicks}. */
export function* traceValues(traces: { y?: unknown }[]): Generator<unknown> {
  for (const t of traces) {
    const y = t.y as ArrayLike<unknown> | undefined;
    if (!y) continue;
    for (let i = 0; i < y.length; i += 1) yield y[i];
  }
}
