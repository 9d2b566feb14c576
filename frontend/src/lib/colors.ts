/**
 * Colour by iteration: a sequential scale (viridis: perceptually uniform, readable in grey and
 * by colour-blind readers) from the first to the last iteration shown, and one colorbar.
 */
const VIRIDIS = ["#440154", "#482878", "#3e4989", "#31688e", "#26828e", "#1f9e89", "#35b779", "#6ece58", "#b5de2b", "#fde725"];

function hex(c: string): [number, number, number] {
  return [1, 3, 5].map((i) => Number.parseInt(c.slice(i, i + 2), 16)) as [number, number, number];
}

/** The colour at t in [0, 1] on the scale (linear between its stops). */
export function sequentialColor(t: number): string {
  const x = Math.min(Math.max(Number.isFinite(t) ? t : 0, 0), 1) * (VIRIDIS.length - 1);
  const i = Math.min(Math.floor(x), VIRIDIS.length - 2);
  const f = x - i;
  const a = hex(VIRIDIS[i]);
  const b = hex(VIRIDIS[i + 1]);
  const rgb = a.map((v, j) => Math.round(v + (b[j] - v) * f));
  return `#${rgb.map((v) => v.toString(16).padStart(2, "0")).join("")}`;
}

/** Colour of iteration k among iterations lo..hi (a single iteration: the middle of the scale). */
export function iterationColor(k: number, lo: number, hi: number): string {
  return sequentialColor(hi > lo ? (k - lo) / (hi - lo) : 0.5);
}

/** The scale in Plotly's form, for a colorbar. */
export const PLOTLY_SCALE: [number, string][] = VIRIDIS.map((c, i) => [i / (VIRIDIS.length - 1), c]);
