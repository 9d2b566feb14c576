/** Forms: every invalid input gets exactly one human-readable message at its field, the count agrees, nothing is rounded, no uncaught error. */
import { describe, expect, it, vi } from "vitest";
import { fireEvent, render, screen, waitFor } from "@testing-library/react";
import userEvent from "@testing-library/user-event";
import { useState } from "react";
import { TaskEditorPage } from "./TaskEditorPage";
import { jsonResponse, mockApi, renderPage } from "../test/utils";
import { Link } from "react-router-dom";
import { LEAVE_QUESTION } from "../lib/unsaved";
import { SchemaForm, schemaFieldPaths, schemaLocalErrors, type JsonSchema } from "../components/SchemaForm";
import { errorView, humanMessage, schemaLabel } from "../lib/formErrors";

const PHASE = {
  type: "object",
  title: "PhaseSpec",
  properties: {
    name: { type: "string", title: "Name" },
    duration: { type: "number", exclusiveMinimum: 0, title: "Duration", description: "phase duration [s]" },
    intervals: { type: "integer", minimum: 1, maximum: 20000, title: "Intervals", description: "DMOCC intervals in this phase" },
    w_tau: { type: "number", minimum: 0, title: "W Tau" },
    w_T: { type: "number", minimum: 0, title: "W T" },
    q_min: { anyOf: [{ type: "array", items: { type: "number" } }, { type: "null" }], title: "Q Min", description: "joint lower bounds in this phase (default: model range)" },
  },
};
const TASK_SCHEMA = {
  type: "object",
  title: "TaskSpec",
  properties: { name: { type: "string" }, model: { $ref: "#/$defs/ModelSpec" }, phases: { type: "array", title: "Phases", items: { $ref: "#/$defs/PhaseSpec" } }, endpoint_cost: { type: "number" } },
  $defs: {
    ModelSpec: { type: "object", properties: { mass: { type: "number", exclusiveMinimum: 0, description: "head mass [kg]" }, gravity: { type: "number", minimum: 0, description: "gravitational acceleration [m/s^2]" } } },
    PhaseSpec: PHASE,
  },
};
const PRESET = {
  key: "two-phase",
  name: "two-phase",
  description: "",
  spec: { name: "two", model: { mass: 5, gravity: 9.81 }, phases: [{ name: "approach", duration: 1, intervals: 100, w_tau: 0.001, w_T: 0.0001 }, { name: "rest", duration: 1, intervals: 100, w_tau: 1, w_T: 1 }] },
};
const loc = (...parts: (string | number)[]) => ({ loc: ["body", ...parts], msg: "", type: "x" });

describe("task editor form errors", () => {
  it("a refused save shows each problem once, at its field, in words; the count agrees; no uncaught error", async () => {
    const unhandled = vi.fn();
    process.on("unhandledRejection", unhandled);
    const saves: unknown[] = [];
    mockApi({
      "GET /tasks/presets": [PRESET],
      "GET /tasks/schema": TASK_SCHEMA,
      "POST /tasks/check": { valid: true, errors: [] },
      "POST /tasks": (_url: URL, body: unknown) => {
        saves.push(body);
        return jsonResponse(
          {
            detail: [
              { ...loc("spec", "phases", 0, "q_min", 0), msg: "Input should be a valid number, unable to parse string as a number" },
              { ...loc("spec", "model", "gravity"), msg: "Input should be less than or equal to 1000" },
              { ...loc("spec", "endpoint_cost"), msg: "Input should be greater than or equal to 0" },
            ],
          },
          422,
        );
      },
    });
    renderPage(<TaskEditorPage />, { route: "/tasks/new" });
    // a new task needs a name (a blank one is a problem the form names)
    fireEvent.change(await screen.findByLabelText("Name"), { target: { value: "a task" } });
    await screen.findByLabelText("phase 1 duration [s]");
    await userEvent.type(screen.getByLabelText("Name"), "bad task");
    await waitFor(() => expect(screen.getByTestId("check-state")).toHaveTextContent("valid"), { timeout: 3000 });
    await userEvent.click(screen.getByRole("button", { name: "Create task" }));
    await waitFor(() => expect(saves).toHaveLength(1));

    // the list field is marked, its item named, the label from the schema
    const qmin = screen.getByLabelText("phase 1 q min [rad]");
    await waitFor(() => expect(qmin).toHaveAttribute("aria-invalid", "true"));
    const atQmin = document.querySelector('[data-error-path="phases.0.q_min.0"]')!;
    expect(atQmin).toHaveTextContent("joint 1: must be a number");
    expect(atQmin).toHaveAttribute("title", "Phase 1 › joint lower bounds in this phase (q_min) 1: must be a number");
    expect(qmin.closest("td")).toContainElement(atQmin as HTMLElement);
    // the model's field carries the server's message in words
    expect(screen.getByLabelText(/^gravity/)).toHaveAttribute("aria-invalid", "true");
    expect(document.querySelector('[data-error-path="model.gravity"]')).toHaveTextContent("must be at most 1000");
    // a field the form does not show: once, in the summary, with its label
    expect(document.querySelector('[data-testid="form-errors"] [data-error-path="endpoint_cost"]')).toHaveTextContent("endpoint_cost: must be at least 0");

    // each problem exactly once; the badge counts what is shown; no raw paths
    const shown = [...document.querySelectorAll("[data-error-path]")].map((e) => e.getAttribute("data-error-path"));
    expect(shown.sort()).toEqual(["endpoint_cost", "model.gravity", "phases.0.q_min.0"]);
    expect(screen.getByTestId("check-state")).toHaveAttribute("data-count", "3");
    expect(screen.getByTestId("check-state")).toHaveTextContent("3 problems");
    expect(document.body.textContent).not.toMatch(/spec\.phases|Input should/);
    await new Promise((r) => setTimeout(r, 50));
    process.off("unhandledRejection", unhandled);
    expect(unhandled).not.toHaveBeenCalled();
  });

  it("a fraction in a whole-number field is not rounded: the form says so at the field and sends it as typed", async () => {
    const bodies: { spec: { phases: { intervals: number }[] } }[] = [];
    mockApi({
      "GET /tasks/presets": [PRESET],
      "GET /tasks/schema": TASK_SCHEMA,
      "POST /tasks/check": (_u: URL, body: { spec: { phases: { intervals: number }[] } }) => {
        bodies.push(body);
        return { valid: true, errors: [] };
      },
    });
    renderPage(<TaskEditorPage />, { route: "/tasks/new" });
    // a new task needs a name (a blank one is a problem the form names)
    fireEvent.change(await screen.findByLabelText("Name"), { target: { value: "a task" } });
    const intervals = await screen.findByLabelText("phase 1 intervals");
    fireEvent.change(intervals, { target: { value: "2.5" } });
    expect(await screen.findByText("must be a whole number")).toBeInTheDocument();
    expect(intervals).toHaveAttribute("aria-invalid", "true");
    await waitFor(() => expect(bodies.at(-1)?.spec.phases[0].intervals).toBe(2.5));
    expect(screen.getByTestId("check-state")).toHaveAttribute("data-count", "1");
    // a list item that is no number is marked at its field before the server is asked
    const qmin = screen.getByLabelText("phase 2 q min [rad]");
    fireEvent.blur(qmin, { target: { value: "0.1, abc" } });
    await waitFor(() => expect(qmin).toHaveAttribute("aria-invalid", "true"));
    expect(document.querySelector('[data-error-path="phases.1.q_min.1"]')).toHaveTextContent("joint 2: must be a number");
    expect(screen.getByTestId("check-state")).toHaveAttribute("data-count", "2");
  });
});

describe("schema forms", () => {
  const SCHEMA: JsonSchema = {
    type: "object",
    properties: {
      slices: { type: "integer", minimum: 1, maximum: 64, description: "slices of the cushion" },
      gravity: { type: "number", minimum: 0, maximum: 100, description: "gravitational acceleration [m/s^2]" },
    },
  };
  function Form() {
    const [value, setValue] = useState<Record<string, unknown>>({ slices: 4, gravity: 9.81 });
    const view = errorView([schemaLocalErrors(SCHEMA, value)], schemaFieldPaths(SCHEMA), (p) => schemaLabel(SCHEMA, p));
    return (
      <>
        <SchemaForm schema={SCHEMA} value={value} onChange={setValue} errors={view} />
        <output data-testid="value">{JSON.stringify(value)}</output>
        <output data-testid="count">{view.problems.length}</output>
      </>
    );
  }

  it("keeps 2.5 in an integer field (no silent rounding) and uses the schema's bounds", () => {
    render(<Form />);
    fireEvent.change(screen.getByLabelText(/^slices/), { target: { value: "2.5" } });
    expect(screen.getByTestId("value")).toHaveTextContent('"slices":2.5');
    expect(screen.getByText("must be a whole number")).toBeInTheDocument();
    fireEvent.change(screen.getByLabelText(/^gravity/), { target: { value: "1e308" } });
    expect(screen.getByText("must be at most 100")).toBeInTheDocument();
    expect(screen.getByTestId("count")).toHaveTextContent("2");
    expect(document.querySelectorAll(".field-error")).toHaveLength(2);
  });

  it("turns pydantic's messages into words", () => {
    expect(humanMessage("Input should be a valid number, unable to parse string as a number")).toBe("must be a number");
    expect(humanMessage("Input should be a valid integer, got a number with a fractional part")).toBe("must be a whole number");
    expect(humanMessage("Input should be greater than 0")).toBe("must be greater than 0");
    expect(humanMessage("Field required")).toBe("required");
    expect(humanMessage("Value error, phases must not overlap")).toBe("phases must not overlap");
  });
});

describe("names", () => {
  it("a blank new task is not valid: the name is named at its field; a name of spaces is refused before sending; a name is sent trimmed", async () => {
    const saves: { name: string }[] = [];
    mockApi({
      "GET /tasks/presets": [PRESET],
      "GET /tasks/schema": TASK_SCHEMA,
      "POST /tasks/check": { valid: true, errors: [] },
      "POST /tasks": (_url: URL, body: { name: string }) => (saves.push(body), jsonResponse({ detail: "stop here" }, 409)),
    });
    renderPage(<TaskEditorPage />, { route: "/tasks/new" });
    const name = await screen.findByLabelText("Name");
    await waitFor(() => expect(screen.getByTestId("check-state")).toHaveTextContent("1 problem"), { timeout: 3000 });
    expect(name).toHaveAttribute("aria-invalid", "true");
    expect(document.querySelector('[data-error-path="name"]')).toHaveTextContent("must not be empty");
    await userEvent.type(name, "   ");
    await userEvent.click(screen.getByRole("button", { name: "Create task" }));
    expect(document.querySelector('[data-error-path="name"]')).toHaveTextContent("must not be empty");
    await userEvent.type(name, "my task  ");
    await waitFor(() => expect(screen.getByTestId("check-state")).toHaveTextContent("valid"), { timeout: 3000 });
    await userEvent.click(screen.getByRole("button", { name: "Create task" }));
    await waitFor(() => expect(saves.map((b) => b.name)).toEqual(["my task"]));
  });
});

describe("a refused save", () => {
  it("its problem goes once the value is changed (the next inline validation answers for the new draft)", async () => {
    mockApi({
      "GET /tasks/presets": [PRESET],
      "GET /tasks/schema": TASK_SCHEMA,
      "POST /tasks/check": { valid: true, errors: [] },
      "POST /tasks": () => jsonResponse({ detail: [{ ...loc("spec", "phases", 0, "w_T"), msg: "Value error, the phase's weights do not fit the model" }] }, 422),
    });
    renderPage(<TaskEditorPage />, { route: "/tasks/new" });
    fireEvent.change(await screen.findByLabelText("Name"), { target: { value: "a task" } });
    await waitFor(() => expect(screen.getByTestId("check-state")).toHaveTextContent("valid"), { timeout: 3000 });
    await userEvent.click(screen.getByRole("button", { name: "Create task" }));
    expect(await screen.findByText("the phase's weights do not fit the model")).toBeInTheDocument();
    expect(screen.getByTestId("check-state")).toHaveTextContent("1 problem");
    const wT = screen.getByLabelText("phase 1 w_T");
    await userEvent.clear(wT);
    await userEvent.type(wT, "0.5");
    expect(screen.queryByText("the phase's weights do not fit the model")).toBeNull();
    expect(wT).toHaveAttribute("aria-invalid", "false");
    await waitFor(() => expect(screen.getByTestId("check-state")).toHaveTextContent("valid"), { timeout: 3000 });
  });
});

describe("unsaved edits", () => {
  it("a link away from a task editor nobody edited leaves without a question", async () => {
    mockApi({ "GET /tasks/presets": [PRESET], "GET /tasks/schema": TASK_SCHEMA, "POST /tasks/check": { valid: true, errors: [] } });
    const confirm = vi.spyOn(window, "confirm").mockReturnValue(false);
    try {
      renderPage(
        <>
          <Link to="/campaigns">Campaigns</Link>
          <TaskEditorPage />
        </>,
        { route: "/tasks/new", path: "/tasks/new" },
      );
      await screen.findByLabelText("Name");
      await userEvent.click(screen.getByRole("link", { name: "Campaigns" }));
      expect(confirm).not.toHaveBeenCalled(); // nothing edited: no question
      expect(await screen.findByTestId("elsewhere")).toBeInTheDocument();
    } finally {
      confirm.mockRestore();
    }
  });

  it("an edited task: cancel keeps the page, confirm leaves", async () => {
    mockApi({ "GET /tasks/presets": [PRESET], "GET /tasks/schema": TASK_SCHEMA, "POST /tasks/check": { valid: true, errors: [] } });
    const confirm = vi.spyOn(window, "confirm").mockReturnValue(false);
    try {
      renderPage(
        <>
          <Link to="/campaigns">Campaigns</Link>
          <TaskEditorPage />
        </>,
        { route: "/tasks/new", path: "/tasks/new" },
      );
      await userEvent.type(await screen.findByLabelText("Name"), "my task");
      await userEvent.click(screen.getByRole("link", { name: "Campaigns" }));
      expect(confirm).toHaveBeenCalledWith(LEAVE_QUESTION);
      expect(screen.queryByTestId("elsewhere")).toBeNull();
      expect(screen.getByLabelText("Name")).toHaveValue("my task");
      confirm.mockReturnValue(true);
      await userEvent.click(screen.getByRole("link", { name: "Campaigns" }));
      expect(await screen.findByTestId("elsewhere")).toBeInTheDocument();
    } finally {
      confirm.mockRestore();
    }
  });
});
