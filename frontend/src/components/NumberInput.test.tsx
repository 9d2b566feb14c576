/**
 * Number fields keep exactly what the user types, key by key, in every kind of form and table:
 * the schema-generated forms (task model, oracle, new campaign, fork), the phases table, the
 * chain tables, the exploration section and the scenario ranges. Text that is no number is
 * named at its field.
 */
import { useState } from "react";
import { describe, expect, it } from "vitest";
import { render, screen, within } from "@testing-library/react";
import userEvent from "@testing-library/user-event";
import { readNumber, NumberInput, type NumberText } from "./NumberInput";
import { parseNumberList, SchemaForm, schemaFieldPaths, schemaLocalErrors, type JsonSchema } from "./SchemaForm";
import { errorView, schemaLabel } from "../lib/formErrors";
import { PhasesTable, phaseFieldPaths, phaseLocalErrors, type PhaseRow } from "../task/PhasesTable";
import { ChainEditor, chainFieldPaths, chainLocalErrors } from "../task/ChainEditor";
import { ScenarioRanges, rangeFieldPaths, rangeLocalErrors, type RangeRow } from "../task/ScenarioRanges";
import { ExplorationSection } from "../campaign/ExplorationSection";
import type { ConfigDraft } from "../campaign/ConfigSections";
import openapi from "../../openapi.json";
import fixture from "../lib/kinematics.fixture.json";

const TYPED = ["0.0005", "0.3001", "0.0025", "1e-4", "1e308", "-0.005", "0.05", "0.001"];
const components = (openapi as unknown as { components: { schemas: Record<string, JsonSchema> } }).components.schemas;
const ROOT: JsonSchema = { ...components.TaskSpec, $defs: components };

/** Type `text` key by key into an emptied field: after every key the field shows exactly the keys typed so far, and the form holds their number. */
async function typeKeyByKey(input: HTMLElement, text: string, held: () => unknown) {
  const user = userEvent.setup();
  await user.clear(input);
  for (let i = 1; i <= text.length; i++) {
    await user.type(input, text[i - 1]);
    // the text itself (whatever the input's type), so a rewritten field fails here
    expect((input as HTMLInputElement).value).toBe(text.slice(0, i));
  }
  expect(held()).toBe(Number(text));
}

describe("readNumber", () => {
  it("reads decimal numbers as typed and keeps anything else as text", () => {
    expect(readNumber("")).toBeUndefined();
    expect(readNumber("  ")).toBeUndefined();
    expect(readNumber("0.")).toBe(0);
    expect(readNumber("0.0005")).toBe(0.0005);
    expect(readNumber("1e308")).toBe(1e308);
    expect(readNumber("-.5")).toBe(-0.5);
    expect(readNumber("1e")).toBe("1e");
    expect(readNumber("--5")).toBe("--5");
    expect(readNumber("abc")).toBe("abc");
    expect(readNumber("0x10")).toBe("0x10");
    expect(readNumber("Infinity")).toBe("Infinity");
  });

  it("reads a list field's items the same way: no hex or other silent rewrite", () => {
    expect(parseNumberList("0.1, 0x10, abc, 1e-4")).toEqual([0.1, "0x10", "abc", 0.0001]);
    expect(parseNumberList(" , ")).toBeNull();
  });

  it("shows a value set from outside, and keeps the typed text while it reads as the value", async () => {
    function Harness() {
      const [v, setV] = useState<NumberText>(1);
      return (
        <>
          <NumberInput aria-label="x" value={v} onChange={setV} />
          <button type="button" onClick={() => setV(2.5)}>
            reset
          </button>
        </>
      );
    }
    render(<Harness />);
    const x = screen.getByLabelText("x");
    await typeKeyByKey(x, "0.30", () => Number((x as HTMLInputElement).value));
    await userEvent.click(screen.getByRole("button", { name: "reset" }));
    expect(x).toHaveValue("2.5");
  });
});

const AUX: JsonSchema = {
  type: "object",
  properties: {
    k: { type: "number", default: 6e6, exclusiveMinimum: 0 },
    output_dt: { anyOf: [{ type: "number" }, { type: "null" }], default: null },
    steps: { type: "integer", default: 10, minimum: 1 },
  },
};

function SchemaHarness({ record }: { record: (v: Record<string, unknown>) => void }) {
  const [v, setV] = useState<Record<string, unknown>>({ k: 6e6, output_dt: null, steps: 10 });
  const errors = errorView([schemaLocalErrors(AUX, v)], schemaFieldPaths(AUX), (p) => schemaLabel(AUX, p));
  return <SchemaForm schema={AUX} value={v} onChange={(next) => (record(next), setV(next))} errors={errors} />;
}

describe("schema-generated forms (task model, oracle, new campaign, fork)", () => {
  it.each(TYPED)("keeps %s typed key by key", async (text) => {
    const held = { value: {} as Record<string, unknown> };
    render(<SchemaHarness record={(v) => (held.value = v)} />);
    await typeKeyByKey(screen.getByLabelText(/^output_dt/), text, () => held.value.output_dt);
  });

  it.each(["abc", "1e", "--5"])("names %s at its field as no number, and keeps it", async (text) => {
    const held = { value: {} as Record<string, unknown> };
    render(<SchemaHarness record={(v) => (held.value = v)} />);
    const k = screen.getByLabelText(/^k/);
    await userEvent.clear(k);
    await userEvent.type(k, text);
    expect(k).toHaveValue(text);
    expect(k).toHaveAttribute("aria-invalid", "true");
    expect(k.closest(".field")).toHaveTextContent("must be a number");
  });

  it("a cleared nullable field is null, and 1e309 is no finite number", async () => {
    const held = { value: {} as Record<string, unknown> };
    render(<SchemaHarness record={(v) => (held.value = v)} />);
    const dt = screen.getByLabelText(/^output_dt/);
    await userEvent.type(dt, "1e309");
    expect(dt).toHaveValue("1e309");
    expect(dt.closest(".field")).toHaveTextContent("must be a finite number");
    await userEvent.clear(dt);
    expect(held.value.output_dt).toBeNull();
  });
});

describe("the phases table", () => {
  function Harness({ record }: { record: (v: PhaseRow[]) => void }) {
    const [phases, setPhases] = useState<PhaseRow[]>([{ name: "approach", duration: 0.3, intervals: 20, w_tau: 1, w_T: 0 }]);
    const errors = errorView([phaseLocalErrors(phases, components.PhaseSpec, ROOT)], phaseFieldPaths(phases), (p) => p);
    return <PhasesTable phases={phases} onChange={(next) => (record(next), setPhases(next))} errors={errors} />;
  }

  it.each(TYPED)("keeps %s typed key by key in w_T", async (text) => {
    const held = { phases: [] as PhaseRow[] };
    render(<Harness record={(v) => (held.phases = v)} />);
    await typeKeyByKey(screen.getByLabelText("phase 1 w_T"), text, () => held.phases[0].w_T);
  });

  it("names text that is no number at its cell", async () => {
    const held = { phases: [] as PhaseRow[] };
    render(<Harness record={(v) => (held.phases = v)} />);
    const cell = screen.getByLabelText("phase 1 duration [s]");
    await userEvent.clear(cell);
    await userEvent.type(cell, "--5");
    expect(cell).toHaveValue("--5");
    expect(cell).toHaveAttribute("aria-invalid", "true");
    expect(cell.closest("td")).toHaveTextContent("must be a number");
  });
});

describe("the chain tables", () => {
  const chain0 = structuredClone((fixture.cases.find((c) => c.name === "head-neck-2dof")!.model as { chain: Record<string, unknown> }).chain);
  function Harness({ record }: { record: (v: Record<string, unknown>) => void }) {
    const [chain, setChain] = useState<Record<string, unknown>>(chain0);
    const errors = errorView([chainLocalErrors(chain, ROOT)], chainFieldPaths(chain, ROOT), (p) => p);
    return <ChainEditor chain={chain} onChange={(next) => (record(next), setChain(next))} root={ROOT} errors={errors} />;
  }
  const link = (held: { chain: Record<string, unknown> }, i: number) => (held.chain.links as Record<string, unknown>[])[i];
  const joint = (held: { chain: Record<string, unknown> }, i: number) => (held.chain.joints as Record<string, unknown>[])[i];

  it.each(TYPED)("keeps %s typed key by key in a link's mass and a joint's q0", async (text) => {
    const held = { chain: {} as Record<string, unknown> };
    render(<Harness record={(v) => (held.chain = v)} />);
    await typeKeyByKey(within(screen.getByTestId("chain-links")).getByLabelText("link 1 mass [kg]"), text, () => link(held, 0).mass);
    await typeKeyByKey(within(screen.getByTestId("chain-joints")).getByLabelText("joint 2 q0 (start) [rad]"), text, () => joint(held, 1).q0);
  });

  it("names text that is no number at its cell", async () => {
    const held = { chain: {} as Record<string, unknown> };
    render(<Harness record={(v) => (held.chain = v)} />);
    const cell = screen.getByLabelText("link 2 length [m]");
    await userEvent.clear(cell);
    await userEvent.type(cell, "1e");
    expect(cell).toHaveValue("1e");
    expect(cell.closest("td")).toHaveTextContent("must be a number");
  });
});

describe("the exploration section of a new campaign", () => {
  it.each(TYPED)("keeps %s typed key by key in the stopping threshold", async (text) => {
    const held = { value: {} as ConfigDraft };
    function Harness({ record }: { record: (v: ConfigDraft) => void }) {
      const [v, setV] = useState<ConfigDraft>({ settings: { strategy: "ensemble-disagreement", batch: 2, candidates: 4 }, stopping: { min_disagreement: null } });
      return <ExplorationSection value={v} onChange={(next) => (record(next), setV(next))} errors={errorView([], [], (p) => p)} />;
    }
    render(<Harness record={(v) => (held.value = v)} />);
    await typeKeyByKey(screen.getByLabelText("Stopping threshold [N]"), text, () => held.value.stopping.min_disagreement);
  });
});

describe("scenario ranges", () => {
  function Harness({ record }: { record: (v: RangeRow[]) => void }) {
    const [ranges, setRanges] = useState<RangeRow[]>([{ parameter: "initial.q.0", low: 0.15, high: 0.3 }]);
    const errors = errorView([rangeLocalErrors(ranges)], rangeFieldPaths(ranges), (p) => p);
    return <ScenarioRanges ranges={ranges} onChange={(r) => (record(r ?? []), setRanges(r ?? []))} errors={errors} preview={undefined} previewing={false} onPreview={() => {}} canPreview={false} />;
  }

  it.each(TYPED)("keeps %s typed key by key in low", async (text) => {
    const held = { ranges: [] as RangeRow[] };
    render(<Harness record={(v) => (held.ranges = v)} />);
    await typeKeyByKey(screen.getByLabelText("range 1 low"), text, () => held.ranges[0].low);
  });

  it("low above high is named at high while typing, and the message goes once it is fixed", async () => {
    const held = { ranges: [] as RangeRow[] };
    render(<Harness record={(v) => (held.ranges = v)} />);
    const low = screen.getByLabelText("range 1 low");
    await userEvent.clear(low);
    await userEvent.type(low, "0.5");
    const high = screen.getByLabelText("range 1 high");
    expect(high).toHaveAttribute("aria-invalid", "true");
    expect(high.closest("td")).toHaveTextContent("must be at least low");
    await userEvent.clear(low);
    await userEvent.type(low, "0.2");
    expect(high).toHaveAttribute("aria-invalid", "false");
    expect(screen.queryByText(/must be at least low/)).toBeNull();
    expect(held.ranges[0]).toEqual({ parameter: "initial.q.0", low: 0.2, high: 0.3 });
  });
});
