/**
 * Choosing iterations by range or list: "1-5, 8, 12-20", plus quick choices (last N, every
 * k-th). Selections are kept in the URL in the same compact form.
 */

export interface Selection {
  /** the chosen iterations that exist, ascending */
  iterations: number[];
  /** one message per part that could not be read, e.g. `"x": not a number or range` */
  errors: string[];
  /** one message per part read otherwise than written, e.g. `5-1: read as 1-5` */
  notes: string[];
}

/**
 * Parse "1-5, 8, 12-20" against the iterations that exist (others are left out, each with the
 * reason: no such iteration, a fork's inherited one, a range without any, text that is no range;
 * a range written high-low is read low-high, and that is said too).
 */
export function parseSelection(text: string, available: readonly number[], inherited: readonly number[] = []): Selection {
  const exists = new Set(available);
  const fromSource = new Set(inherited);
  const chosen = new Set<number>();
  const errors: string[] = [];
  const notes: string[] = [];
  for (const raw of text.split(/[,;\s]+/)) {
    const part = raw.trim();
    if (!part) continue;
    const range = /^(\d+)\s*(?:-|–|\.\.)\s*(\d+)$/.exec(part);
    if (range) {
      let [a, b] = [Number(range[1]), Number(range[2])];
      if (a > b) {
        [a, b] = [b, a];
        notes.push(`${part}: read as ${a}-${b} (a range runs from low to high)`);
      }
      const inRange = available.filter((k) => k >= a && k <= b);
      for (const k of inRange) chosen.add(k);
      if (!inRange.length) errors.push(inherited.some((k) => k >= a && k <= b) ? `${part}: inherited from the source campaign (its curves are on the source's page)` : `${part}: no iteration with oracle data in this range`);
      continue;
    }
    if (/^\d+$/.test(part)) {
      const k = Number(part);
      if (exists.has(k)) chosen.add(k);
      else if (fromSource.has(k)) errors.push(`${k}: inherited from the source campaign (its curves are on the source's page)`);
      else errors.push(`${k}: no such iteration with oracle data`);
      continue;
    }
    errors.push(`"${part}": not an iteration number or range (e.g. 1-5, 8, 12-20)`);
  }
  return { iterations: [...chosen].sort((x, y) => x - y), errors, notes };
}

/** The compact form of a set of iterations: consecutive runs of `available` become ranges. */
export function formatSelection(iterations: readonly number[], available: readonly number[] = iterations): string {
  const chosen = new Set(iterations);
  const sorted = [...available].sort((a, b) => a - b);
  const parts: string[] = [];
  let i = 0;
  while (i < sorted.length) {
    if (!chosen.has(sorted[i])) {
      i++;
      continue;
    }
    let j = i;
    while (j + 1 < sorted.length && chosen.has(sorted[j + 1])) j++;
    parts.push(j - i >= 2 ? `${sorted[i]}-${sorted[j]}` : j === i ? `${sorted[i]}` : `${sorted[i]}, ${sorted[j]}`);
    i = j + 1;
  }
  // iterations not among `available` (not loaded yet) are kept as given
  for (const k of iterations) if (!sorted.includes(k)) parts.push(String(k));
  return parts.join(", ");
}

export function lastN(available: readonly number[], n: number): number[] {
  return available.slice(Math.max(available.length - n, 0));
}

/** Every k-th iteration of those available, always including the latest. */
export function everyKth(available: readonly number[], k: number): number[] {
  if (!available.length || k < 1) return [];
  const last = available[available.length - 1];
  const out = available.filter((it) => (last - it) % k === 0);
  return out;
}
