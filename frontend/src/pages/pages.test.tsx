import { describe, expect, it } from "vitest";
import { fireEvent, screen, waitFor, within } from "@testing-library/react";
import userEvent from "@testing-library/user-event";
import { CampaignsPage, sortCampaigns } from "./CampaignsPage";
import { TaskEditorPage } from "./TaskEditorPage";
import { TokensPage } from "./TokensPage";
import { SignInPage } from "./SignInPage";
import { jsonResponse, mockApi, renderPage, sseStream } from "../test/utils";
import type { CampaignSummary } from "../api/types";

const summary = (id: number, name: string, status: string, force: number | null) => ({
  id,
  name,
  status,
  owner_id: 1,
  owner: "ana@lab",
  task_id: 1,
  task: "two-phase",
  task_version: 1,
  oracle_id: 1,
  oracle: "aux",
  oracle_type: "aux-penalty",
  oracle_version: 1,
  current_iteration: id,
  current_step: null,
  max_iterations: 10,
  force_rmse: force,
  moment_rmse: force === null ? null : force / 10,
  source_campaign_id: null,
  source_iteration: null,
  created_at: "2026-11-21T22:00:00Z",
  started_at: `2026-11-21T2${id}:00:00Z`,
  finished_at: null,
  // 8 iterations left x 15 s each while running; unknown otherwise
  eta_s: status === "running" ? 120 : null,
});

describe("campaigns list", () => {
  it("shows status, iteration k/N and latest RMSE, filters by text and sorts by RMSE", async () => {
    mockApi({
      "GET /campaigns": [summary(1, "baseline", "completed", 0.4), summary(2, "stiff foam", "running", 1.2), summary(3, "draft one", "draft", null)],
      "GET /campaigns/{id}/metrics": [],
    });
    renderPage(<CampaignsPage />, { route: "/campaigns" });
    const table = await screen.findByTestId("campaigns-table");
    expect(within(table).getAllByRole("row")).toHaveLength(4);
    const running = within(table).getByRole("row", { name: /stiff foam/ });
    expect(running).toHaveTextContent("running");
    expect(running).toHaveTextContent("2 / 10");
    expect(running).toHaveTextContent("1.20");
    expect(running).toHaveTextContent("2 min 0 s"); // ETA
    expect(within(table).getByRole("row", { name: /baseline/ })).not.toHaveTextContent(/\d min/);

    await userEvent.click(screen.getByRole("button", { name: /Force RMSE/ }));
    const names = within(table).getAllByRole("link").map((a) => a.textContent);
    expect(names).toEqual(["baseline", "stiff foam", "draft one"]);

    fireEvent.change(screen.getByLabelText("Search"), { target: { value: "foam" } });
    await waitFor(() => expect(within(screen.getByTestId("campaigns-table")).getAllByRole("row")).toHaveLength(2));
  });

  it("shows a campaign created and started elsewhere (CLI, API) without reload, from the live channel; nothing polls", async () => {
    const stream = sseStream();
    let rows = [summary(1, "baseline", "completed", 0.4)];
    const { calls } = mockApi({
      "GET /campaigns": () => rows,
      "GET /campaigns/events/stream": (url: URL) => stream.response(url),
      "GET /campaigns/{id}/metrics": [],
    });
    renderPage(<CampaignsPage />, { route: "/campaigns" });
    const table = await screen.findByTestId("campaigns-table");
    await waitFor(() => expect(screen.getByTestId("live-state")).toHaveAttribute("data-state", "live"));
    rows = [...rows, summary(2, "from the CLI", "draft", null)];
    stream.send({ kind: "status", campaign_id: 2, message: "created", data: { status: "draft" } });
    expect(await within(table).findByRole("row", { name: /from the CLI/ })).toHaveTextContent("draft");
    rows = [rows[0], summary(2, "from the CLI", "running", null)];
    stream.send({ kind: "status", campaign_id: 2, data: { from: "queued", to: "running" } });
    await waitFor(() => expect(within(table).getByRole("row", { name: /from the CLI/ })).toHaveTextContent("running"));
    // no polling of the list or the sparklines while the stream is up
    const before = calls.length;
    await new Promise((r) => setTimeout(r, 4500));
    expect(calls.slice(before)).toEqual([]);
    stream.close();
  }, 10000);

  it("has an empty state that points to tasks and oracles", async () => {
    mockApi({ "GET /campaigns": [] });
    renderPage(<CampaignsPage />, { route: "/campaigns" });
    expect(await screen.findByText("No campaigns yet")).toBeInTheDocument();
    expect(screen.getByRole("link", { name: "task" })).toHaveAttribute("href", "/tasks/new");
  });

  it("sorts missing values last", () => {
    const rows = [{ id: 1, force_rmse: null }, { id: 2, force_rmse: 3 }, { id: 3, force_rmse: 1 }] as unknown as CampaignSummary[];
    expect(sortCampaigns(rows, "force_rmse", false).map((r) => r.id)).toEqual([3, 2, 1]);
    expect(sortCampaigns(rows, "force_rmse", true).map((r) => r.id)).toEqual([2, 3, 1]);
  });
});

const PRESET = {
  key: "head-headrest-2phase",
  name: "head-headrest-2phase",
  description: "",
  spec: { name: "two", model: { mass: 5 }, phases: [{ name: "approach", duration: 1, intervals: 100, w_tau: 0.001, w_T: 0.0001 }, { name: "rest", duration: 1, intervals: 100, w_tau: 1, w_T: 1 }] },
};
const TASK_SCHEMA = { type: "object", properties: {}, $defs: { ModelSpec: { type: "object", properties: { mass: { type: "number", exclusiveMinimum: 0, description: "head mass [kg]" } } } } };

describe("task editor", () => {
  it("shows the API's validation message at the phase cell it concerns", async () => {
    mockApi({
      "GET /tasks/presets": [PRESET],
      "GET /tasks/schema": TASK_SCHEMA,
      "GET /openapi.json": { paths: {} },
      "POST /tasks/check": (_url: URL, body: { spec?: { phases?: { duration: number }[] } }) => {
        const bad = (body.spec?.phases?.[0]?.duration ?? 1) <= 0;
        return { valid: !bad, errors: bad ? [{ loc: ["spec", "phases", 0, "duration"], field: "spec.phases.0.duration", msg: "Input should be greater than 0", type: "greater_than" }] : [] };
      },
    });
    renderPage(<TaskEditorPage />, { route: "/tasks/new" });
    // a new task needs a name (a blank one is a problem the form names)
    fireEvent.change(await screen.findByLabelText("Name"), { target: { value: "a task" } });
    const duration = await screen.findByLabelText("phase 1 duration [s]");
    await waitFor(() => expect(screen.getByTestId("check-state")).toHaveTextContent("valid"), { timeout: 3000 });
    fireEvent.change(duration, { target: { value: "-1" } });
    expect(await screen.findByText("must be greater than 0", {}, { timeout: 3000 })).toBeInTheDocument();
    expect(screen.getByLabelText("phase 1 duration [s]")).toHaveAttribute("aria-invalid", "true");
    expect(screen.getByTestId("check-state")).toHaveTextContent("1 problem");
    // "solve once" previews a saved task (and its unsaved edits)
    expect(screen.getByRole("button", { name: "Solve once" })).toBeDisabled();
    expect(screen.getByLabelText(/^mass/)).toHaveValue("5");
  });
});

describe("tokens and sign-in", () => {
  it("shows a new token once and lists tokens with a revoke button", async () => {
    let tokens = [{ id: 1, name: "old", kind: "personal", token_prefix: "alc_ab", created_at: "2026-11-20T10:00:00Z", last_used_at: null, expires_at: null, revoked_at: null, revoked: false }];
    mockApi({
      "GET /me/tokens": () => tokens,
      "POST /me/tokens": () => {
        const t = { ...tokens[0], id: 2, name: "notebook" };
        tokens = [...tokens, t];
        return jsonResponse({ ...t, token: "alc_secret_value_shown_once_1234567890" }, 201);
      },
    });
    renderPage(<TokensPage />, { route: "/tokens" });
    expect(await screen.findByRole("row", { name: /old/ })).toHaveTextContent("Revoke");
    expect(document.title).toBe("API tokens · alcove");
    await userEvent.type(screen.getByLabelText("Name"), "notebook");
    await userEvent.click(screen.getByRole("button", { name: "Create token" }));
    expect(await screen.findByTestId("new-token")).toHaveTextContent("alc_secret_value_shown_once_1234567890");
    await userEvent.click(screen.getByRole("button", { name: "Done" }));
    expect(screen.queryByTestId("new-token")).toBeNull();
    expect(await screen.findByRole("row", { name: /notebook/ })).toBeInTheDocument();
  });

  it("a refused token name is named at the field with no uncaught error; a name of spaces is refused before sending", async () => {
    const { calls } = mockApi({
      "GET /me/tokens": () => [],
      "POST /me/tokens": () =>
        jsonResponse({ detail: [{ loc: ["body", "name"], field: "name", msg: "contains a NUL character (U+0000), which cannot be stored: remove it", type: "string_nul" }] }, 422),
    });
    const unhandled: unknown[] = [];
    const onUnhandled = (reason: unknown) => unhandled.push(reason);
    process.on("unhandledRejection", onUnhandled);
    try {
      renderPage(<TokensPage />, { route: "/tokens" });
      const name = await screen.findByLabelText("Name");
      await userEvent.type(name, "   ");
      await userEvent.click(screen.getByRole("button", { name: "Create token" }));
      expect(await screen.findByText(/must not be empty/)).toBeInTheDocument();
      expect(calls.filter((c) => c.method === "POST")).toHaveLength(0);
      fireEvent.change(name, { target: { value: "bad\u0000name" } });
      await userEvent.click(screen.getByRole("button", { name: "Create token" }));
      expect(await screen.findByText(/contains a NUL character/)).toBeInTheDocument();
      expect(name).toHaveAttribute("aria-invalid", "true");
      await new Promise((r) => setTimeout(r, 0));
      expect(unhandled).toEqual([]);
    } finally {
      process.off("unhandledRejection", onUnhandled);
    }
  });

  it("signs in with e-mail and password and keeps the token; shows the API's refusal", async () => {
    mockApi({
      "POST /auth/login": (_url: URL, body: { password: string }) => {
        return body.password === "right" ? { access_token: "tok-123", token_type: "bearer", expires_at: "2026-11-22T10:00:00Z" } : jsonResponse({ detail: "wrong e-mail or password" }, 401);
      },
    });
    renderPage(<SignInPage />, { route: "/signin?next=/campaigns/4", token: null });
    await userEvent.type(screen.getByLabelText("Email"), "ana@lab.org");
    await userEvent.type(screen.getByLabelText("Password"), "wrong");
    await userEvent.click(screen.getByRole("button", { name: "Sign in" }));
    expect(await screen.findByRole("alert")).toHaveTextContent("wrong e-mail or password");
    await userEvent.clear(screen.getByLabelText("Password"));
    await userEvent.type(screen.getByLabelText("Password"), "right");
    await userEvent.click(screen.getByRole("button", { name: "Sign in" }));
    await waitFor(() => expect(localStorage.getItem("alcove.token")).toBe("tok-123"));
  });

  it("says how long to wait when sign-ins from here are throttled", async () => {
    mockApi({
      "POST /auth/login": () => new Response(JSON.stringify({ detail: "too many failed logins: try again later" }), { status: 429, headers: { "Content-Type": "application/json", "Retry-After": "8" } }),
    });
    renderPage(<SignInPage />, { route: "/signin", token: null });
    await userEvent.type(screen.getByLabelText("Email"), "ana@lab.org");
    await userEvent.type(screen.getByLabelText("Password"), "wrong");
    await userEvent.click(screen.getByRole("button", { name: "Sign in" }));
    expect(await screen.findByRole("alert")).toHaveTextContent("Too many failed sign-ins from this address: try again in 8 s.");
  });
});
