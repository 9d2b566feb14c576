/**
 * Chart state lives in the URL so a view can be shared and survives reload:
 * `log=0|1`, `k=5` (the iteration shown), `overlay=1-5, 8` (iterations overlaid), `tab=`.
 */
import { useCallback, useMemo } from "react";
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

export function useBoolParam(name: string, fallback: boolean): [boolean, (v: boolean) => void] {
  const [params, setParams] = useSearchParams();
  const raw = params.get(name);
  const value = raw === null ? fallback : raw === "1";
  const set = useCallback(
    (v: boolean) =>
      setParams(
        (p) => {
          const next = new URLSearchParams(p);
          next.set(name, v ? "1" : "0");
          return next;
        },
        { replace: true },
      ),
    [name, setParams],
  );
  return [value, set];
}

export function useIntListParam(name: string): [number[], (v: number[]) => void] {
  const [params, setParams] = useSearchParams();
  const raw = params.get(name);
  const value = useMemo(() => parseIntList(raw), [raw]);
  const set = useCallback(
    (v: number[]) =>
      setParams(
        (p) => {
          const next = new URLSearchParams(p);
          if (v.length) next.set(name, v.join(","));
          else next.delete(name);
          return next;
        },
        { replace: true },
      ),
    [name, setParams],
  );
  return [value, set];
}

export function useStringParam(name: string, fallback = ""): [string, (v: string) => void] {
  const [params, setParams] = useSearchParams();
  const value = params.get(name) ?? fallback;
  const set = useCallback(
    (v: string) =>
      setParams(
        (p) => {
          const next = new URLSearchParams(p);
          if (v && v !== fallback) next.set(name, v);
          else next.delete(name);
          return next;
        },
        { replace: true },
      ),
    [name, fallback, setParams],
  );
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
