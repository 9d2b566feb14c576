import { useState } from "react";
import { describe, expect, it } from "vitest";
import { act, fireEvent, render, screen, waitFor, within } from "@testing-library/react";
import { TaskEditorPage } from "../pages/TaskEditorPage";
import { ChainPlayer, sampleAt } from "../components/ChainPlayer";
import { Plot } from "../components/Plot";
import { addLink, removeLink } from "./ChainEditor";
import { mockApi, renderPage } from "../test/utils";
import { initialPose, resolveModel } from "../lib/kinematics";
import { ChainDrawing } from "../components/ChainDrawing";
import openapi from "../../openapi.json";
import fixture from "../lib/kinematics.fixture.json";

// the API's real task schema (as GET /tasks/schema serves it: TaskSpec with its definitions)
// and its real model presets (the fixture holds what GET /tasks/model-presets serves)
const components = (openapi as unknown as { components: { schemas: Record<string, Record<string, unknown>> } }).components.schemas;
const TASK_SCHEMA = { ...components.TaskSpec, $defs: components };
const MODEL_PRESETS = ["head-neck-1dof", "head-neck-2dof", "trunk-neck-head-3dof"].map((key) => {
  const model = fixture.cases.find((c) => c.name === key)!.model;
  return { key, description: key, ndof: key === "head-neck-1dof" ? 1 : (model as { chain: { links: unknown[] } }).chain.links.length, model };
});
const PRESET = {
  key: "head-headrest-2phase",
  name: "head-headrest-2phase",
  description: "",
  spec: {
    name: "two",
    model: MODEL_PRESETS[0].model,
    initial: { q: null, qd: null, velocity: "given" },
    phases: [
      { name: "approach", duration: 1, intervals: 100, w_tau: 0.001, w_T: 0.0001, q_min: [0.05] },
      { name: "rest", duration: 1, intervals: 100, w_tau: 1, w_T: 1 },
    ],
    final: { velocity: "rest", q: null },
  },
};

type Spec = { model?: { preset?: string; chain?: { joints: { q0: number; q_min: number; q_max: number }[] } } };

function api() {
  return mockApi({
    "GET /tasks/presets": [PRESET],
    "GET /tasks/schema": TASK_SCHEMA,
    "GET /tasks/model-presets": MODEL_PRESETS,
    "GET /openapi.json": { paths: {} },
    // the API's rule: a chain joint's q0 lies within its range
    "POST /tasks/check": (_url: URL, body: { spec?: Spec }) => {
      const errors = (body.spec?.model?.chain?.joints ?? []).flatMap((j, i) =>
        j.q0 < j.q_min || j.q0 > j.q_max ? [{ loc: ["spec", "model", "chain", "joints", i, "q0"], field: `spec.model.chain.joints.${i}.q0`, msg: `Value error, ${j.q0} rad lies outside the joint range [${j.q_min}, ${j.q_max}] rad`, type: "value_error" }] : [],
      );
      return { valid: !errors.length, errors };
    },
  });
}

const drawing = () => screen.getByTestId("model-drawing");
/** whole pages in jsdom take a few seconds on a loaded 2-core machine */
const SLOW = 30_000;

describe("task editor: the model as a chain", () => {
  it("a chain preset: links and joints with units and ranges, a drawing that follows the values, the API's errors at their cell", async () => {
    api();
    renderPage(<TaskEditorPage />, { route: "/tasks/new" });
    // a new task needs a name (a blank one is a problem the form names)
    fireEvent.change(await screen.findByLabelText("Name"), { target: { value: "a task" } });
    await screen.findByLabelText(/^theta0/);
    // the 1-DOF preset: its own parameters, no chain group, each field once
    expect(screen.queryByTestId("chain-editor")).toBeNull();
    expect(screen.getAllByLabelText(/^gravity/)).toHaveLength(1);
    expect(drawing()).toHaveAttribute("data-links", "1");
    expect(drawing()).toHaveAttribute("data-q", "0.2320");

    fireEvent.change(screen.getByLabelText(/^preset/), { target: { value: "head-neck-2dof" } });
    const links = await screen.findByTestId("chain-links");
    expect(within(links).getAllByRole("row")).toHaveLength(3); // header + 2 links
    expect(links).toHaveTextContent("mass [kg]");
    expect(links).toHaveTextContent("> 0, ≤ 200"); // the schema's range of a link mass
    const joints = screen.getByTestId("chain-joints");
    expect(joints).toHaveTextContent("q0 (start) [rad]");
    expect(joints).toHaveTextContent("-1.571 to 1.571"); // ±π/2, to 4 digits
    // the 1-DOF parameters are gone: gravity is the chain's, once
    expect(screen.getAllByLabelText(/^gravity/)).toHaveLength(1);
    expect(screen.queryByLabelText(/^theta0/)).toBeNull();
    // the per-joint lists of the 1-DOF task are back to their defaults (2 joints now)
    expect(screen.getByLabelText("phase 1 q min [rad]")).toHaveValue("");
    expect(drawing()).toHaveAttribute("data-links", "2");
    expect(drawing()).toHaveAttribute("data-q", "0.2320,0.0000");
    const gap0 = Number(drawing().getAttribute("data-gap-mm"));

    // tilting the head back (C0/C1) brings it closer to the headrest: the picture follows at once
    fireEvent.change(screen.getByLabelText("joint 2 q0 (start) [rad]"), { target: { value: "0.3" } });
    expect(drawing()).toHaveAttribute("data-q", "0.2320,0.3000");
    expect(Number(drawing().getAttribute("data-gap-mm"))).toBeLessThan(gap0);

    // outside the joint's range: the API's message at that cell, by its path
    fireEvent.change(screen.getByLabelText("joint 2 q0 (start) [rad]"), { target: { value: "0.5" } });
    const message = await screen.findByText(/lies outside the joint range/, {}, { timeout: 10_000 });
    expect(message).toHaveAttribute("data-error-path", "model.chain.joints.1.q0");
    expect(within(joints).getByText(/lies outside the joint range/)).toBe(message);
    expect(screen.getByLabelText("joint 2 q0 (start) [rad]")).toHaveAttribute("aria-invalid", "true");
    expect(screen.getByTestId("check-state")).toHaveTextContent("1 problem");

    // a link more: inserted before the head, drawn at once
    fireEvent.click(screen.getByRole("button", { name: "Add link" }));
    expect(within(screen.getByTestId("chain-links")).getAllByRole("row")).toHaveLength(4);
    expect(drawing()).toHaveAttribute("data-links", "3");
  }, SLOW);

  it("the 1-DOF model as a user-defined chain keeps its picture", async () => {
    api();
    renderPage(<TaskEditorPage />, { route: "/tasks/new" });
    // a new task needs a name (a blank one is a problem the form names)
    fireEvent.change(await screen.findByLabelText("Name"), { target: { value: "a task" } });
    await screen.findByLabelText(/^theta0/);
    const before = drawing().getAttribute("data-head");
    fireEvent.change(screen.getByLabelText(/^preset/), { target: { value: "chain" } });
    await screen.findByTestId("chain-links");
    expect(screen.getByLabelText("link 1 mass [kg]")).toHaveValue("5");
    expect(drawing()).toHaveAttribute("data-head", before);
    await waitFor(() => expect(screen.getByTestId("check-state")).toHaveTextContent("valid"), { timeout: 10_000 });
  }, SLOW);
});

describe("adding and removing links", () => {
  const chain = (fixture.cases.find((c) => c.name === "trunk-neck-head-3dof")!.model as { chain: Record<string, unknown> }).chain;
  it("the headrest's touch pose and the head's link follow", () => {
    const withBody = { ...chain, contact_body: { link: 2, origin: null } };
    const added = addLink(withBody);
    expect((added.links as unknown[]).length).toBe(4);
    expect((added.headrest as { touch_q: number[] }).touch_q).toEqual([0.35, -0.04, 0, 0]);
    expect((added.contact_body as { link: number }).link).toBe(3);
    const removed = removeLink(added, 0);
    expect((removed.headrest as { touch_q: number[] }).touch_q).toEqual([-0.04, 0, 0]);
    expect((removed.contact_body as { link: number }).link).toBe(2);
    expect((removeLink(removed, 2).contact_body as { link: number | null }).link).toBeNull(); // the head's link removed: the last link carries it
  });
});

describe("the drawing of any value the form holds", () => {
  const chain = (fixture.cases.find((c) => c.name === "head-neck-2dof")!.model as { chain: { links: Record<string, unknown>[] } }).chain;
  it.each([1e308, 1e6])("a link %s m long is described, not drawn as a broken picture", (length) => {
    const huge = { preset: "chain", chain: { ...chain, links: chain.links.map((l, i) => (i === 0 ? { ...l, length } : l)) } };
    const resolved = resolveModel(huge)!;
    const { container } = render(<ChainDrawing chain={resolved} q={initialPose(resolved, null)} testId="model-drawing" />);
    expect(screen.getByTestId("model-drawing")).toHaveAttribute("data-drawable", "false");
    expect(container.querySelector("svg")).toBeNull();
    expect(container.textContent).not.toMatch(/Infinity|NaN/);
  });
  it("a model of ordinary size is drawn", () => {
    const resolved = resolveModel({ preset: "chain", chain })!;
    const { container } = render(<ChainDrawing chain={resolved} q={initialPose(resolved, null)} testId="model-drawing" />);
    expect(container.querySelector("svg[data-testid=model-drawing]")).not.toBeNull();
  });
});

describe("playback", () => {
  const model = fixture.cases.find((c) => c.name === "head-neck-1dof")!.model as Record<string, unknown>;
  const chain = resolveModel(model)!;
  const t = Array.from({ length: 41 }, (_, i) => i * 0.01);
  const q = t.map((s) => [0.232 + 0.3 * s]);
  // a force only where the head is pressed in (from t = 0.25 s)
  const fx = t.map((s) => (s >= 0.25 ? 100 * (s - 0.2) : 0));
  const fz = t.map(() => 0);

  function Harness() {
    const [i, setI] = useState(0);
    return (
      <>
        <ChainPlayer chain={chain} t={t} q={q} force={{ fx, fz }} index={i} setIndex={setI} />
        <Plot testId="force" traces={[{ x: t, y: fx }]} cursorX={t[i]} />
      </>
    );
  }

  it("the slider moves the chain, the force arrow and the plot's cursor together", () => {
    render(<Harness />);
    const svg = screen.getByTestId("chain-player-drawing");
    expect(svg).toHaveAttribute("data-q", "0.2320");
    expect(svg.querySelector("[data-part=force]")).toBeNull(); // no force before contact
    expect(screen.getByTestId("force")).toHaveAttribute("data-cursor", "0");
    fireEvent.change(screen.getByLabelText("Time"), { target: { value: "30" } });
    expect(svg).toHaveAttribute("data-q", (0.232 + 0.3 * 0.3).toFixed(4));
    expect(screen.getByTestId("force")).toHaveAttribute("data-cursor", String(t[30]));
    expect(svg.querySelector("[data-part=force]")).not.toBeNull();
    expect(svg).toHaveAttribute("data-force", (100 * (0.3 - 0.2)).toFixed(2));
    expect(Number(svg.getAttribute("data-gap-mm"))).toBeLessThan(0); // pressed in
    expect(screen.getByTestId("chain-player-time-value")).toHaveTextContent("t = 0.300 s");
  });

  it("playback runs to the end of the trajectory and moves the cursor with it", async () => {
    render(<Harness />);
    fireEvent.change(screen.getByLabelText("speed"), { target: { value: "1" } }); // real time: 0.4 s
    fireEvent.click(screen.getByRole("button", { name: "Play" }));
    expect(screen.getByTestId("chain-player")).toHaveAttribute("data-playing", "true");
    await waitFor(() => expect(screen.getByTestId("chain-player")).toHaveAttribute("data-playing", "false"), { timeout: 15_000 });
    expect(screen.getByTestId("chain-player")).toHaveAttribute("data-index", "40");
    expect(screen.getByTestId("force")).toHaveAttribute("data-cursor", String(t[40]));
    await act(async () => {});
  }, SLOW);

  it("sampleAt: the last sample at or before a time", () => {
    expect(sampleAt(t, -1)).toBe(0);
    expect(sampleAt(t, 0.055)).toBe(5);
    expect(sampleAt(t, 0.061)).toBe(6);
    expect(sampleAt(t, 9)).toBe(40);
  });
});
