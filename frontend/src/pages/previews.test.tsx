import { describe, expect, it } from "vitest";
import { fireEvent, screen, waitFor } from "@testing-library/react";
import userEvent from "@testing-library/user-event";
import { TaskEditorPage } from "./TaskEditorPage";
import { OracleEditorPage } from "./OracleEditorPage";
import { jsonResponse, mockApi, renderPage } from "../test/utils";

const SPEC = { name: "two", model: { mass: 5 }, phases: [{ name: "approach", duration: 0.2, intervals: 2, w_tau: 0.001, w_T: 0.0001 }, { name: "rest", duration: 0.2, intervals: 2, w_tau: 1, w_T: 1 }] };
const TASK = { id: 1, owner_id: 1, name: "two-phase", description: "", version: 1, version_id: 11, spec: SPEC, created_at: "2026-11-21T22:00:00Z", updated_at: "2026-11-21T22:00:00Z" };
const TASK_ROUTES = {
  "GET /tasks/presets": [],
  "GET /tasks/schema": { type: "object", properties: {}, $defs: {} },
  "GET /tasks/1": TASK,
  "POST /tasks/check": { valid: true, errors: [] },
};

function preview(status: string, extra: Record<string, unknown> = {}) {
  return {
    id: 5,
    kind: "task",
    status,
    task_version_id: 11,
    oracle_version_id: null,
    draft: true,
    options: { intervals: null, intervals_per_phase: [2, 2] },
    created_at: "2026-11-22T02:00:00Z",
    started_at: null,
    finished_at: null,
    worker_name: status === "pending" ? null : "worker-1@host",
    error: null,
    result: null,
    ...extra,
  };
}

// the OCP solution on its grid: rows are time samples (n, ndof)
const SOLUTION = {
  t: [0, 0.1, 0.2, 0.3, 0.4],
  q: [[0.2], [0.25], [0.3], [0.3], [0.3]],
  qd: [[0], [0.5], [0], [0], [0]],
  tau: [[1], [2], [-1], [0], [null]],
  status: "Solve_Succeeded",
  converged: true,
  cost: 0.0123,
  iterations: 17,
  constraint_violation: 1e-9,
  wall_time_s: 0.8,
  intervals: 4,
  intervals_per_phase: [2, 2],
  grid: "2 + 2 intervals (the task's own grid)",
};

describe("task editor: solve once", () => {
  it("sends the edit as shown, polls the preview while a worker runs it and plots angle and torque", async () => {
    let polls = 0;
    const { calls } = mockApi({
      ...TASK_ROUTES,
      "POST /tasks/1/previews": () => jsonResponse(preview("pending"), 202),
      "GET /previews/5": () => {
        polls += 1;
        return polls < 2 ? preview("running") : preview("succeeded", { result: SOLUTION });
      },
    });
    renderPage(<TaskEditorPage />, { route: "/tasks/1", path: "/tasks/:id" });
    const button = await screen.findByRole("button", { name: "Solve once" });
    await waitFor(() => expect(button).toBeEnabled());
    // an unsaved edit: phase 1 lasts 0.3 s
    fireEvent.change(screen.getByLabelText("phase 1 duration [s]"), { target: { value: "0.3" } });
    await waitFor(() => expect(button).toBeEnabled());
    await userEvent.click(button);
    // the worker is at it: a loading state, the button is busy
    expect(await screen.findByText(/Running on worker-1@host|Waiting for a worker/)).toBeInTheDocument();
    expect(screen.getByRole("button", { name: "Solving…" })).toBeDisabled();

    await waitFor(() => expect(screen.getByTestId("preview-torque")).toHaveAttribute("data-points", "5"), { timeout: 4000 });
    expect(screen.getByTestId("preview-angle")).toHaveAttribute("data-points", "5");
    expect(screen.getByTestId("preview-torque")).toHaveAttribute("data-shapes", "2"); // both phases shaded
    expect(screen.getByTestId("solve-summary")).toHaveTextContent("Solve_Succeeded · 17 iterations · cost 0.01230");
    // solved on the task's own grid (no "intervals" override sent), and it says so
    expect(screen.getByTestId("solve-grid")).toHaveTextContent("Grid: 2 + 2 intervals (the task's own grid)");
    expect(screen.getByRole("button", { name: "Solve once" })).toBeEnabled();

    const post = calls.find((c) => c.method === "POST" && c.path === "/tasks/1/previews");
    expect(post?.body).toEqual({ spec: { ...SPEC, phases: [{ ...SPEC.phases[0], duration: 0.3 }, SPEC.phases[1]] } });
    expect(polls).toBeGreaterThanOrEqual(2);
    // polling stops once the preview is final
    const settled = polls;
    await new Promise((r) => setTimeout(r, 1300));
    expect(polls).toBe(settled);
  });

  it("shows why the worker could not solve it, and why the API refused to start one", async () => {
    let answer: Response | null = null;
    mockApi({
      ...TASK_ROUTES,
      "POST /tasks/1/previews": () => answer ?? jsonResponse(preview("pending"), 202),
      "GET /previews/5": () => preview("failed", { error: "OCP failed: Infeasible_Problem_Detected" }),
    });
    renderPage(<TaskEditorPage />, { route: "/tasks/1", path: "/tasks/:id" });
    const button = await screen.findByRole("button", { name: "Solve once" });
    await waitFor(() => expect(button).toBeEnabled());
    await userEvent.click(button);
    expect(await screen.findByText(/OCP failed: Infeasible_Problem_Detected/, {}, { timeout: 4000 })).toBeInTheDocument();
    expect(screen.getByTestId("preview-panel")).toHaveAttribute("data-status", "failed");

    answer = jsonResponse({ detail: "you have 3 previews pending or running (at most 3); wait for one to finish" }, 429);
    await userEvent.click(screen.getByRole("button", { name: "Solve once" }));
    expect(await screen.findByText(/you have 3 previews pending/, {}, { timeout: 4000 })).toBeInTheDocument();
  });

  it("says when a preview waits for the job queue (the broker is down), not for a worker", async () => {
    const waiting = "waiting for the job queue: the broker is not reachable; it is sent as soon as it is back";
    mockApi({
      ...TASK_ROUTES,
      "POST /tasks/1/previews": () => jsonResponse(preview("pending", { status_detail: waiting }), 202),
      "GET /previews/5": () => preview("pending", { status_detail: waiting }),
    });
    renderPage(<TaskEditorPage />, { route: "/tasks/1", path: "/tasks/:id" });
    const button = await screen.findByRole("button", { name: "Solve once" });
    await waitFor(() => expect(button).toBeEnabled());
    await userEvent.click(button);
    expect(await screen.findByText(/Waiting for the job queue: the broker is not reachable/, {}, { timeout: 4000 })).toBeInTheDocument();
    expect(screen.queryByText(/Waiting for a worker/)).not.toBeInTheDocument();
  });

  it("needs a saved task", async () => {
    mockApi({ ...TASK_ROUTES, "GET /tasks/presets": [{ key: "p", name: "p", description: "", spec: SPEC }] });
    renderPage(<TaskEditorPage />, { route: "/tasks/new" });
    expect(await screen.findByRole("button", { name: "Solve once" })).toBeDisabled();
  });
});

describe("oracle editor: test on a sample trajectory", () => {
  const ORACLE = { id: 2, owner_id: 1, name: "aux", description: "", type: "aux-penalty", params: { stiffness: 1000 }, version: 1, version_id: 21, created_at: "2026-11-21T22:00:00Z", updated_at: "2026-11-21T22:00:00Z" };
  const TYPES = [{ name: "aux-penalty", kind: "builtin", description: "penalty contact", available: true, unavailable_reason: null, params_schema: { type: "object", properties: { stiffness: { type: "number" } } } }];

  it("replays the sample motion through the oracle on a worker and plots the force and moment", async () => {
    const t = [0, 0.5, 1];
    const { calls } = mockApi({
      "GET /oracles/types": TYPES,
      "GET /oracles/2": ORACLE,
      "POST /oracles/check": { valid: true, errors: [] },
      "POST /oracles/2/previews": () => jsonResponse({ ...preview("pending"), kind: "oracle", task_version_id: null, oracle_version_id: 21 }, 202),
      "GET /previews/5": () =>
        preview("succeeded", {
          kind: "oracle",
          result: {
            ok: true,
            failure_reason: null,
            wall_time_s: 0.4,
            trajectory: { t, q: [[0.2], [0.4], [0.2]], qd: [[0], [0], [0]] },
            t,
            fx: [0, 30, 0],
            fy: [0, 0, 0],
            fz: [0, -2, 0],
            mx: [0, 0, 0],
            my: [0, -1.5, 0],
            mz: [0, 0, 0],
            peak_force_n: 30.1,
            diagnostics: {},
          },
        }),
    });
    renderPage(<OracleEditorPage />, { route: "/oracles/2", path: "/oracles/:id" });
    const button = await screen.findByRole("button", { name: "Test on a sample trajectory" });
    await waitFor(() => expect(button).toBeEnabled());
    await userEvent.click(button);
    // fx, fz and my: the components that are zero throughout are left out
    await waitFor(() => expect(screen.getByTestId("oracle-test-plot")).toHaveAttribute("data-traces", "3"), { timeout: 4000 });
    expect(screen.getByTestId("oracle-test-motion")).toHaveAttribute("data-points", "3");
    expect(screen.getByTestId("oracle-test-summary")).toHaveTextContent("peak force 30.1 N");
    // unchanged parameters: the saved version is tested
    expect(calls.find((c) => c.method === "POST" && c.path === "/oracles/2/previews")?.body).toEqual({});
  });
});
