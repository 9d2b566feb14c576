import { afterEach, describe, expect, it, vi } from "vitest";
import { render, screen } from "@testing-library/react";
import userEvent from "@testing-library/user-event";
import { DownloadButton } from "./DownloadButton";

afterEach(() => vi.unstubAllGlobals());

describe("a download button", () => {
  it("says it is preparing the file until the server answers, then is ready again; a failure is shown beside it", async () => {
    let answer: (r: Response) => void = () => {};
    vi.stubGlobal("fetch", vi.fn(() => new Promise<Response>((resolve) => (answer = resolve))));
    render(<DownloadButton path="/api/v1/campaigns/3/export" filename="campaign-3.zip" label="Export" />);
    const button = screen.getByRole("button", { name: "Export" });
    await userEvent.click(button);
    expect(button).toHaveAttribute("aria-busy", "true");
    expect(button).toBeDisabled();
    expect(button).toHaveTextContent("Export: preparing…");
    expect(screen.getByRole("status")).toHaveTextContent("Preparing campaign-3.zip");
    answer(new Response(JSON.stringify({ detail: "campaign 3 not found" }), { status: 404, headers: { "Content-Type": "application/json" } }));
    expect(await screen.findByRole("alert")).toHaveTextContent("Export: campaign 3 not found");
    expect(button).toHaveAttribute("aria-busy", "false");
    expect(button).toBeEnabled();
    expect(button).toHaveTextContent(/^Export$/);
  });
});

describe("a download whose model zips a worker builds first", () => {
  it("shows the build's progress, then downloads once it is ready; a failed build says why", async () => {
    const build = (status: string, done: number, detail = "") => ({
      id: 7, campaign_id: 3, status, models_total: 2, models_done: done, detail, error: status === "failed" ? "the artifacts folder /data/artifacts/model-zips is full" : null,
      download_url: "/api/v1/campaigns/3/export", created_at: "2026-01-01T00:00:00Z", started_at: null, finished_at: null,
    });
    const json = (body: unknown, status = 200, headers: Record<string, string> = {}) =>
      new Response(JSON.stringify(body), { status, headers: { "Content-Type": "application/json", ...headers } });
    const accepted = () => json(build("queued", 0, "waiting for a worker on queue 'artifacts'"), 202, { Location: "/api/v1/campaigns/3/artifact-builds/7", "Retry-After": "0" });
    let release: () => void = () => {};
    let releaseReady: () => void = () => {};
    const answers: (() => Response | Promise<Response>)[] = [
      accepted,
      () => new Promise<Response>((resolve) => (release = () => resolve(json(build("running", 1))))),
      () => new Promise<Response>((resolve) => (releaseReady = () => resolve(json(build("ready", 2))))),
      () => new Response("zip bytes", { status: 200, headers: { "Content-Disposition": 'attachment; filename="campaign-3.zip"' } }),
      accepted,
      () => json(build("failed", 0)),
    ];
    const fetch = vi.fn(() => Promise.resolve(answers.shift()!()));
    vi.stubGlobal("fetch", fetch);
    const createObjectURL = vi.fn(() => "blob:zip");
    vi.stubGlobal("URL", Object.assign(URL, { createObjectURL, revokeObjectURL: vi.fn() }));
    render(<DownloadButton path="/api/v1/campaigns/3/export" filename="campaign-3.zip" label="Export" className="" />);
    const button = screen.getByRole("button", { name: "Export" });

    await userEvent.click(button);
    expect(await screen.findByRole("status")).toHaveTextContent("campaign-3.zip: waiting for a worker on queue 'artifacts'…");
    release();
    await vi.waitFor(() => expect(button).toHaveTextContent("Export: building 2 of 2…"));
    expect(screen.getByRole("progressbar", { name: "Export: model zips built" })).toHaveAttribute("value", "1");
    releaseReady();
    await vi.waitFor(() => expect(createObjectURL).toHaveBeenCalledTimes(1));
    await vi.waitFor(() => expect(button).toHaveTextContent(/^Export$/));
    expect(fetch.mock.calls.map((c) => (c as unknown[])[0])).toEqual([
      "/api/v1/campaigns/3/export",
      "/api/v1/campaigns/3/artifact-builds/7",
      "/api/v1/campaigns/3/artifact-builds/7",
      "/api/v1/campaigns/3/export",
    ]);

    await userEvent.click(button);
    expect(await screen.findByRole("alert")).toHaveTextContent("Export: the artifacts folder /data/artifacts/model-zips is full");
    expect(button).toBeEnabled();
  });
});
