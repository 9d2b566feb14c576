/**
 * Chart state lives in the URL so a view can be shared and survives reload:
 * `log=0|1`, `k=5` (the iteration shown), `overlay=1-5, 8` (iterations overlaid), `tab=`.
 */
import { useCallback, useMemo, useState } from "react";
import { useSearchParams } from "react-router-dom";

export function parseIntList(raw: string | null): number[] {
  if (!raw) return [];
  const out: number[] = [];
  for (const part of raw.split(",")) {
    const n = Number.parseInt(part, 10);
    if (Number.isInteger(n) && n >= 0 && !out.includes(n)) out.push(n);
  }
  return out;
}

/**
 * One search parameter as state that a control shows at once. React Router applies a
 * navigation in a transition, so a controlled input bound to the URL alone is put back to its
 * old value when the event ends and shows the new one only when the transition commits: a
 * radio or checkbox flickers back, and a fast typist loses characters. The value shown is
 * local state set in the same event as the navigation; it follows the URL whenever the URL's
 * value changes (a link, back and forward, another control writing the same parameter).
 */
function useParam(name: string): [string | null, (v: string | null) => void] {
  const [params, setParams] = useSearchParams();
  const inUrl = params.get(name);
  const [shown, setShown] = useState(inUrl);
  const [lastInUrl, setLastInUrl] = useState(inUrl);
  if (inUrl !== lastInUrl) {
    // adjusting state while rendering (React's documented pattern): no extra commit
    setLastInUrl(inUrl);
    setShown(inUrl);
  }
  const set = useCallback(
    (v: string | null) => {
      setShown(v);
      setParams(
        (p) => {
          const next = new URLSearchParams(p);
          if (v === null) next.delete(name);
          else next.set(name, v);
          return next;
        },
        { replace: true },
      );
    },
    [name, setParams],
  );
  return [shown, set];
}

export function useBoolParam(name: string, fallback: boolean): [boolean, (v: boolean) => void] {
  const [raw, setRaw] = useParam(name);
  const value = raw === null ? fallback : raw === "1";
  const set = useCallback((v: boolean) => setRaw(v ? "1" : "0"), [setRaw]);
  return [value, set];
}

export function useIntListParam(name: string): [number[], (v: number[]) => void] {
  const [raw, setRaw] = useParam(name);
  const value = useMemo(() => parseIntList(raw), [raw]);
  const set = useCallback((v: number[]) => setRaw(v.length ? v.join(",") : null), [setRaw]);
  return [value, set];
}

export function useStringParam(name: string, fallback = ""): [string, (v: string) => void] {
  const [raw, setRaw] = useParam(name);
  const value = raw ?? fallback;
  const set = useCallback((v: string) => setRaw(v && v !== fallback ? v : null), [fallback, setRaw]);
  return [value, set];
}

/**
 * Set several parameters in one navigation. (Two setters called in a row each start from the
 * same rendered parameters, so the second would drop the first's change.)
 */
export function useSetParams(): (changes: Record<string, string | null>) => void {
  const [, setParams] = useSearchParams();
  return useCallback(
    (changes: Record<string, string | null>) =>
      setParams(
        (p) => {
          const next = new URLSearchParams(p);
          for (const [k, v] of Object.entries(changes)) {
            if (v === null || v === "") next.delete(k);
            else next.set(k, v);
          }
          return next;
        },
        { replace: true },
      ),
    [setParams],
  );
}
