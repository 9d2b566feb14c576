import { describe, expect, it } from "vitest";
import { errorAt } from "./PhasesTable";

describe("errorAt", () => {
  it("shows a field's own error and those of its list items", () => {
    const errors = { "phases.0.q_min": "expected 1 value(s)", "phases.0.q_min.0": "0 rad lies outside the model's joint range", "phases.0.q_max": "other" };
    expect(errorAt(errors, "phases.0.q_min")).toBe("expected 1 value(s); joint 0: 0 rad lies outside the model's joint range");
    expect(errorAt(errors, "phases.0.q_max")).toBe("other");
    expect(errorAt(errors, "phases.1.q_min")).toBeUndefined();
    expect(errorAt({ "phases.0.q_min_x": "not mine" }, "phases.0.q_min")).toBeUndefined();
  });
});
