/** The new-campaign form checks while typing, as the task and oracle editors do: every problem at once, each at its field, in words, with its label. */
import { describe, expect, it } from "vitest";
import { screen, waitFor, within } from "@testing-library/react";
import userEvent from "@testing-library/user-event";
import openapi from "../../openapi.json";
import { NewCampaignPage, withoutFields } from "./NewCampaignPage";
import { jsonResponse, mockApi, renderPage } from "../test/utils";

type Body = { name?: string; oracle_id?: number; settings?: { strategy?: string; replay_dt?: unknown }; stopping?: { max_iterations?: unknown }; preliminary?: { samples?: unknown } };
const err = (field: string, msg: string) => ({ loc: field.split("."), field, msg, type: "x" });

/** The API's answers to a draft: the definitions it names and the rules across fields, which the form cannot check itself. */
function serverCheck(body: Body) {
  const errors = [];
  if (body.oracle_id === 3) errors.push(err("oracle_id", "no such oracle (or not shared with you)"));
  if (body.settings?.strategy === "ensemble-disagreement") errors.push(err("settings.strategy", "strategy 'ensemble-disagreement' needs a surrogate ensemble of at least 2 members"));
  if (body.stopping?.max_iterations === null) errors.push(err("stopping", "Value error, at least one stopping rule is needed (e.g. max_iterations)"));
  if (!body.name) errors.push(err("name", "String should have at least 1 character"));
  return { valid: errors.length === 0, errors, normalized: null };
}

function setup(create: () => unknown = () => jsonResponse({ detail: "stop here" }, 409)) {
  return mockApi({
    "GET /openapi.json": openapi,
    "GET /tasks": [{ id: 1, name: "t", version: 1 }],
    "GET /oracles": [
      { id: 2, name: "o", type: "aux-penalty", version: 1 },
      { id: 3, name: "gone", type: "aux-penalty", version: 1 },
    ],
    "GET /surrogate-configs": [],
    "POST /campaigns/check": (_u: URL, body: Body) => serverCheck(body),
    "POST /campaigns": create,
  });
}

const badge = () => screen.getByTestId("check-state");
const fieldOf = (el: HTMLElement) => el.closest(".field") as HTMLElement;

describe("the new-campaign form", () => {
  it("leaves the values it names itself out of what the API checks", () => {
    const body = { name: "", seed: 0, settings: { replay_dt: "abc", batch: 2 }, preliminary: { dataset_ids: [1, "x"], samples: 3 } };
    expect(withoutFields(body, ["name", "settings.replay_dt", "preliminary.dataset_ids.1"])).toEqual({ seed: 0, settings: { batch: 2 }, preliminary: { samples: 3 } });
    expect(body.settings.replay_dt).toBe("abc");
  });

  it("a blank new campaign is not valid: its name is named at the field and the badge counts it", async () => {
    const { calls } = setup();
    renderPage(<NewCampaignPage />, { route: "/campaigns/new" });
    const name = await screen.findByLabelText("Name");
    await waitFor(() => expect(badge()).toHaveTextContent("1 problem"), { timeout: 5000 });
    expect(name).toHaveAttribute("aria-invalid", "true");
    expect(fieldOf(name)).toHaveTextContent("must not be empty");
    // the API was asked, and its raw words for the same problem are not shown beside the form's
    expect(calls.some((c) => c.method === "POST" && c.path === "/campaigns/check")).toBe(true);
    expect(document.body.textContent).not.toMatch(/String should/);
  });

  it("checks while typing and names every problem at once, each at its field with its label; nothing is created", async () => {
    const { calls } = setup();
    renderPage(<NewCampaignPage />, { route: "/campaigns/new" });
    const user = userEvent.setup();
    await user.type(await screen.findByLabelText("Name"), "explore");
    await user.selectOptions(screen.getByLabelText("Oracle"), "3");
    const section = await screen.findByTestId("exploration");
    await user.selectOptions(within(section).getByLabelText("Strategy"), "ensemble-disagreement");
    const stopping = screen.getByRole("region", { name: "Stopping rules" });
    await user.clear(within(stopping).getByLabelText(/^max_iterations/));
    const replayDt = within(screen.getByRole("region", { name: "Run settings" })).getByLabelText(/^replay_dt/);
    await user.clear(replayDt);
    await user.type(replayDt, "abc");
    const samples = within(screen.getByRole("region", { name: /Preliminary data/ })).getByLabelText(/^samples/);
    await user.clear(samples);
    await user.type(samples, "1");

    // the form's own checks and the API's, all at once: 5 problems, each once at its field
    await waitFor(() => expect(badge()).toHaveTextContent("5 problems"), { timeout: 5000 });
    const checks = calls.filter((c) => c.method === "POST" && c.path === "/campaigns/check");
    // the values the form names itself are left out, so the API checks all the rest of their section
    const sent = checks.at(-1)!.body as Body;
    expect(sent).toMatchObject({ name: "explore", oracle_id: 3, settings: { strategy: "ensemble-disagreement" }, stopping: { max_iterations: null } });
    expect(sent.settings).not.toHaveProperty("replay_dt");
    expect(sent.preliminary).not.toHaveProperty("samples");
    expect(fieldOf(screen.getByLabelText("Oracle"))).toHaveTextContent("no such oracle (or not shared with you)");
    expect(within(section).getByLabelText("Strategy")).toHaveAttribute("aria-invalid", "true");
    expect(section).toHaveTextContent("needs a surrogate ensemble of at least 2 members");
    expect(replayDt).toHaveAttribute("aria-invalid", "true");
    expect(fieldOf(replayDt)).toHaveTextContent("must be a number");
    expect(samples).toHaveAttribute("aria-invalid", "true");
    expect(fieldOf(samples)).toHaveTextContent("must be at least 2");
    // a rule across the section's fields is named in the section, in words
    const rule = stopping.querySelector('[data-error-path="stopping"]');
    expect(rule).toHaveTextContent("at least one stopping rule is needed (e.g. max_iterations)");
    expect(rule).toHaveAttribute("title", "Stopping rules: at least one stopping rule is needed (e.g. max_iterations)");
    // labels from the schema, never a broken one; nothing listed above the form
    expect(document.querySelector('[data-error-path="settings.replay_dt"]')!.getAttribute("title")).toMatch(/^Run settings › .*\(replay_dt\): must be a number$/);
    for (const el of document.querySelectorAll("[data-error-path]")) expect(el.getAttribute("title")).not.toMatch(/› :|^: /);
    expect(screen.queryByTestId("form-errors")).toBeNull();
    expect([...document.querySelectorAll("[data-error-path]")].map((e) => e.getAttribute("data-error-path")).sort()).toEqual(["oracle_id", "preliminary.samples", "settings.replay_dt", "settings.strategy", "stopping"]);
    expect(calls.some((c) => c.method === "POST" && c.path === "/campaigns")).toBe(false);

    // each fix takes its problem away; at the end the form is valid
    await user.selectOptions(screen.getByLabelText("Oracle"), "2");
    await user.selectOptions(within(section).getByLabelText("Strategy"), "random-scenarios");
    await user.type(within(stopping).getByLabelText(/^max_iterations/), "3");
    await user.clear(replayDt);
    await user.type(replayDt, "0.0025");
    await user.type(samples, "00");
    await waitFor(() => expect(badge()).toHaveTextContent("valid"), { timeout: 5000 });
    expect(document.querySelectorAll("[data-error-path]")).toHaveLength(0);
  }, 20_000);

  it("a refused create's problem goes once the value is changed, and the count with it", async () => {
    const { calls } = setup(() => jsonResponse({ detail: [err("settings.replay_dt", "Value error, the replay step does not fit the oracle")] }, 422));
    renderPage(<NewCampaignPage />, { route: "/campaigns/new" });
    const user = userEvent.setup();
    await user.type(await screen.findByLabelText("Name"), "refused");
    await waitFor(() => expect(badge()).toHaveTextContent("valid"), { timeout: 5000 });
    await user.click(screen.getByRole("button", { name: "Create campaign" }));
    expect(await screen.findByText("the replay step does not fit the oracle")).toBeInTheDocument();
    expect(badge()).toHaveTextContent("1 problem");
    expect(calls.filter((c) => c.method === "POST" && c.path === "/campaigns")).toHaveLength(1);
    const replayDt = within(screen.getByRole("region", { name: "Run settings" })).getByLabelText(/^replay_dt/);
    await user.clear(replayDt);
    await user.type(replayDt, "0.005");
    expect(screen.queryByText("the replay step does not fit the oracle")).toBeNull();
    await waitFor(() => expect(badge()).toHaveTextContent("valid"), { timeout: 5000 });
  }, 20_000);
});
