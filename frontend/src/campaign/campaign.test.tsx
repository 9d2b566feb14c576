import { describe, expect, it } from "vitest";
import { render, screen, waitFor, within } from "@testing-library/react";
import userEvent from "@testing-library/user-event";
import Plotly from "plotly.js-basic-dist-min";
import { wrenchTraces } from "./ForcesPanel";
import { auxLawTraces, bestPossibleTraces, calibrationTraces, componentTraces, hasCalibration, rmseTraces } from "./RmsePlot";
import { forkDefaults, DEFAULT_FURTHER } from "./ForkDialog";
import { Controls } from "./Controls";
import { progressText } from "./queries";
import { Plot } from "../components/Plot";
import type { CampaignOut, IterationCurves } from "../api/types";
import { jsonResponse, mockApi, renderPage } from "../test/utils";

const wrench = (k: number) => ({ fx: [k, k + 1], fy: [0, 0], fz: [1, 2], mx: [0, 0], my: [0.1, 0.2], mz: [0, 0] });
const curves = (k: number): IterationCurves => ({ iteration: k, t: [0, 0.1], q: [[0.2], [0.3]], truth: wrench(k), predicted: wrench(k + 0.5), std: null });

describe("force overlay at paper scale", () => {
  it("200 iterations: colour by iteration on one scale, one colorbar, no legend entry per iteration", () => {
    const traces = wrenchTraces(Array.from({ length: 200 }, (_, i) => curves(i + 1)), ["fx", "fz"]);
    const lines = traces.filter((t) => t.mode === "lines");
    expect(lines).toHaveLength(200 * 2 * 2);
    expect(lines.every((t) => t.showlegend === false)).toBe(true);
    const bars = traces.filter((t) => (t.marker as { showscale?: boolean } | undefined)?.showscale);
    expect(bars).toHaveLength(1);
    expect(bars[0].marker).toMatchObject({ cmin: 1, cmax: 200 });
    // oracle traces: one colour per iteration, none repeated across far-apart iterations
    const oracleFx = lines.filter((t) => String(t.name).endsWith("fx oracle")).map((t) => (t.line as { color: string }).color);
    expect(new Set(oracleFx).size).toBeGreaterThan(190);
    expect(oracleFx[0]).not.toBe(oracleFx[8]); // the old palette of 8 colours repeated here
  });

  it("one iteration: a colour per component and a small legend (oracle / surrogate)", () => {
    const traces = wrenchTraces([curves(3)], ["fx", "fz"]);
    expect(traces.map((t) => t.name)).toEqual(["fx oracle", "fx surrogate", "fz oracle", "fz surrogate"]);
  });
});

describe("an ensemble's prediction with its spread", () => {
  const std = { fx: [0.5, 1], fy: [0, 0], fz: [0.25, 0], mx: [0, 0], my: [0.01, 0.02], mz: [0, 0] };
  it("one iteration: the mean dashed inside a shaded band of mean ± 2 std, drawn below the lines", () => {
    const traces = wrenchTraces([{ ...curves(3), std }], ["fx", "fz"]);
    expect(traces.map((t) => t.name)).toEqual(["fx −2σ", "fx surrogate ±2σ", "fx oracle", "fx surrogate (ensemble mean)", "fz −2σ", "fz surrogate ±2σ", "fz oracle", "fz surrogate (ensemble mean)"]);
    // predicted fx = [3.5, 4.5]: the band is [3.5 - 2 * 0.5, 4.5 - 2 * 1] .. [3.5 + 1, 4.5 + 2]
    expect(traces[0].y).toEqual([2.5, 2.5]);
    expect(traces[1].y).toEqual([4.5, 6.5]);
    expect(traces[1].fill).toBe("tonexty"); // filled down to the lower edge
    expect(traces[0].showlegend).toBe(false);
    // a zero std (fz at t = 0.1) is a band of zero width at the mean
    expect(traces[4].y).toEqual([0.5, 2]);
    expect(traces[5].y).toEqual([1.5, 2]);
  });

  it("a single model (K = 1) and an overlay of iterations draw no band", () => {
    expect(wrenchTraces([curves(3)], ["fx"]).some((t) => t.fill)).toBe(false);
    expect(wrenchTraces([{ ...curves(3), std }, { ...curves(4), std }], ["fx"]).some((t) => t.fill)).toBe(false);
  });

  it("calibration per iteration in percent, K = 1 iterations (null) left out", () => {
    const p = (k: number, calibration: number | null) => ({ iteration: k, status: "succeeded", force_rmse: 1, moment_rmse: 0.1, quarantined: false, calibration });
    expect(hasCalibration([p(1, null)])).toBe(false);
    const [trace] = calibrationTraces([p(1, 0.5), p(2, null), p(3, 0.95)]);
    expect(trace.x).toEqual([1, 3]);
    expect(trace.y).toEqual([50, 95]);
  });

  it("the held-out suite's calibration as a dashed line beside the in-loop one", () => {
    const p = (k: number, calibration: number | null, validation_calibration: number | null) => ({ iteration: k, status: "succeeded", force_rmse: 1, moment_rmse: 0.1, quarantined: false, calibration, validation_calibration });
    expect(calibrationTraces([p(1, 0.5, null)])).toHaveLength(1); // not evaluated yet: no dashed line
    const traces = calibrationTraces([p(1, 0.5, 0.25), p(2, 0.75, null), p(3, 0.9, 0.625)]);
    expect(traces).toHaveLength(2);
    const [inLoop, suite] = traces;
    expect((inLoop.line as { dash?: string }).dash).toBeUndefined();
    expect((suite.line as { dash?: string }).dash).toBe("dash");
    expect(suite.x).toEqual([1, 3]);
    expect(suite.y).toEqual([25, 62.5]);
    expect(hasCalibration([p(1, null, 0.8)])).toBe(true); // an ensemble scored only on the suite so far
  });
});

describe("RMSE per component", () => {
  it("draws one component's RMSE in the loop, in contact and on the suite, with its unit", () => {
    const p = (k: number, suite: boolean) => ({
      iteration: k,
      status: "succeeded",
      force_rmse: 5,
      moment_rmse: 0.5,
      quarantined: false,
      components: { fx: k, fz: 10 * k, my: 0.1 * k, fx_contact: 2 * k, fz_contact: null, my_contact: 0.2 },
      validation_components: suite ? { fx: 3 * k, fz: 20, my: 0.3, fx_contact: 4 * k, fz_contact: 21, my_contact: 0.4 } : null,
    });
    const points = [p(1, true), p(2, false), p(3, true)];
    const fz = componentTraces(points, "fz");
    expect(fz.map((t) => t.name)).toEqual(["fz RMSE [N]", "fz RMSE in contact [N]", "fz RMSE, held-out suite [N]", "fz RMSE in contact, held-out suite [N]"]);
    expect(fz[0].y).toEqual([10, 20, 30]);
    expect(fz[1].y).toEqual([null, null, null]); // none in contact: a gap, not 0
    expect(fz[2].x).toEqual([1, 3]);
    expect((fz[2].line as { dash: string }).dash).toBe("dash");
    const my = componentTraces(points, "my");
    expect(my[0].name).toBe("my RMSE [N m]");
    expect(my[3].y).toEqual([0.4, 0.4]);
    expect(componentTraces(points, "fx", "oracle")[0].x).toEqual([null, null, null]); // no oracle calls recorded
  });
});

describe("the auxiliary law's error on the suite", () => {
  it("is a horizontal reference line across the campaign's own iterations, per vector or component", () => {
    const p = (k: number, inherited = false) => ({ iteration: k, status: "succeeded", force_rmse: 1, moment_rmse: 0.1, quarantined: false, inherited });
    const points = [p(1, true), p(2), p(3), p(5)];
    const aux = { force_rmse: 40.2, moment_rmse: 4.6, components: { fx: 32.3, fz: 23.9, my: 4.6, fz_contact: null } };
    const lines = auxLawTraces(points, aux);
    expect(lines.map((t) => t.name)).toEqual(["auxiliary law, held-out suite: force [N]", "auxiliary law, held-out suite: moment [N m]"]);
    expect(lines[0].x).toEqual([2, 5]); // the campaign's own iterations, not the inherited one
    expect(lines[0].y).toEqual([40.2, 40.2]);
    expect(auxLawTraces(points, aux, "iteration", "fz")[0].y).toEqual([23.9, 23.9]);
    expect(auxLawTraces(points, aux, "iteration", "fz_contact")).toEqual([]); // no value: no line
    expect(auxLawTraces(points, null)).toEqual([]);
    expect(auxLawTraces([p(4)], aux)[0].x).toEqual([4, 5]); // one iteration: a short line, still visible
  });
});

describe("best-possible line", () => {
  it("puts each budget at that many oracle calls, or at the model trained on them, and skips budgets not reached", () => {
    const p = (k: number, calls: number) => ({ iteration: k, status: "succeeded", force_rmse: 1, moment_rmse: 0.1, quarantined: false, cumulative_oracle_calls: calls });
    // a batch campaign: 4 calls per iteration
    const points = [p(1, 4), p(2, 8), p(3, 12)];
    const pt = (budget: number, f: number) => ({ budget, force_rmse: f, moment_rmse: f / 10, components: { fx: f / 2, fz: budget === 8 ? null : f } });
    const line = { replays: 16, points: [pt(4, 9), pt(8, 7), pt(16, 6)] };
    const [force, moment] = bestPossibleTraces(points, line, "oracle");
    expect(force.x).toEqual([4, 8, 16]);
    expect(force.y).toEqual([9, 7, 6]);
    expect(moment.y).toEqual([0.9, 0.7, 0.6]);
    // on the iteration axis: model k + 1 is the first trained on the calls of iteration k; 16 calls not reached
    const [onIterations] = bestPossibleTraces(points, line, "iteration");
    expect(onIterations.x).toEqual([2, 3]);
    expect(onIterations.y).toEqual([9, 7]);
    // one component; a budget without the component is left out, not drawn at 0
    expect(bestPossibleTraces(points, line, "oracle", "fz")[0].x).toEqual([4, 16]);
    expect(bestPossibleTraces(points, line, "wall")).toEqual([]);
    expect(bestPossibleTraces(points, null)).toEqual([]);
  });
});

describe("RMSE plot of a fork", () => {
  it("draws the inherited iterations grey and its own in colour", () => {
    const p = (k: number, inherited: boolean) => ({ iteration: k, status: "succeeded", force_rmse: 1 / (k + 1), moment_rmse: 0.1, quarantined: false, inherited });
    const traces = rmseTraces([p(0, true), p(1, true), p(2, true), p(3, false), p(4, false)]);
    const grey = traces.filter((t) => String(t.name).includes("inherited"));
    expect(grey).toHaveLength(2);
    expect(grey[0].x).toEqual([0, 1, 2, 3]); // joined to the fork's first iteration
    expect((grey[0].line as { color: string }).color).toBe("#a3a9b6");
    const own = traces.find((t) => t.name === "force RMSE [N]")!;
    expect(own.x).toEqual([3, 4]);
    expect(traces.some((t) => String(t.name).includes("in contact"))).toBe(false); // none given: no trace
  });

  it("adds the in-contact RMSE as dotted lines (the held-out suite is dashed) where the series has it", () => {
    const p = (k: number) => ({ iteration: k, status: "succeeded", force_rmse: 1, moment_rmse: 0.1, force_rmse_contact: k === 1 ? null : 2, moment_rmse_contact: 0.3, quarantined: false });
    const traces = rmseTraces([p(1), p(2)]);
    const contact = traces.find((t) => t.name === "force RMSE in contact [N]")!;
    expect(contact.y).toEqual([null, 2]);
    expect((contact.line as { dash: string }).dash).toBe("dot");
    expect(traces.find((t) => t.name === "moment RMSE in contact [N m]")!.y).toEqual([0.3, 0.3]);
  });
});

describe("RMSE plot with the held-out validation suite", () => {
  it("draws the generalisation error dashed beside the in-loop RMSE, only where a model was evaluated", () => {
    const p = (k: number, v: number | null) => ({ iteration: k, status: "succeeded", force_rmse: 1, moment_rmse: 0.1, validation_force_rmse: v, validation_moment_rmse: v === null ? null : v / 10, quarantined: false });
    const traces = rmseTraces([p(1, 9), p(2, 8), p(3, null)]);
    const held = traces.filter((t) => String(t.name).includes("held-out suite"));
    expect(held.map((t) => t.name)).toEqual(["force RMSE, held-out suite [N]", "moment RMSE, held-out suite [N m]"]);
    expect(held[0].x).toEqual([1, 2]);
    expect(held[0].y).toEqual([9, 8]);
    expect((held[0].line as { dash: string }).dash).toBe("dash");
    expect(rmseTraces([p(1, null)]).some((t) => String(t.name).includes("held-out"))).toBe(false);
  });
});

describe("plot toolbar", () => {
  it("keeps the PNG download and has no link or upload to another host", async () => {
    render(<Plot traces={[{ x: [1], y: [2], type: "scatter" }]} exportName="rmse" testId="p" />);
    await waitFor(() => expect(Plotly.react).toHaveBeenCalled());
    const config = (Plotly.react as unknown as { mock: { calls: unknown[][] } }).mock.calls.at(-1)![3] as Record<string, unknown>;
    expect(config).toMatchObject({ showSendToCloud: false, plotlyServerURL: "", displaylogo: false, toImageButtonOptions: { format: "png", filename: "rmse", scale: 2 } });
    expect(config.modeBarButtonsToRemove).toContain("sendChartToCloud");
  });
});

const campaign = (status: string, k: number, max: number | null): CampaignOut =>
  ({
    id: 7,
    campaign: { id: 7, name: "baseline", status, current_iteration: k, source_campaign_id: null, source_iteration: null },
    config: { stopping: { max_iterations: max }, preliminary: {}, settings: {}, policies: {} },
    latest_metrics: null,
  }) as unknown as CampaignOut;

describe("fork", () => {
  it("continues the campaign: forks at the latest finished iteration and runs more iterations, never k / N with k > N", () => {
    // the defect: a finished 8-iteration campaign forked with the defaults ran one iteration and showed "9 / 8"
    expect(forkDefaults(campaign("completed", 8, 8), 8)).toEqual({ k: 8, further: DEFAULT_FURTHER });
    expect(forkDefaults(campaign("paused", 5, 20), 5)).toEqual({ k: 5, further: 15 });
    expect(progressText(9, 8)).toBe("9");
    expect(progressText(3, 8)).toBe("3 / 8");
  });

  it("the dialog explains a fork, shows the iteration limit it will use and sends it", async () => {
    const { calls } = mockApi({
      "GET /openapi.json": { components: { schemas: { StoppingRules: { type: "object", properties: { max_iterations: { anyOf: [{ type: "integer", minimum: 1 }, { type: "null" }] } } } } } },
      "POST /campaigns/7/fork": () => jsonResponse({ ...campaign("running", 9, 18), id: 8 }, 201),
    });
    renderPage(<Controls campaign={campaign("completed", 8, 8)} lastIteration={8} />, { route: "/campaigns/7", path: "/campaigns/7" });
    // jsdom has no <dialog>: open it by hand as the browser would
    HTMLDialogElement.prototype.showModal ??= function (this: HTMLDialogElement) {
      this.open = true;
    };
    HTMLDialogElement.prototype.close ??= function (this: HTMLDialogElement) {
      this.open = false;
    };
    await userEvent.click(screen.getByRole("button", { name: "Fork…" }));
    const dialog = screen.getByRole("dialog", { hidden: true });
    expect(within(dialog).getByTestId("fork-explanation")).toHaveTextContent("continues the loop from iteration k + 1");
    expect(within(dialog).getByLabelText("Fork after iteration k")).toHaveValue("8");
    expect(within(dialog).getByLabelText("Further iterations")).toHaveValue("10");
    expect(within(dialog).getByTestId("fork-limit")).toHaveTextContent("the fork runs iterations 9 to 18 (stopping rule max_iterations = 18)");
    await waitFor(() => expect(within(dialog).getByLabelText(/^max_iterations/)).toHaveValue("18"));
    await userEvent.clear(within(dialog).getByLabelText("Further iterations"));
    await userEvent.type(within(dialog).getByLabelText("Further iterations"), "4");
    expect(within(dialog).getByLabelText(/^max_iterations/)).toHaveValue("12");
    await userEvent.click(within(dialog).getByRole("button", { name: "Fork" }));
    await waitFor(() => expect(calls.some((c) => c.path === "/campaigns/7/fork")).toBe(true));
    const body = calls.find((c) => c.path === "/campaigns/7/fork")!.body as { iteration: number; stopping: { max_iterations: number }; start: boolean };
    expect(body).toMatchObject({ iteration: 8, stopping: { max_iterations: 12 }, start: true });
    await waitFor(() => expect(screen.getByTestId("elsewhere")).toBeInTheDocument()); // navigated to the fork
  });
});
