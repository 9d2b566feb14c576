import { describe, expect, it } from "vitest";
import { ApiError } from "./errors";
import { retryDelay, shouldRetry, shouldRetryWrite } from "./retry";

describe("retry policy", () => {
  it("retries a busy database (503) and network failures, with growing delays", () => {
    expect(shouldRetry(0, new ApiError(503, { detail: "database busy, retry" }))).toBe(true);
    expect(shouldRetry(4, new ApiError(0, null))).toBe(true);
    expect(shouldRetry(5, new ApiError(503, null))).toBe(false);
    expect(retryDelay(0)).toBeLessThan(retryDelay(2));
  });
  it("repeats a write only when the server said it did not happen", () => {
    expect(shouldRetryWrite(0, new ApiError(503, { detail: "database busy, retry" }))).toBe(true);
    expect(shouldRetryWrite(0, new ApiError(0, null))).toBe(false);
    expect(shouldRetryWrite(0, new ApiError(409, null))).toBe(false);
  });
  it("never retries client errors", () => {
    for (const status of [400, 401, 403, 404, 409, 422]) expect(shouldRetry(0, new ApiError(status, null))).toBe(false);
  });
});
