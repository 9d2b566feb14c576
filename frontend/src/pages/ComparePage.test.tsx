import { describe, expect, it } from "vitest";
import { screen, waitFor } from "@testing-library/react";
import userEvent from "@testing-library/user-event";
import Plotly from "plotly.js-basic-dist-min";
import { ComparePage } from "./ComparePage";
import { mockApi, renderPage } from "../test/utils";

const summary = (id: number, name: string) => ({ id, name, status: "completed", owner: "a", task: "t", task_version: 1, oracle: "o", oracle_type: "aux-penalty", current_iteration: 3, max_iterations: 3, force_rmse: 1, moment_rmse: 0.1 });
/** The traces last handed to Plotly for the plot with this test id. */
const plotted = (testId: string) => (Plotly.react as unknown as { mock: { calls: unknown[][] } }).mock.calls.filter((c) => (c[0] as HTMLElement).dataset.testid === testId).pop()?.[1] as { name: string; x: unknown[]; y: unknown[] }[] | undefined;
const metrics = (n: number) => Array.from({ length: n }, (_, i) => ({ iteration_index: i + 1, force_rmse: 1 / (i + 1), moment_rmse: 0.1 / (i + 1), extra: {} }));

describe("compare", () => {
  it("overlays the RMSE curves of the campaigns in the URL, one trace each", async () => {
    mockApi({
      "GET /campaigns": [summary(1, "soft"), summary(2, "stiff"), summary(3, "other")],
      "GET /campaigns/1/metrics": metrics(3),
      "GET /campaigns/2/metrics": metrics(5),
      "GET /campaigns/3/metrics": metrics(2),
    });
    renderPage(<ComparePage />, { route: "/compare?ids=1,2" });
    await waitFor(() => expect(screen.getByTestId("compare-force")).toHaveAttribute("data-points", "8"));
    expect(screen.getByTestId("compare-moment")).toHaveAttribute("data-traces", "2");
    expect(screen.getByTestId("compare-force")).toHaveAttribute("data-log-y", "true");
    await userEvent.click(screen.getByLabelText(/other/));
    await waitFor(() => expect(screen.getByTestId("compare-force")).toHaveAttribute("data-traces", "3"));
  });

  it("shows one component's RMSE of every campaign, in the loop and on the suite, with the auxiliary law's line once per suite", async () => {
    const row = (k: number, components: Record<string, number | null> | null) => ({ iteration_index: k, force_rmse: 1 / k, moment_rmse: 0.1 / k, components, extra: {} });
    const suite = { id: 5, status: "complete", motions_done: 4, n_motions: 4, shared_by: 2 };
    const auxLaw = { force_rmse: 40.2, moment_rmse: 4.6, components: { fx: 32.3, fz: 23.9, my: 4.6 } };
    const point = (k: number, fz: number) => ({ iteration_index: k, model_version_id: 10 + k, force_rmse: 2, moment_rmse: 0.2, components: { fx: 1, fz }, per_motion: [] });
    mockApi({
      "GET /campaigns": [summary(1, "soft"), summary(2, "stiff")],
      "GET /campaigns/1/metrics": [1, 2, 3].map((k) => row(k, { fx: k, fz: 10 * k, fz_contact: 11 * k })),
      // iteration 2 was stored before the components were recorded
      "GET /campaigns/2/metrics": [row(1, { fx: 0.5, fz: 5 }), row(2, null), row(3, { fx: 0.7, fz: 7 })],
      "GET /campaigns/1/validation": { suite, points: [point(1, 12), point(3, 9)], aux_law: auxLaw },
      "GET /campaigns/2/validation": { suite, points: [point(3, 8)], aux_law: auxLaw },
    });
    renderPage(<ComparePage />, { route: "/compare?ids=1,2" });
    await waitFor(() => expect(plotted("compare-force")?.map((t) => t.name)).toContain("auxiliary law, held-out suite: force [N]"));
    expect(screen.getByTestId("rmse-quantity")).toHaveValue("vector");
    await userEvent.selectOptions(screen.getByTestId("rmse-quantity"), "fz");
    expect(screen.getByTestId("location").getAttribute("data-search")).toContain("rmse=fz");
    expect(screen.queryByTestId("compare-force")).not.toBeInTheDocument();
    expect(await screen.findByTestId("compare-fz")).toHaveAttribute("aria-label", "fz RMSE [N]");
    const traces = plotted("compare-fz")!;
    expect(traces.map((t) => t.name)).toEqual(["soft: fz RMSE [N]", "soft: fz RMSE, held-out suite [N]", "stiff: fz RMSE [N]", "stiff: fz RMSE, held-out suite [N]", "auxiliary law, held-out suite: fz [N]"]);
    expect(traces.map((t) => t.y)).toEqual([[10, 20, 30], [12, 9], [5, null, 7], [8], [23.9, 23.9]]); // the row without components: a gap, not 0
    expect(traces.map((t) => t.x)).toEqual([[1, 2, 3], [1, 3], [1, 2, 3], [3], [1, 3]]);
    // back to the vectors: the parameter leaves the URL
    await userEvent.selectOptions(screen.getByTestId("rmse-quantity"), "vector");
    expect(await screen.findByTestId("compare-moment")).toBeInTheDocument();
    expect(screen.getByTestId("location").getAttribute("data-search")).not.toContain("rmse=");
  });

  it("opens on the component in the URL, with the auxiliary law's line per distinct suite", async () => {
    const row = (k: number, fz: number) => ({ iteration_index: k, force_rmse: 1, moment_rmse: 0.1, components: { fz }, extra: {} });
    const series = (id: number, fz: number) => ({ suite: { id, status: "complete", motions_done: 4, n_motions: 4, shared_by: 1 }, points: [], aux_law: { force_rmse: 40, moment_rmse: 4, components: { fz } } });
    mockApi({
      "GET /campaigns": [summary(1, "soft"), summary(2, "stiff")],
      "GET /campaigns/1/metrics": [row(1, 3), row(2, 2)],
      "GET /campaigns/2/metrics": [row(1, 4), row(2, 1)],
      "GET /campaigns/1/validation": series(5, 20),
      "GET /campaigns/2/validation": series(6, 30),
    });
    renderPage(<ComparePage />, { route: "/compare?ids=1,2&rmse=fz" });
    await waitFor(() => expect(plotted("compare-fz")?.filter((t) => t.name.startsWith("auxiliary law")).map((t) => [t.name, t.y])).toEqual([
      ["auxiliary law, held-out suite of soft: fz [N]", [20, 20]],
      ["auxiliary law, held-out suite of stiff: fz [N]", [30, 30]],
    ]));
    expect(screen.getByTestId("rmse-quantity")).toHaveValue("fz");
    expect(plotted("compare-fz")!.slice(0, 2).map((t) => t.y)).toEqual([[3, 2], [4, 1]]);
  });

  it("asks for two campaigns when fewer are selected", async () => {
    mockApi({ "GET /campaigns": [summary(1, "soft")] });
    renderPage(<ComparePage />, { route: "/compare?ids=1" });
    expect(await screen.findByText("Pick at least two campaigns")).toBeInTheDocument();
  });
});
