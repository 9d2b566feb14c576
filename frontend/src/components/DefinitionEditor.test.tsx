import { describe, expect, it } from "vitest";
import { screen, waitFor } from "@testing-library/react";
import userEvent from "@testing-library/user-event";
import { DefinitionEditor } from "./DefinitionEditor";
import { noErrors } from "../lib/formErrors";
import { jsonResponse, mockApi, renderPage } from "../test/utils";

/** The editor shell of oracle 3 as the oracle page renders it (name "aux", no field errors). */
function renderOracleEditor(existing: { id: number; version: number; version_locked: boolean; can_edit: boolean }) {
  renderPage(
    <DefinitionEditor
      kind="oracle"
      noun="oracle"
      existing={existing}
      name="aux"
      setName={() => {}}
      description=""
      setDescription={() => {}}
      errors={noErrors}
      saving={false}
      onSave={() => {}}
    >
      <p>parameters</p>
    </DefinitionEditor>,
  );
}

describe("definition editor shell (tasks and oracles)", () => {
  it("saves a used version as a new one, lists the versions and shares", async () => {
    let shares: { id: number; email: string; permission: string }[] = [];
    const { calls } = mockApi({
      "GET /oracles/3/versions": [
        { version: 1, locked: true, note: "", created_at: "2026-11-20T10:00:00Z", spec_hash: "a", type: "aux-penalty", params: {} },
        { version: 2, locked: true, note: "stiffer", created_at: "2026-11-21T10:00:00Z", spec_hash: "b", type: "aux-penalty", params: {} },
      ],
      "GET /shares": () => shares,
      "POST /shares": (_u: URL, body: { email: string; permission: string }) => {
        shares = [{ id: 1, email: body.email, permission: body.permission }];
        return jsonResponse({ ...shares[0], object_type: "oracle", object_id: 3, created_at: "" }, 201);
      },
    });
    renderOracleEditor({ id: 3, version: 2, version_locked: true, can_edit: true });
    expect(screen.getByRole("button", { name: "Save as version 3" })).toBeEnabled();
    const history = await screen.findByTestId("version-history");
    expect(history).toHaveTextContent("stiffer");
    expect(screen.getByRole("heading", { name: "Oracle: aux" })).toBeInTheDocument();
    await userEvent.type(screen.getByLabelText("Share with"), "bo@lab");
    await userEvent.click(screen.getByRole("button", { name: "Share" }));
    await waitFor(() => expect(screen.getAllByText(/bo@lab/)).toHaveLength(2)); // the list and the confirmation
    // the same words whether or not bo@lab has an account (sharing does not tell)
    expect(screen.getByRole("status")).toHaveTextContent("Shared with bo@lab. If no account uses this address yet, the account made with it will get it.");
    expect(calls.find((c) => c.method === "POST" && c.path === "/shares")?.body).toEqual({ email: "bo@lab", permission: "view", object_type: "oracle", object_id: 3 });
  });

  it("lists a share made while the list's first request was still on its way", async () => {
    // the first GET read the empty list before the share committed and answers after it: the
    // list must be fetched again, not joined onto that answer
    let shares: { id: number; email: string; permission: string }[] = [];
    let answerFirstList: () => void = () => {};
    const firstListRead = new Promise<void>((resolve) => (answerFirstList = resolve));
    let lists = 0;
    mockApi({
      "GET /oracles/3/versions": [],
      "GET /shares": () => {
        lists += 1;
        if (lists > 1) return shares;
        const snapshot = [...shares];
        return firstListRead.then(() => snapshot);
      },
      "POST /shares": (_u: URL, body: { email: string; permission: string }) => {
        shares = [{ id: 1, email: body.email, permission: body.permission }];
        return jsonResponse({ ...shares[0], object_type: "oracle", object_id: 3, created_at: "" }, 201);
      },
    });
    renderOracleEditor({ id: 3, version: 1, version_locked: false, can_edit: true });
    await waitFor(() => expect(lists).toBe(1));
    await userEvent.type(screen.getByLabelText("Share with"), "bo@lab");
    const share = userEvent.click(screen.getByRole("button", { name: "Share" }));
    await waitFor(() => expect(shares).toHaveLength(1)); // stored; the first list answer is still to come
    answerFirstList();
    await share;
    await waitFor(() => expect(screen.getByText("bo@lab (view)")).toBeInTheDocument());
    expect(lists).toBe(2);
  });
});
