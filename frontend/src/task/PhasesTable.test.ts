import { describe, expect, it } from "vitest";
import { phaseFieldPaths } from "./PhasesTable";
import { atFieldText, errorView } from "../lib/formErrors";

const phases = [{ duration: 1, w_tau: 1, w_T: 0 }, { duration: 1, w_tau: 1, w_T: 0 }];

describe("phase cells own their list items' errors", () => {
  it("shows a field's own error and those of its list items at the field, once each", () => {
    const view = errorView(
      [
        [
          { field: "phases.0.q_min", message: "expected 1 value(s)" },
          { field: "phases.0.q_min.0", message: "0 rad lies outside the model's joint range" },
          { field: "phases.0.q_max", message: "other" },
          { field: "phases.0.q_min_x", message: "not mine" },
        ],
      ],
      ["phases", ...phaseFieldPaths(phases)],
      (p) => p,
    );
    expect(view.at("phases.0.q_min").map((p) => atFieldText(p, "joint"))).toEqual(["expected 1 value(s)", "joint 1: 0 rad lies outside the model's joint range"]);
    expect(view.at("phases.0.q_max").map((p) => atFieldText(p))).toEqual(["other"]);
    expect(view.at("phases.1.q_min")).toEqual([]);
    // not a cell of the table: the table's own list of problems has it
    expect(view.at("phases").map((p) => p.path)).toEqual(["phases.0.q_min_x"]);
  });
});
