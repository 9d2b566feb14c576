import { describe, expect, it } from "vitest";
import { backoff, FALLBACK_POLL_MS, invalidationsFor, SseParser } from "./live";
import type { CampaignEvent } from "./types";

const ev = (kind: string, step: string | null = null, data: Record<string, unknown> = {}): CampaignEvent => ({ id: 1, campaign_id: 7, iteration_index: 3, step, kind, message: "", data, created_at: "" });

describe("SSE parser", () => {
  it("reads id, event and data, across chunk boundaries and CRLF, and skips keep-alive comments", () => {
    const p = new SseParser();
    expect(p.push(": keep-alive\n\nid: 4\nevent: sta")).toEqual([]);
    expect(p.push('tus\r\ndata: {"a":1}\r')).toEqual([]);
    expect(p.push("\n\r\n")).toEqual([{ id: "4", event: "status", data: '{"a":1}' }]);
    // a frame carries the id it was sent with (readStream keeps the last id seen across frames)
    expect(p.push("data: line 1\ndata: line 2\n\n")).toEqual([{ id: null, event: "message", data: "line 1\nline 2" }]);
    expect(p.push("id: 5\nevent: step_started\ndata:{}\n\nid: 6\nevent: forked\ndata: {}\n\n").map((f) => f.id)).toEqual(["5", "6"]);
  });
});

describe("which queries an event changes", () => {
  const keys = (e: CampaignEvent) => invalidationsFor(e).map((k) => k.join("/"));
  it("a step start refreshes the header and the jobs only", () => {
    expect(keys(ev("step_started", "train"))).toEqual(["campaign/7", "jobs/7"]);
  });
  it("a trained model refreshes the models, an appended pool the pools and iteration marks", () => {
    expect(keys(ev("step_succeeded", "train"))).toContain("models/7");
    expect(keys(ev("step_succeeded", "append"))).toEqual(expect.arrayContaining(["pools/7", "iteration-states/7"]));
    expect(keys(ev("step_succeeded", "ocp"))).not.toContain("metrics/7");
  });
  it("a terminal status refreshes everything that may have changed last", () => {
    expect(keys(ev("status", null, { from: "running", to: "completed" }))).toEqual(expect.arrayContaining(["campaign/7", "campaigns", "jobs/7", "iteration-states/7", "pools/7", "models/7"]));
  });
  it("an earlier model's generalisation error refreshes the header and the campaign list", () => {
    expect(keys(ev("validation_evaluated", null))).toEqual(["campaign/7", "validation/7", "campaigns"]);
    expect(keys(ev("step_succeeded", "evaluate"))).toContain("validation/7");
  });
  it("the fallback polls less often the longer the stream is down", () => {
    expect([1, 2, 3, 4, 5, 9].map((n) => backoff(FALLBACK_POLL_MS, n))).toEqual([2000, 4000, 8000, 15000, 30000, 30000]);
  });
});
