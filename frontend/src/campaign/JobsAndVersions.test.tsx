import { describe, expect, it } from "vitest";
import { screen, within } from "@testing-library/react";
import { JobsTable, VersionsPanel } from "./JobsAndVersions";
import { mockApi, renderPage } from "../test/utils";

function model(id: number, version: number, stopped_improving: number) {
  return {
    id,
    campaign_id: 3,
    version,
    pool_version_id: 10 + version,
    parent_model_id: version > 1 ? id - 1 : null,
    surrogate_config_version_id: 1,
    seed: 0,
    test_force_rmse: 1.5,
    test_moment_rmse: 0.1,
    epochs: 1000,
    train_wall_time_s: 3.2,
    code_version: "test",
    library_versions: {},
    architecture: {},
    training_metrics: { stopped_improving },
    created_at: "2026-12-04T20:00:00Z",
    stopped_improving,
  };
}

describe("model versions table", () => {
  it("warns about a model whose members stopped at max_epochs while still improving", async () => {
    mockApi({
      "GET /campaigns/3/model-versions": [model(21, 1, 0), model(22, 2, 3)],
      "GET /campaigns/3/pool-versions": [
        { id: 11, version: 0, campaign_id: 3, parent_id: null, n_datasets: 10, n_samples: 4000, content_hash: "a", created_at: "2026-12-04T20:00:00Z" },
        { id: 12, version: 1, campaign_id: 3, parent_id: 11, n_datasets: 11, n_samples: 4401, content_hash: "b", created_at: "2026-12-04T20:00:00Z" },
      ],
    });
    renderPage(<VersionsPanel campaignId={3} />);
    const table = await screen.findByTestId("model-table");
    const rows = within(table).getAllByRole("row").slice(1);
    expect(rows).toHaveLength(2);
    // newest first: m2 capped, m1 not
    expect(within(rows[0]).getByRole("img", { name: "3 nets stopped at max_epochs while still improving" })).toHaveTextContent("capped");
    expect(within(rows[1]).queryByRole("img")).toBeNull();
  });

  it("names each model's inputs and whether the normal force has layers of its own", async () => {
    mockApi({
      "GET /campaigns/3/model-versions": [
        { ...model(22, 2, 0), architecture: { features: "history", normal_force: "own" } },
        { ...model(21, 1, 0), architecture: { features: "paper", normal_force: "shared" } },
        { ...model(20, 0, 0), architecture: {} },
      ],
      "GET /campaigns/3/pool-versions": [],
    });
    renderPage(<VersionsPanel campaignId={3} />);
    const cells = await screen.findAllByTestId("model-features");
    expect(cells.map((c) => c.textContent).sort()).toEqual(["paper", "paper", "paper + history; fx own layers"]);
  });
});

function job(id: number, step: string, slot: number, batch_jobs: object[]) {
  return {
    id, iteration: 1, step, slot, status: "succeeded", queue: step, attempts: 1, max_attempts: 3,
    worker_name: "w@host", queued_at: null, started_at: "2026-12-04T20:00:00Z", finished_at: null,
    lease_until: null, heartbeat_at: null, wall_time_s: 3.0, error: null, result: {}, batch_jobs,
  };
}

describe("jobs table", () => {
  it("shows an oracle call's scheduler job, its state and how long it ran", async () => {
    const slurm = {
      scheduler: "slurm", job_id: "4711", state: "collected", reason: null, attempt: 1, worker_name: "o@login1",
      workdir: "/scratch/jobs/a", exit_code: 0, submitted_at: "2026-12-04T20:00:00Z",
      started_at: "2026-12-04T20:00:01Z", ended_at: "2026-12-04T20:00:07Z", collected_at: "2026-12-04T20:00:07Z",
    };
    mockApi({ "GET /campaigns/3/jobs": [job(1, "train", 0, []), job(2, "oracle", 0, [slurm])] });
    renderPage(<JobsTable campaignId={3} />);
    const table = await screen.findByTestId("jobs-table");
    const cells = within(table).getAllByTestId("batch-job");
    expect(cells).toHaveLength(1);
    expect(cells[0]).toHaveTextContent("slurm 4711 · collected · 6");
    expect(cells[0].getAttribute("title")).toContain("queued 1");
  });
});
