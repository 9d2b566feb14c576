import { describe, expect, it } from "vitest";
import { ApiError, fieldErrors } from "./errors";

describe("API errors", () => {
  it("turns FastAPI 422 details into field paths without the location prefix", () => {
    const body = { detail: [{ loc: ["body", "phases", 0, "duration"], msg: "must be positive", type: "value_error" }] };
    expect(fieldErrors(body)).toEqual([{ field: "phases.0.duration", message: "must be positive" }]);
    expect(new ApiError(422, body).message).toBe("phases.0.duration: must be positive");
  });

  it("uses a string detail as the message", () => {
    expect(new ApiError(409, { detail: "campaign is running" }).message).toBe("campaign is running");
  });

  it("falls back to the status code", () => {
    expect(new ApiError(502, null).message).toBe("HTTP 502");
    expect(fieldErrors(undefined)).toEqual([]);
  });
});
