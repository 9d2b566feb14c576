/**
 * A picture of the model (SVG, world x forward to the right, z up): the links and joints of the
 * chain, the head with its elliptic occipital profile, the headrest's cushion and, when given,
 * the contact force on the head as an arrow at the profile point nearest the headrest. The view
 * is fixed over `frames` (all poses of a trajectory), so playback does not jump.
 */
import { useMemo } from "react";
import { bounds, contactPoint, headInHeadrest, headrestToWorld, pose, profileOutline, rotate, signedGap, type Chain, type Vec2 } from "../lib/kinematics";

/** Cushion drawn behind the headrest surface: half its height along the surface and its depth [m]. */
const CUSHION_HALF = 0.14;
const CUSHION_DEPTH = 0.06;
/** Length of the arrow of the largest force shown [m in the picture]. */
const ARROW_MAX = 0.12;

export interface ChainDrawingProps {
  chain: Chain;
  q: readonly number[];
  /** every pose the view must hold (playback); default: q alone */
  frames?: readonly (readonly number[])[];
  /** the contact force on the head in the headrest frame H [N] (fx along the normal, fz along the surface) */
  force?: { fx: number; fz: number } | null;
  /** the force drawn ARROW_MAX long (the largest of the trajectory) [N] */
  forceScale?: number;
  height?: number;
  testId?: string;
  label?: string;
}

function cushion(chain: Chain, zc: number): Vec2[] {
  const o = chain.headrest.origin;
  return (
    [
      [0, zc - CUSHION_HALF],
      [0, zc + CUSHION_HALF],
      [-CUSHION_DEPTH, zc + CUSHION_HALF],
      [-CUSHION_DEPTH, zc - CUSHION_HALF],
    ] as Vec2[]
  ).map((p) => {
    const w = rotate(chain.headrest.tilt, p);
    return [o[0] + w[0], o[1] + w[1]] as Vec2;
  });
}

/** The largest coordinate drawn [m]: a body and its headrest lie within metres of the base. */
const MAX_DRAWN_M = 1e4;
const inDrawing = (v: number) => Number.isFinite(v) && Math.abs(v) <= MAX_DRAWN_M;

const pts = (ps: Vec2[]) => ps.map(([x, z]) => `${x.toFixed(5)},${(-z).toFixed(5)}`).join(" ");

export function ChainDrawing({ chain, q, frames, force, forceScale, height = 320, testId = "chain-drawing", label = "The model at this pose" }: ChainDrawingProps) {
  // the view: every joint and head outline of the frames (a sample of them), and the cushion
  const view = useMemo(() => {
    const all = frames?.length ? frames : [q];
    const step = Math.max(1, Math.floor(all.length / 40));
    const sample = all.filter((_, i) => i % step === 0 || i === all.length - 1);
    const first = all[0];
    // the cushion is centred where the head meets it
    const c = contactPoint(chain, first);
    const zc = rotate(-chain.headrest.tilt, [c[0] - chain.headrest.origin[0], c[1] - chain.headrest.origin[1]])[1];
    const points: Vec2[] = [...cushion(chain, zc)];
    for (const s of sample) points.push(...pose(chain, s).joints, ...profileOutline(chain, s, 24));
    const [x0, z0, x1, z1] = bounds(points);
    const pad = 0.08 * Math.max(x1 - x0, z1 - z0, 0.1);
    return { zc, box: [x0 - pad, z0 - pad, x1 + pad, z1 + pad] as const };
  }, [chain, frames, q]);

  const p = pose(chain, q);
  const outline = profileOutline(chain, q);
  const gap = signedGap(chain, q);
  const h = headInHeadrest(chain, q);
  const [x0, z0, x1, z1] = view.box;
  const span = Math.max(x1 - x0, z1 - z0);
  const r = span * 0.012;
  const f = force && Number.isFinite(force.fx) && Number.isFinite(force.fz) ? force : null;
  const magnitude = f ? Math.hypot(f.fx, f.fz) : 0;
  let arrow: { from: Vec2; to: Vec2 } | null = null;
  if (f && magnitude > 0 && forceScale && forceScale > 0) {
    const from = contactPoint(chain, q);
    const d = headrestToWorld(chain, [f.fx, f.fz]);
    const k = (ARROW_MAX * Math.max(magnitude / forceScale, 0.08)) / magnitude;
    arrow = { from, to: [from[0] + k * d[0], from[1] + k * d[1]] };
  }
  const markerId = `${testId}-arrowhead`;
  // an SVG holds single-precision numbers: a model whose points are not finite or lie far beyond any body (a 1e308 m link) is described, not drawn
  const drawable = [[x0, z0], [x1, z1], ...p.joints, ...p.coms, ...outline, p.head.origin].every(([x, z]) => inDrawing(x) && inDrawing(z)) && inDrawing(gap);
  if (!drawable)
    return (
      <figure className="chain-drawing" style={{ margin: 0 }}>
        <p className="muted" data-testid={testId} data-drawable="false" data-links={chain.links.length} role="img" aria-label={`${label}: not drawn`}>
          The model cannot be drawn with these values: its points lie beyond {MAX_DRAWN_M} m (or are not numbers). Check the lengths, positions and offsets.
        </p>
      </figure>
    );
  return (
    <figure className="chain-drawing" style={{ margin: 0 }}>
      <svg
        data-testid={testId}
        data-gap-mm={(gap * 1000).toFixed(2)}
        data-head={`${h.x.toFixed(5)},${h.z.toFixed(5)},${h.angle.toFixed(5)}`}
        data-q={q.map((v) => v.toFixed(4)).join(",")}
        data-force={f ? magnitude.toFixed(2) : ""}
        data-links={chain.links.length}
        role="img"
        aria-label={`${label}: ${chain.links.length} link(s), gap ${(gap * 1000).toFixed(1)} mm${f ? `, contact force ${magnitude.toFixed(1)} N` : ""}`}
        viewBox={`${x0} ${-z1} ${x1 - x0} ${z1 - z0}`}
        preserveAspectRatio="xMidYMid meet"
        width="100%"
        height={height}
        style={{ background: "#fbfcfe", border: "1px solid var(--line)", borderRadius: 6 }}
      >
        <defs>
          <marker id={markerId} viewBox="0 0 10 10" refX="8" refY="5" markerUnits="userSpaceOnUse" markerWidth={4 * r} markerHeight={4 * r} orient="auto-start-reverse">
            <path d="M0,0 L10,5 L0,10 z" fill="#b3261e" />
          </marker>
        </defs>
        <polygon data-part="cushion" points={pts(cushion(chain, view.zc))} fill="rgba(211,102,47,0.18)" stroke="#d3662f" strokeWidth={1.5} vectorEffect="non-scaling-stroke" />
        <polygon data-part="head" points={pts(outline)} fill={gap < 0 ? "rgba(179,38,30,0.12)" : "rgba(47,91,211,0.10)"} stroke="#2f5bd3" strokeWidth={1.5} vectorEffect="non-scaling-stroke" />
        {/* each link's COG hangs on its joint (a link of length 0, the head, is drawn this way) */}
        {p.coms.map(([x, z], i) => (
          <line key={`b${i}`} x1={p.joints[i][0]} y1={-p.joints[i][1]} x2={x} y2={-z} stroke="#3b4256" strokeOpacity={0.55} strokeWidth={1.5} vectorEffect="non-scaling-stroke" />
        ))}
        <polyline data-part="links" points={pts(p.joints)} fill="none" stroke="#3b4256" strokeWidth={4} strokeLinecap="round" strokeLinejoin="round" vectorEffect="non-scaling-stroke" />
        {/* the base: a fixed support under the first joint */}
        <polygon points={pts([p.joints[0], [p.joints[0][0] - 1.6 * r, p.joints[0][1] - 2.2 * r], [p.joints[0][0] + 1.6 * r, p.joints[0][1] - 2.2 * r]])} fill="#6b7385" />
        {p.joints.slice(0, -1).map(([x, z], i) => (
          <circle key={`j${i}`} data-part="joint" cx={x} cy={-z} r={r} fill="#fff" stroke="#3b4256" strokeWidth={2} vectorEffect="non-scaling-stroke">
            <title>{chain.joints[i]?.name || `joint ${i + 1}`}</title>
          </circle>
        ))}
        {p.coms.map(([x, z], i) => (
          <circle key={`c${i}`} data-part="com" cx={x} cy={-z} r={r * 0.55} fill="#3b4256">
            <title>{`COG of ${chain.links[i]?.name || `link ${i + 1}`}`}</title>
          </circle>
        ))}
        <circle data-part="head-origin" cx={p.head.origin[0]} cy={-p.head.origin[1]} r={r * 0.5} fill="#2f5bd3" />
        {arrow && (
          <line
            data-part="force"
            x1={arrow.from[0]}
            y1={-arrow.from[1]}
            x2={arrow.to[0]}
            y2={-arrow.to[1]}
            stroke="#b3261e"
            strokeWidth={3}
            vectorEffect="non-scaling-stroke"
            markerEnd={`url(#${markerId})`}
          />
        )}
      </svg>
      <figcaption className="hint" data-testid={`${testId}-caption`}>
        {gap >= 0 ? `head ${(gap * 1000).toFixed(1)} mm clear of the headrest` : `cushion pressed in ${(-gap * 1000).toFixed(1)} mm`}
        {f ? ` · contact force ${magnitude.toFixed(1)} N` : ""} · joint angles {q.map((v) => v.toFixed(3)).join(", ")} rad
      </figcaption>
    </figure>
  );
}
