import { describe, expect, it, vi } from "vitest";
import { fireEvent, render, screen } from "@testing-library/react";
import { errorView, schemaLabel } from "../lib/formErrors";
import { schemaFieldPaths, SchemaForm, schemaDefaults, schemaLocalErrors, type JsonSchema } from "./SchemaForm";
import { humanMessage } from "../api/errors";

// The aux-penalty parameters as pydantic emits them (see `alcove oracle schema aux-penalty`).
const AUX: JsonSchema = {
  type: "object",
  title: "AuxPenaltyParams",
  properties: {
    k: { type: "number", default: 6e6, exclusiveMinimum: 0, description: "quadratic stiffness k [N/m^2]" },
    d0: { type: "number", default: 100, minimum: 0 },
    r_sp: { anyOf: [{ type: "array", items: { type: "number" } }, { type: "null" }], default: null },
    mode: { enum: ["fast", "exact"], type: "string", default: "fast" },
    nested: { $ref: "#/$defs/Cushion" },
  },
  required: ["k"],
  $defs: { Cushion: { type: "object", properties: { thickness: { type: "number", default: 0.05 }, friction: { type: "boolean", default: true } } } },
};

describe("SchemaForm", () => {
  it("collects the defaults, following $ref into nested objects", () => {
    expect(schemaDefaults(AUX)).toEqual({ k: 6e6, d0: 100, r_sp: null, mode: "fast", nested: { thickness: 0.05, friction: true } });
  });

  it("renders one labelled input per field with its bounds and description", () => {
    render(<SchemaForm schema={AUX} value={schemaDefaults(AUX)} onChange={() => {}} />);
    expect(screen.getByLabelText(/^k/)).toHaveValue("6000000");
    expect(screen.getByText(/quadratic stiffness k \[N\/m\^2\] · > 0/)).toBeInTheDocument();
    expect(screen.getByLabelText(/^mode/)).toHaveValue("fast");
    expect(screen.getByLabelText("thickness")).toHaveValue("0.05");
    expect(screen.getByLabelText("friction")).toBeChecked();
  });

  it("emits numbers for number fields and null for a cleared nullable field", () => {
    const onChange = vi.fn();
    render(<SchemaForm schema={AUX} value={{ k: 1, d0: 2 }} onChange={onChange} />);
    fireEvent.change(screen.getByLabelText(/^d0/), { target: { value: "3.5" } });
    expect(onChange).toHaveBeenLastCalledWith({ k: 1, d0: 3.5 });
    fireEvent.blur(screen.getByLabelText("r_sp"), { target: { value: "0.1, 0, -0.02" } });
    expect(onChange).toHaveBeenLastCalledWith({ k: 1, d0: 2, r_sp: [0.1, 0, -0.02] });
  });

  it("rounds long bounds for display, in hints, in its own checks and in the API's messages", () => {
    const tilt: JsonSchema = { type: "object", properties: { tilt: { type: "number", minimum: -1.5707963267948966, maximum: 1.5707963267948966, description: "headrest inclination [rad]" } } };
    const own = schemaLocalErrors(tilt, { tilt: 2 });
    const errors = errorView([own], schemaFieldPaths(tilt), (p) => schemaLabel(tilt, p));
    render(<SchemaForm schema={tilt} value={{ tilt: 2 }} onChange={() => {}} errors={errors} />);
    expect(screen.getByText("headrest inclination [rad] · ≥ -1.5708, ≤ 1.5708")).toBeInTheDocument();
    expect(screen.getByText("must be at most 1.5708")).toBeInTheDocument();
    expect(humanMessage("Input should be less than or equal to 1.5707963267948966")).toBe("must be at most 1.5708");
    expect(document.body.textContent).not.toContain("1.5707963267948966");
  });

  it("shows the API's field errors next to the field, in words, and marks it invalid", () => {
    const errors = errorView([[{ field: "k", message: "Input should be greater than 0" }, { field: "nested.thickness", message: "too thin" }]], schemaFieldPaths(AUX), (p) => schemaLabel(AUX, p));
    render(<SchemaForm schema={AUX} value={{ k: -1 }} onChange={() => {}} errors={errors} />);
    expect(screen.getByLabelText(/^k/)).toHaveAttribute("aria-invalid", "true");
    expect(screen.getByText("must be greater than 0")).toBeInTheDocument();
    expect(screen.getByText("too thin")).toBeInTheDocument();
    expect(errors.unplaced).toEqual([]);
  });
});
