/** A tiny inline SVG line (log scale) for table rows: cheap enough for hundreds of rows. */
export function sparklinePath(values: number[], width: number, height: number, log = true): string {
  const ys = values.filter((v) => Number.isFinite(v) && (!log || v > 0)).map((v) => (log ? Math.log10(v) : v));
  if (ys.length === 0) return "";
  const lo = Math.min(...ys);
  const hi = Math.max(...ys);
  const span = hi - lo || 1;
  const dx = ys.length > 1 ? width / (ys.length - 1) : 0;
  return ys
    .map((y, i) => `${i === 0 ? "M" : "L"}${(i * dx).toFixed(1)},${(height - ((y - lo) / span) * height).toFixed(1)}`)
    .join(" ");
}

export function Sparkline({ values, width = 90, height = 22, label }: { values: number[]; width?: number; height?: number; label: string }) {
  const d = sparklinePath(values, width, height);
  if (!d) return <span className="muted">—</span>;
  return (
    <svg width={width} height={height} role="img" aria-label={label} className="sparkline">
      <path d={d} fill="none" stroke="currentColor" strokeWidth={1.5} />
    </svg>
  );
}
