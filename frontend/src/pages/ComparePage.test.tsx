import { describe, expect, it } from "vitest";
import { screen, waitFor } from "@testing-library/react";
import userEvent from "@testing-library/user-event";
import { ComparePage } from "./ComparePage";
import { mockApi, renderPage } from "../test/utils";

const summary = (id: number, name: string) => ({ id, name, status: "completed", owner: "a", task: "t", task_version: 1, oracle: "o", oracle_type: "aux-penalty", current_iteration: 3, max_iterations: 3, force_rmse: 1, moment_rmse: 0.1 });
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

  it("asks for two campaigns when fewer are selected", async () => {
    mockApi({ "GET /campaigns": [summary(1, "soft")] });
    renderPage(<ComparePage />, { route: "/compare?ids=1" });
    expect(await screen.findByText("Pick at least two campaigns")).toBeInTheDocument();
  });
});
