/**
 * Playback of a solved trajectory: the chain moving into the cushion (ChainDrawing), the contact
 * force as an arrow, a time slider and play / pause. The sample shown is the parent's state
 * (`index`), so the parent's plots can draw a cursor at the same time (see Plot's `cursorX`):
 * moving the slider moves the cursor, and playback moves both.
 */
import { useEffect, useMemo, useRef, useState } from "react";
import { ChainDrawing } from "./ChainDrawing";
import type { Chain } from "../lib/kinematics";

/** Playback speeds (fractions of real time: a contact lasts a few tenths of a second). */
export const SPEEDS = [0.05, 0.1, 0.25, 1] as const;
/** At most this many picture updates per second during playback. */
const FPS = 25;

/** The last sample at or before time `time` (t ascending). */
export function sampleAt(t: readonly number[], time: number): number {
  let lo = 0;
  let hi = t.length - 1;
  if (hi < 0 || time <= t[0]) return 0;
  if (time >= t[hi]) return hi;
  while (hi - lo > 1) {
    const mid = (lo + hi) >> 1;
    if (t[mid] <= time) lo = mid;
    else hi = mid;
  }
  return lo;
}

export interface ChainPlayerProps {
  chain: Chain;
  t: readonly number[];
  /** joint angles, one row per sample */
  q: readonly (readonly number[])[];
  /** contact force on the head in H per sample [N]; null: no arrow */
  force?: { fx: readonly (number | null)[]; fz: readonly (number | null)[] } | null;
  index: number;
  setIndex: (i: number) => void;
  testId?: string;
  label?: string;
}

export function ChainPlayer({ chain, t, q, force, index, setIndex, testId = "chain-player", label = "Playback" }: ChainPlayerProps) {
  const [playing, setPlaying] = useState(false);
  const [speed, setSpeed] = useState<number>(0.1);
  const n = Math.min(t.length, q.length);
  const i = Math.min(Math.max(index, 0), Math.max(n - 1, 0));
  const frames = useMemo(() => q.slice(0, n).map((row) => row.map((v) => (v === null || !Number.isFinite(v) ? 0 : v))), [q, n]);
  const forceScale = useMemo(() => {
    if (!force) return 0;
    let m = 0;
    for (let k = 0; k < n; k++) m = Math.max(m, Math.hypot(force.fx[k] ?? 0, force.fz[k] ?? 0));
    return m;
  }, [force, n]);

  // playback: the time advances with the clock (times the speed); the picture follows at FPS
  const setRef = useRef(setIndex);
  const startIndex = useRef(i);
  useEffect(() => {
    setRef.current = setIndex;
    startIndex.current = i;
  });
  useEffect(() => {
    if (!playing || n < 2) return;
    const from = startIndex.current >= n - 1 ? 0 : startIndex.current;
    const t0 = t[from];
    const wall0 = performance.now();
    // a timer at FPS (not requestAnimationFrame: the picture needs no more, and a timer also
    // runs where frames are not painted)
    const timer = setInterval(() => {
      const time = t0 + ((performance.now() - wall0) / 1000) * speed;
      setRef.current(sampleAt(t, time));
      if (time >= t[n - 1]) {
        clearInterval(timer);
        setPlaying(false);
      }
    }, 1000 / FPS);
    return () => clearInterval(timer);
  }, [playing, speed, t, n]);

  if (n === 0) return null;
  const f = force ? { fx: force.fx[i] ?? Number.NaN, fz: force.fz[i] ?? Number.NaN } : null;
  return (
    <div className="chain-player" data-testid={testId} data-index={i} data-playing={playing ? "true" : "false"}>
      <ChainDrawing chain={chain} q={frames[i]} frames={frames} force={f} forceScale={forceScale} testId={`${testId}-drawing`} label={label} />
      <div className="slider">
        <button type="button" onClick={() => setPlaying(!playing)} aria-label={playing ? "Pause" : "Play"} data-testid={`${testId}-play`}>
          {playing ? "❚❚ Pause" : "▶ Play"}
        </button>
        <label htmlFor={`${testId}-time`}>Time</label>
        <input
          id={`${testId}-time`}
          type="range"
          min={0}
          max={n - 1}
          step={1}
          value={i}
          onChange={(e) => {
            setPlaying(false);
            setIndex(Number(e.target.value));
          }}
          aria-valuetext={`t = ${t[i].toFixed(3)} s`}
        />
        <output htmlFor={`${testId}-time`} data-testid={`${testId}-time-value`}>
          t = {t[i].toFixed(3)} s
        </output>
        <label htmlFor={`${testId}-speed`}>speed</label>
        <select id={`${testId}-speed`} value={speed} onChange={(e) => setSpeed(Number(e.target.value))}>
          {SPEEDS.map((s) => (
            <option key={s} value={s}>
              {s}× real time
            </option>
          ))}
        </select>
      </div>
    </div>
  );
}
