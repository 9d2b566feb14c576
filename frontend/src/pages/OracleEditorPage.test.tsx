import { describe, expect, it } from "vitest";
import { screen } from "@testing-library/react";
import { OracleEditorPage } from "./OracleEditorPage";
import { mockApi, renderPage } from "../test/utils";

describe("oracle editor: where a command oracle runs", () => {
  it("says that the chosen entry's calls run as batch jobs, with the administrator's resources", async () => {
    const launcher = "one Slurm job per oracle call (partition short, 1 task x 8 CPU, time limit 3600 s)";
    mockApi({
      "GET /oracles/types": [
        { name: "lsdyna-slurm", kind: "command", description: "LS-DYNA on the cluster", available: true, unavailable_reason: null, launcher, params_schema: { type: "object", properties: {} } },
      ],
      "GET /oracles/2": { id: 2, owner_id: 1, name: "dyna", description: "", type: "lsdyna-slurm", params: {}, version: 1, version_id: 21, created_at: "2026-11-21T22:00:00Z", updated_at: "2026-11-21T22:00:00Z" },
      "POST /oracles/check": { valid: true, errors: [] },
    });
    renderPage(<OracleEditorPage />, { route: "/oracles/2", path: "/oracles/:id" });
    expect(await screen.findByTestId("oracle-launcher")).toHaveTextContent(`Runs as ${launcher} (set by the administrator).`);
  });
});
