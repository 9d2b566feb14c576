import { describe, expect, it, vi } from "vitest";
import { cleanup, fireEvent, render, screen, within } from "@testing-library/react";
import { ScenarioRanges, rangeFieldPaths, type RangeRow } from "./ScenarioRanges";
import { errorView } from "../lib/formErrors";
import type { ScenarioPreview } from "../api/types";

const ranges: RangeRow[] = [
  { parameter: "initial.q.0", low: 0.15, high: 0.3 },
  { parameter: "model.headrest_offset", low: -0.005, high: 0.005 },
];

function view(errors: { field: string; message: string }[] = []) {
  return errorView([errors], rangeFieldPaths(ranges), (p) => p);
}

describe("scenario ranges of a task", () => {
  it("edits, adds and removes ranges; no range left is null (one scenario, the task itself)", () => {
    const onChange = vi.fn();
    render(<ScenarioRanges ranges={ranges} onChange={onChange} errors={view()} preview={undefined} previewing={false} onPreview={() => {}} canPreview />);
    const high = screen.getByLabelText("range 1 high");
    fireEvent.change(high, { target: { value: "0.25" } });
    fireEvent.blur(high);
    expect(onChange).toHaveBeenLastCalledWith([{ ...ranges[0], high: 0.25 }, ranges[1]]);
    fireEvent.click(screen.getByText("Add range"));
    expect(onChange.mock.lastCall?.[0]).toHaveLength(3);
    fireEvent.click(screen.getByLabelText("remove range 2"));
    expect(onChange).toHaveBeenLastCalledWith([ranges[0]]);
    onChange.mockClear();
    cleanup();
    render(<ScenarioRanges ranges={[ranges[0]]} onChange={onChange} errors={view()} preview={undefined} previewing={false} onPreview={() => {}} canPreview />);
    fireEvent.click(screen.getByLabelText("remove range 1"));
    expect(onChange).toHaveBeenLastCalledWith(null);
  });

  it("switches a range's distribution and edits its shape; back to uniform drops the shape", () => {
    const onChange = vi.fn();
    const { rerender } = render(<ScenarioRanges ranges={ranges} onChange={onChange} errors={view()} preview={undefined} previewing={false} onPreview={() => {}} canPreview />);
    expect(screen.queryByLabelText("range 1 mean")).toBeNull();
    fireEvent.change(screen.getByLabelText("range 1 distribution"), { target: { value: "normal" } });
    const normal = onChange.mock.lastCall?.[0] as RangeRow[];
    expect(normal[0]).toEqual({ ...ranges[0], distribution: "normal", mean: expect.closeTo(0.225, 12), std: expect.closeTo(0.025, 12) });
    rerender(<ScenarioRanges ranges={normal} onChange={onChange} errors={view([{ field: "ranges.0.std", message: "Input should be greater than 0" }])} preview={undefined} previewing={false} onPreview={() => {}} canPreview />);
    const std = screen.getByLabelText("range 1 std");
    expect(std.getAttribute("aria-invalid")).toBe("true");
    fireEvent.change(std, { target: { value: "0.05" } });
    fireEvent.blur(std);
    expect(onChange).toHaveBeenLastCalledWith([{ ...normal[0], std: 0.05 }, ranges[1]]);
    fireEvent.change(screen.getByLabelText("range 1 distribution"), { target: { value: "triangular" } });
    expect(onChange).toHaveBeenLastCalledWith([{ ...ranges[0], distribution: "triangular", mode: expect.closeTo(0.225, 12) }, ranges[1]]);
    fireEvent.change(screen.getByLabelText("range 1 distribution"), { target: { value: "uniform" } });
    expect(onChange).toHaveBeenLastCalledWith([ranges[0], ranges[1]]);
  });

  it("suggests the headrest tilt and offset among the parameters", () => {
    const { container } = render(<ScenarioRanges ranges={ranges} onChange={() => {}} errors={view()} preview={undefined} previewing={false} onPreview={() => {}} canPreview />);
    const options = Array.from(container.querySelectorAll("#range-parameters option")).map((o) => o.getAttribute("value"));
    expect(options).toContain("model.tilt");
    expect(options).toContain("model.headrest_offset");
    expect(options).not.toContain("model.theta_contact");
  });

  it("shows the server's error at the range it names", () => {
    const errors = view([{ field: "ranges.0.high", message: "initial.q.0 = 0.5 is not a valid task" }]);
    render(<ScenarioRanges ranges={ranges} onChange={() => {}} errors={errors} preview={undefined} previewing={false} onPreview={() => {}} canPreview />);
    expect(screen.getByLabelText("range 1 high").getAttribute("aria-invalid")).toBe("true");
    expect(screen.getByLabelText("range 1 low").getAttribute("aria-invalid")).toBe("false");
    expect(screen.getByRole("alert").textContent).toContain("0.5 is not a valid task");
  });

  it("lists the sampled scenarios, one column per ranged parameter", () => {
    const onPreview = vi.fn();
    const preview = {
      seed: 0,
      ranges,
      scenarios: [
        { iteration: 1, values: { "initial.q.0": 0.2123456, "model.headrest_offset": 0.001 }, spec: {} },
        { iteration: 2, values: { "initial.q.0": 0.29, "model.headrest_offset": -0.004 }, spec: {} },
      ],
    } as unknown as ScenarioPreview;
    render(<ScenarioRanges ranges={ranges} onChange={() => {}} errors={view()} preview={preview} previewing={false} onPreview={onPreview} canPreview />);
    fireEvent.click(screen.getByText("Preview scenarios"));
    expect(onPreview).toHaveBeenCalledOnce();
    const table = screen.getByTestId("scenario-preview");
    const rows = within(table).getAllByRole("row");
    expect(rows.map((r) => r.textContent)).toEqual(["iterationinitial.q.0model.headrest_offset", "10.21230.001000", "20.2900-0.004000"]);
  });

  it("cannot preview before the task exists or without ranges", () => {
    const { rerender } = render(<ScenarioRanges ranges={ranges} onChange={() => {}} errors={view()} preview={undefined} previewing={false} onPreview={() => {}} canPreview={false} />);
    expect((screen.getByText("Preview scenarios") as HTMLButtonElement).disabled).toBe(true);
    rerender(<ScenarioRanges ranges={[]} onChange={() => {}} errors={view()} preview={undefined} previewing={false} onPreview={() => {}} canPreview />);
    expect((screen.getByText("Preview scenarios") as HTMLButtonElement).disabled).toBe(true);
  });
});
