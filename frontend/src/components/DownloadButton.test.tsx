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
