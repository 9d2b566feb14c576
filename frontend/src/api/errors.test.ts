import { describe, expect, it } from "vitest";
import { ApiError, fieldErrors } from "./errors";

describe("API errors", () => {
  it("turns FastAPI 422 details into field paths without the location prefix", () => {
    const body = { detail: [{ loc: ["body", "phases", 0, "duration"], msg: "must be positive", type: "value_error" }] };
    expect(fieldErrors(body)).toEqual([{ field: "phases.0.duration", message: "must be positive" }]);
    // where no form places it, the message names the field in words, not as a raw path
    expect(new ApiError(422, body).message).toBe("phases 1 › duration: must be positive");
    const raw = { detail: [{ loc: ["body", "spec", "phases", 0, "q_min", 0], msg: "Input should be a valid number", type: "float_parsing" }] };
    expect(new ApiError(422, raw).message).toBe("phases 1 › q_min 1: must be a number");
  });

  it("uses a string detail as the message", () => {
    expect(new ApiError(409, { detail: "campaign is running" }).message).toBe("campaign is running");
  });

  it("falls back to the status code", () => {
    expect(new ApiError(502, null).message).toBe("HTTP 502");
    expect(fieldErrors(undefined)).toEqual([]);
  });
});
