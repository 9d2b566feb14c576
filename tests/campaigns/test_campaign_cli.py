"""`alcove campaign create|start|pause|resume|cancel|fork|status|export` on the embedded
default (a fresh SQLite store). The steps are run in this process with the workers' protocol
(protocol.drive_inline) instead of a worker, so the test stays fast; `alcove campaign run`
through a real worker is tested in tests/campaigns/test_workers.py."""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

runner = CliRunner()
QUICK_YAML = """
preliminary: {samples: 300, chunks: 3}
settings: {ocp_intervals: 20, replay_dt: 0.01, validation_motions: 2, validation_reference_motions: 0}
surrogate: {max_epochs: 30, ensemble_size: 2}
"""


@pytest.fixture
def store(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    from alcove.db import dispose_engines
    from alcove.jobs import reset_sender
    from alcove.settings import get_settings

    for k in ("ALCOVE_DATABASE_URL", "ALCOVE_BROKER_URL"):
        monkeypatch.delenv(k, raising=False)
    monkeypatch.setenv("ALCOVE_DATA_DIR", str(tmp_path / "data"))
    get_settings.cache_clear()
    dispose_engines(close=True)
    reset_sender()
    (tmp_path / "quick.yaml").write_text(QUICK_YAML)
    yield tmp_path
    get_settings.cache_clear()
    dispose_engines(close=True)
    reset_sender()


def cli(*args: str) -> Any:
    from alcove_worker.cli.main import app

    r = runner.invoke(app, ["campaign", *args])
    return r


def ok(*args: str) -> str:
    r = cli(*args)
    assert r.exit_code == 0, (args, r.output)
    return r.output


def status(cid: int) -> dict[str, Any]:
    return json.loads(ok("status", str(cid), "--json"))


def run_queued_steps(cid: int) -> None:
    """What a worker would do with the messages `start`/`resume` sent: run the queued step to the end."""
    from alcove.campaigns.run.protocol import drive_inline
    from alcove.db import open_transaction
    from alcove.jobs.campaign import StepJob
    from alcove.models import Iteration, IterationStep, StepName

    with open_transaction() as s:
        queued = (
            s.query(Iteration.index, IterationStep)
            .join(IterationStep, IterationStep.iteration_id == Iteration.id)
            .filter(IterationStep.campaign_id == cid, IterationStep.status == "queued")
            .all()
        )
        jobs = [
            StepJob(campaign_id=cid, iteration=k, step=StepName(st.step), attempt=st.attempts + 1, slot=st.slot)
            for k, st in queued
        ]
    drive_inline(cid, jobs)


def test_create_start_status_fork_export_on_the_embedded_default(store: Path) -> None:
    cid = int(
        ok(
            "create",
            "--oracle",
            "aux-penalty",
            "--iterations",
            "2",
            "--config",
            str(store / "quick.yaml"),
            "--seed",
            "3",
        )
        .strip()
        .splitlines()[-1]
    )
    assert status(cid)["campaign"]["status"] == "draft"
    assert "queued" in ok("start", str(cid))
    run_queued_steps(cid)
    d = status(cid)
    assert (d["campaign"]["status"], d["campaign"]["stop_reason"], d["iterations_finished"]) == (
        "completed",
        "max_iterations",
        2,
    )

    # a fork from iteration 1 with one more iteration: its own campaign on the source's pool version 1 and model 1
    fork_id = int(ok("fork", str(cid), "--iteration", "1", "--iterations", "3", "--start").strip().splitlines()[-1])
    run_queued_steps(fork_id)
    f = status(fork_id)
    assert f["campaign"]["status"] == "completed" and f["campaign"]["source_iteration"] == 1
    assert f["iterations_finished"] == 2  # iterations 2 and 3

    out = store / "export"
    ok("export", str(cid), "--out", str(out), "--format", "parquet")
    import pyarrow.parquet as pq

    metrics = json.loads((out / "metrics.json").read_text())
    tables = sorted(p.name for p in (out / "pool").iterdir())
    assert tables == ["version-0000.parquet", "version-0001.parquet", "version-0002.parquet"]
    n = [pq.read_table(out / "pool" / t).num_rows for t in tables]
    assert n[0] > 0 and n[0] < n[1] < n[2]  # every version is its parent plus the new oracle rows
    assert (
        [m["iteration_index"] for m in metrics] == [1, 2]
        and (out / "metrics.csv").exists()
        and (out / "campaign.json").exists()
    )
    assert sorted(p.name for p in (out / "models").iterdir()) == ["model-0001.zip", "model-0002.zip"]


def test_pause_resume_cancel_and_bad_transitions_name_the_reason(store: Path) -> None:
    cid = int(
        ok("create", "--oracle", "aux-penalty", "--iterations", "3", "--config", str(store / "quick.yaml"))
        .strip()
        .splitlines()[-1]
    )
    bad = cli("resume", str(cid))
    assert bad.exit_code == 2 and "cannot resume a campaign that is draft" in bad.output
    ok("start", str(cid))
    assert "pausing" in ok("pause", str(cid))  # nothing has claimed the first step yet
    run_queued_steps(cid)  # the job sees the pause and parks its step
    assert status(cid)["campaign"]["status"] == "paused"
    ok("resume", str(cid))
    assert status(cid)["campaign"]["status"] == "running"
    assert "cancelled" in ok("cancel", str(cid))  # no step running: cancelled at once
    run_queued_steps(cid)  # the message resume sent: a no-op now
    d = status(cid)
    assert (d["campaign"]["status"], d["campaign"]["stop_reason"]) == ("cancelled", "cancelled")
    missing = cli("status", "999999")
    assert missing.exit_code == 2 and "campaign" in missing.output and "999999" in missing.output, missing.output


def test_run_refuses_an_unknown_strategy_naming_the_setting(store: Path) -> None:
    """`campaign run --strategy` goes into the campaign's settings and is validated there (before any worker starts)."""
    bad = cli(
        "run", "--no-worker", "--task", "head-headrest-scenarios", "--strategy", "greedy", "--oracle", "aux-penalty"
    )
    assert bad.exit_code == 2 and "settings.strategy" in bad.output, bad.output


@pytest.mark.parametrize(
    ("args", "field"),
    [
        (["--strategy", "paper", "--batch", "2"], "settings.batch"),
        (["--strategy", "ensemble-disagreement", "--batch", "4", "--candidates", "2"], "settings.batch"),
        (["--strategy", "random-scenarios", "--batch", "0"], "settings.batch"),
        (["--strategy", "ensemble-disagreement", "--candidates", "65"], "settings.candidates"),
        (["--strategy", "random-scenarios", "--max-oracle-jobs", "0"], "settings.max_concurrent_oracle_jobs"),
        (["--strategy", "ensemble-disagreement", "--min-disagreement", "-1"], "stopping.min_disagreement"),
    ],
)
def test_run_refuses_bad_batch_settings_naming_the_field(store: Path, args: list[str], field: str) -> None:
    bad = cli("run", "--no-worker", "--task", "head-headrest-scenarios", "--oracle", "aux-penalty", *args)
    assert bad.exit_code == 2 and field in bad.output, bad.output


def test_run_refuses_ensemble_disagreement_with_an_ensemble_of_one(store: Path, tmp_path: Path) -> None:
    cfg = tmp_path / "one.yaml"
    cfg.write_text("surrogate: {ensemble_size: 1}\n")
    args = ["--strategy", "ensemble-disagreement", "--batch", "2", "--candidates", "4", "--config", str(cfg)]
    bad = cli("run", "--no-worker", "--task", "head-headrest-scenarios", "--oracle", "aux-penalty", *args)
    assert bad.exit_code == 2 and "settings.strategy" in bad.output and "no disagreement" in bad.output, bad.output


@pytest.mark.parametrize(
    ("config", "message"),
    [
        ({"surrogate": {"validation_motions": 2}}, "error: surrogate.validation_motions: Extra inputs"),
        ({"surrogate": {"ensemble_size": 0}}, "error: surrogate.ensemble_size:"),
        ({"oracle_params": {"penalty": -1}}, "error: oracle_params.penalty:"),
        ({"task_spec": {"phases": []}}, "error: task_spec.phases"),
    ],
)
def test_a_bad_config_section_names_the_field_inside_it(store: Path, config: dict[str, Any], message: str) -> None:
    """A bad value in a --config section is named with the section's path, and no campaign is made."""
    cfg = store / "bad.json"
    cfg.write_text(json.dumps(config))
    bad = cli("run", "--no-worker", "--oracle", "aux-penalty", "-n", "1", "--config", str(cfg))
    assert bad.exit_code == 2 and bad.output.strip().splitlines()[-1].startswith(message), bad.output
    assert json.loads(ok("list", "--json")) == []


def test_the_json_report_gives_each_iterations_oracle_calls_and_picked_scenarios(store: Path) -> None:
    """What `campaign run --json` prints per iteration (``follow.read_metrics``): for an
    ensemble-disagreement batch, its oracle calls and the picked scenarios with their scores and
    in-loop RMSE, whose mean is the iteration's."""
    from alcove_worker.cli.follow import read_metrics

    cfg = store / "batch.yaml"
    # seed 3, C = 4 (as tests/campaigns/test_batch.py): candidates that reach the headrest (those
    # without contact are never picked)
    # float64 training and the paper's shared force net: the scenario (two of the four candidates reach
    # the headrest) was set up with them
    cfg.write_text(
        QUICK_YAML.replace(
            "validation_motions: 2",
            "validation_motions: 0, strategy: ensemble-disagreement, batch: 2, candidates: 4, min_distance: 0",
        ).replace("ensemble_size: 2}", "ensemble_size: 2, dtype: float64, normal_force: shared}")
    )
    out = ok(
        "create",
        "--task",
        "head-headrest-scenarios",
        "--oracle",
        "aux-penalty",
        "-n",
        "1",
        "--seed",
        "3",
        "--config",
        str(cfg),
    )
    cid = int(out.strip())
    ok("start", str(cid))
    run_queued_steps(cid)
    (row,) = read_metrics(cid)
    assert row["iteration_index"] == 1 and row["oracle_calls"] == 2
    assert [p["pick"] for p in row["picks"]] == [0, 1]
    assert row["picks"][0]["score"] >= row["picks"][1]["score"]
    assert all(p["scenario"]["iteration"] == 1 and p["slot"] in range(4) for p in row["picks"])
    assert row["force_rmse"] == pytest.approx(sum(p["force_rmse"] for p in row["picks"]) / 2, rel=1e-12)

    # `campaign candidates`: the API route's rows (same service function), as JSON and as a table
    api = json.loads(ok("candidates", str(cid), "1", "--json"))
    assert api["iteration_index"] == 1 and api["batch"] == 2 and len(api["candidates"]) == 4
    picked = sorted((c for c in api["candidates"] if c["pick"] is not None), key=lambda c: c["pick"])
    assert [c["slot"] for c in picked] == [p["slot"] for p in row["picks"]]
    assert picked[0]["why"]["code"] == "picked-top" and picked[0]["rank"] == 1
    table = ok("candidates", str(cid), "1")
    for c in api["candidates"]:
        line = next((ln for ln in table.splitlines() if re.match(rf"^│\s+{c['slot']}\s+│", ln)), "")
        first = next(iter(c["scenario"]["values"]))
        assert c["why"]["code"] in line and first in line, (c, table)
    assert "picked-top" in table and "q = 2" in table
    # bad input names the argument and exits 2
    for args, says in (
        ([str(cid + 99), "1"], f"error: campaign_id: campaign {cid + 99} not found"),
        ([str(cid), "7"], f"error: iteration: campaign {cid} has no iteration 7"),
        ([str(cid), "0"], "Invalid value for 'iteration'"),
    ):
        bad = cli("candidates", *args)
        assert bad.exit_code == 2 and says in bad.output, (args, bad.output)
