/**
 * The live channel: Server-Sent Events read with fetch (EventSource cannot send the bearer
 * token), one stream per page. Each event invalidates only the queries whose data it changed;
 * while the stream is down the page polls instead, with backoff, and the stream reconnects
 * with ?after=<last event id>.
 */
import { useEffect, useRef, useState } from "react";
import { createParser, type EventSourceMessage } from "eventsource-parser";
import { useQueryClient, type QueryClient } from "@tanstack/react-query";
import { storedToken } from "./auth";
import { ApiError } from "./errors";
import { ensureIteration, hasSeries } from "./series";
import { keys } from "./keys";
import { refetchAfterWrite } from "./refresh";
import { isTerminal, type CampaignEvent } from "./types";

export interface SseFrame {
  id: string | null;
  event: string;
  data: string;
}

/**
 * Incremental parser of a text/event-stream (eventsource-parser, the spec's algorithm): feed it
 * chunks, get the complete frames. A frame without an `event` field is a "message", as in the
 * browser's EventSource.
 */
export class SseParser {
  private frames: SseFrame[] = [];
  private parser = createParser({
    onEvent: (m: EventSourceMessage) => this.frames.push({ id: m.id ?? null, event: m.event ?? "message", data: m.data }),
  });

  push(chunk: string): SseFrame[] {
    this.parser.feed(chunk);
    const done = this.frames;
    this.frames = [];
    return done;
  }
}

/**
 * Read one stream until the server closes it. Resolves with the last event id seen (or
 * `after` if none); rejects when the connection fails or drops.
 */
/**
 * The server's `ready` frame ends the catch-up after a (re)connection: from then on every event
 * is sent as it is committed. `complete: false` (a first connection, which starts "now", or
 * more missed events than the server keeps) means events may have been missed: reload.
 */
export interface Ready {
  last_event_id: number;
  complete: boolean;
}

export async function readStream(
  url: string,
  opts: { after: number; signal: AbortSignal; onOpen?: () => void; onEvent: (e: CampaignEvent) => void; onReady?: (r: Ready) => void },
): Promise<number> {
  const u = new URL(url, window.location.origin);
  if (opts.after > 0) u.searchParams.set("after", String(opts.after));
  const token = storedToken();
  const response = await fetch(u, { headers: { Accept: "text/event-stream", ...(token ? { Authorization: `Bearer ${token}` } : {}) }, signal: opts.signal, cache: "no-store" });
  if (!response.ok || !response.body) throw new ApiError(response.status, null);
  opts.onOpen?.();
  const reader = response.body.pipeThrough(new TextDecoderStream()).getReader();
  const parser = new SseParser();
  let last = opts.after;
  for (;;) {
    const { value, done } = await reader.read();
    if (done) return last;
    for (const f of parser.push(value)) {
      const id = Number(f.id);
      if (Number.isInteger(id) && id > last) last = id;
      let data: unknown;
      try {
        data = JSON.parse(f.data);
      } catch {
        continue; // a frame that is not JSON: ignore
      }
      if (f.event === "ready") opts.onReady?.(data as Ready);
      else if (data && typeof data === "object" && "kind" in data) opts.onEvent(data as CampaignEvent);
    }
  }
}

const TERMINAL_EVENT = (e: CampaignEvent) => e.kind === "status" && typeof e.data?.to === "string" && isTerminal(e.data.to);

export type LiveState = "off" | "connecting" | "live" | "down";

/** Reconnect delays while the stream is down (ms), and the fallback poll interval at each step. */
export const RECONNECT_MS = [1000, 2000, 4000, 8000, 15000, 30000];
export const FALLBACK_POLL_MS = [2000, 4000, 8000, 15000, 30000];

export function backoff(list: number[], failures: number): number {
  return list[Math.min(Math.max(failures - 1, 0), list.length - 1)];
}

/**
 * Keep a stream open while `enabled`: reconnect at once (with ?after=) when the server ends it
 * (its timeout), with backoff when it fails; stop when `done()` says so after the server
 * closed it (e.g. the campaign reached a terminal state).
 */
export function runStream(
  url: string,
  opts: { onEvent: (e: CampaignEvent) => void; onState: (s: LiveState) => void; onReset?: (openedAt: number) => void; done?: () => boolean; signal: AbortSignal },
): void {
  let after = 0;
  let failures = 0;
  let sawTerminal = false;
  const sleep = (ms: number) =>
    new Promise<void>((resolve) => {
      const t = setTimeout(resolve, ms);
      opts.signal.addEventListener("abort", () => (clearTimeout(t), resolve()), { once: true });
    });
  void (async () => {
    opts.onState("connecting");
    while (!opts.signal.aborted) {
      try {
        let openedAt = 0;
        after = await readStream(url, {
          after,
          signal: opts.signal,
          onOpen: () => {
            failures = 0;
            openedAt = Date.now();
            opts.onState("live");
          },
          onReady: (r) => {
            if (r.last_event_id > after) after = r.last_event_id;
            // events may have been missed (first connection, long outage): reload what is shown
            if (!r.complete) opts.onReset?.(openedAt);
          },
          onEvent: (e) => {
            if (e.id > after) after = e.id;
            if (TERMINAL_EVENT(e)) sawTerminal = true;
            else if (e.kind === "status") sawTerminal = false;
            opts.onEvent(e);
          },
        });
        if (opts.signal.aborted) return;
        if (opts.done && (sawTerminal || opts.done())) {
          opts.onState("off");
          return;
        }
        await sleep(100); // closed by the server's timeout: reconnect
      } catch {
        if (opts.signal.aborted) return;
        failures += 1;
        opts.onState("down");
        await sleep(backoff(RECONNECT_MS, failures));
      }
    }
  })();
}

/** Which of a campaign's queries an event changed. */
export function invalidationsFor(e: CampaignEvent): (readonly unknown[])[] {
  const id = e.campaign_id;
  const out: (readonly unknown[])[] = [keys.campaign(id)];
  switch (e.kind) {
    case "status":
      out.push(keys.campaigns, keys.jobs(id));
      if (TERMINAL_EVENT(e)) out.push(keys.iterationStates(id), keys.pools(id), keys.models(id));
      break;
    case "step_succeeded":
      out.push(keys.jobs(id));
      if (e.step === "train") out.push(keys.models(id), keys.validation(id));
      if (e.step === "evaluate") out.push(keys.validation(id));
      if (e.step === "append") out.push(keys.pools(id), keys.iterationStates(id), keys.campaigns);
      break;
    case "step_failed":
    case "step_cancelled":
      out.push(keys.jobs(id), keys.iterationStates(id));
      break;
    case "step_started":
    case "step_retry":
    case "step_requeued":
    case "step_resent":
      out.push(keys.jobs(id));
      break;
    case "forked":
      out.push(keys.campaigns);
      break;
    case "validation_evaluated":
      out.push(keys.validation(id), keys.campaigns);
      break;
    default:
      break;
  }
  return out;
}

/**
 * Apply a batch of events (those that arrived together, e.g. the catch-up after a reconnect):
 * each query they changed is invalidated once; an evaluated iteration and, after a terminal
 * status, the campaign's latest iteration are fetched until the series holds them.
 */
export function applyEvents(qc: QueryClient, events: CampaignEvent[]): void {
  const todo = new Map<string, readonly unknown[]>();
  for (const e of events) for (const key of invalidationsFor(e)) todo.set(JSON.stringify(key), key);
  // prefixes: ["campaign", 7] is that campaign's detail only; the list's key carries its filters;
  // a first fetch still on its way may have read before the event's change: fetched again
  for (const key of todo.values()) void refetchAfterWrite(qc, key);
  const evaluated = new Map<number, number>();
  for (const e of events)
    if (e.kind === "step_succeeded" && e.step === "evaluate" && e.iteration_index !== null) evaluated.set(e.campaign_id, Math.max(evaluated.get(e.campaign_id) ?? -1, e.iteration_index));
  for (const [id, k] of evaluated) if (hasSeries(qc, id)) void ensureIteration(qc, id, k);
  for (const id of new Set(events.filter(TERMINAL_EVENT).map((e) => e.campaign_id))) {
    // the last iterations' metrics: whatever the campaign's detail reports as latest
    void qc.fetchQuery({ queryKey: keys.campaign(id), staleTime: 0 }).then(
      (c) => {
        const latest = (c as { latest_metrics?: { iteration_index: number } | null }).latest_metrics?.iteration_index;
        if (latest !== undefined && hasSeries(qc, id)) void ensureIteration(qc, id, latest);
      },
      () => undefined,
    );
  }
}

/** Events that arrive within this window are applied together. */
export const BATCH_MS = 50;

/** What a page needs to know of its stream: its state, and how often the page is checked meanwhile (false: not at all). */
export interface Live {
  state: LiveState;
  poll: number | false;
}

/**
 * Keep a stream open at `url` (null: none). Events are handed on in batches; while the stream
 * is down, `onPoll` runs every 2 s, then less often (FALLBACK_POLL_MS), until it is up again.
 */
function useStream(url: string | null, onEvents: (e: CampaignEvent[]) => void, onPoll: () => void, onReset: (openedAt: number) => void, done?: () => boolean): Live {
  const [state, setState] = useState<LiveState>("off");
  const [pollStep, setPollStep] = useState(1);
  const handler = useRef(onEvents);
  const poller = useRef(onPoll);
  const resetter = useRef(onReset);
  const isDone = useRef(done);
  useEffect(() => {
    handler.current = onEvents;
    poller.current = onPoll;
    resetter.current = onReset;
    isDone.current = done;
  });
  useEffect(() => {
    if (!url) return;
    const abort = new AbortController();
    let batch: CampaignEvent[] = [];
    let timer: ReturnType<typeof setTimeout> | null = null;
    const flush = () => {
      timer = null;
      const events = batch;
      batch = [];
      if (events.length && !abort.signal.aborted) handler.current(events);
    };
    runStream(url, {
      signal: abort.signal,
      onEvent: (e) => {
        batch.push(e);
        timer ??= setTimeout(flush, BATCH_MS);
      },
      onState: (s) => setState(s),
      onReset: (openedAt) => resetter.current(openedAt),
      done: () => isDone.current?.() ?? false,
    });
    return () => {
      abort.abort();
      if (timer) clearTimeout(timer);
      setState("off");
    };
  }, [url]);
  // the fallback: poll while the stream is down, each wait longer than the last
  const down = url !== null && state === "down";
  useEffect(() => {
    if (!down) return;
    let n = 1;
    let timer: ReturnType<typeof setTimeout>;
    const schedule = () => {
      timer = setTimeout(() => {
        poller.current();
        n += 1;
        setPollStep(n);
        schedule();
      }, backoff(FALLBACK_POLL_MS, n));
    };
    schedule();
    return () => {
      clearTimeout(timer);
      setPollStep(1);
    };
  }, [down]);
  return { state: url ? state : "off", poll: down ? backoff(FALLBACK_POLL_MS, pollStep) : false };
}

const pageKeys = (id: number) => [keys.campaign(id), keys.metrics(id), keys.iterationStates(id), keys.jobs(id), keys.pools(id), keys.models(id), keys.validation(id)];

/**
 * Refetch what may have changed unseen: the queries under `prefixes` (only those on screen are
 * refetched, the others marked stale), or only those last fetched before `before` (ms).
 */
function refresh(qc: QueryClient, prefixes: (readonly unknown[])[], before?: number): void {
  // a query that has no data yet is still on its first fetch, which is answered after `before`
  for (const key of prefixes) void qc.invalidateQueries({ queryKey: key, predicate: before === undefined ? undefined : (q) => q.state.data !== undefined && q.state.dataUpdatedAt < before });
}

/**
 * The campaign page's stream: open while the campaign may still change (not terminal); the
 * server closes it once the campaign is terminal. A retried campaign opens it again.
 */
export function useCampaignLive(id: number, status: string | undefined): Live {
  const qc = useQueryClient();
  const open = status !== undefined && !isTerminal(status);
  const statusRef = useRef(status);
  useEffect(() => {
    statusRef.current = status;
  });
  return useStream(
    open ? `/api/v1/campaigns/${id}/events/stream` : null,
    (events) => applyEvents(qc, events.map((e) => ({ ...e, campaign_id: e.campaign_id ?? id }))),
    () => refresh(qc, pageKeys(id)),
    (openedAt) => refresh(qc, pageKeys(id), openedAt),
    () => statusRef.current === undefined || isTerminal(statusRef.current),
  );
}

/** The campaign list's stream: every campaign the user can see; never closes on a campaign's end. */
export function useCampaignListLive(enabled = true): Live {
  const qc = useQueryClient();
  return useStream(
    enabled ? "/api/v1/campaigns/events/stream" : null,
    (events) => {
      // every event changes a row (status, iteration, step, RMSE, ETA); a batch refetches the list once
      if (events.length) void qc.invalidateQueries({ queryKey: keys.campaigns });
      // the sparklines of the campaigns that got new metrics
      for (const id of new Set(events.filter((e) => e.kind === "step_succeeded" && e.step === "evaluate").map((e) => e.campaign_id)))
        void qc.invalidateQueries({ queryKey: keys.metrics(id) });
    },
    () => refresh(qc, [keys.campaigns]),
    (openedAt) => refresh(qc, [keys.campaigns, ["metrics"]], openedAt),
  );
}
