"""Command oracles as Slurm jobs, against a real Slurm (``.ci/slurm-up``: one node, 2 CPUs), with
PostgreSQL, Redis and real worker processes:

* a batch iteration's q oracle calls run as q Slurm jobs at once (as many as the CPUs allow);
* a job the scheduler kills at its time limit fails its oracle call with that reason; pausing
  the campaign cancels its other job, still running (the call runs again after the resume),
  and cancelling the campaign cancels the job it is waiting for;
* an oracle worker SIGKILLed while its job runs, then started again: the next attempt attaches
  to the same job (never submitted twice), the program runs once and its result lands once.

The program is ``sleepy_solver.py`` (sleeps, writes zero forces, logs each run). Skipped without
Slurm's commands; under CI a skip is a failure (``tests/conftest.py``).
"""

from __future__ import annotations

import itertools
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import yaml

from tests.oracles.slurm import SOLVER, slurm_is_up
from tests.procs import db_rows, run_cli, start_worker, stop_all, unique
from tests.procs import wait_until as wait_for

pytestmark = [pytest.mark.integration, pytest.mark.slow]

TASK = "head-headrest-scenarios"
LIGHT: dict[str, Any] = {"preliminary": {"samples": 200, "chunks": 2}, "surrogate": {"max_epochs": 20}}
ENDED = "SELECT status, stop_reason FROM campaigns WHERE id = :c AND status IN ('completed', 'failed', 'cancelled')"
JOBS = (
    "SELECT j.job_id, j.state, j.reason, j.attempt, s.slot, j.started_at, j.ended_at, j.worker_name "
    "FROM oracle_batch_jobs j JOIN iteration_steps s ON s.id = j.step_id WHERE j.campaign_id = :c ORDER BY j.id"
)
#: dead-worker detection in seconds (heartbeat 1 s, dead after 4 s, reconciler every 1 s)
QUICK_DEATH = {
    "ALCOVE_WORKER_HEARTBEAT_SECONDS": "1",
    "ALCOVE_WORKER_DEAD_SECONDS": "4",
    "ALCOVE_RECONCILE_SECONDS": "1",
}


@pytest.fixture
def pg_url(fresh_pg_url: str) -> str:
    return fresh_pg_url


@pytest.fixture
def slurm(tmp_path: Path) -> Path:
    """The test catalogue of Slurm entries (its path); skips when Slurm is down."""
    why = slurm_is_up()
    if why is not None:
        pytest.skip(why)
    jobs = tmp_path / "jobs"
    jobs.mkdir()
    launcher = {
        "scheduler": "slurm",
        "cpus_per_task": 1,
        "time_limit_s": 60,
        "poll_s": 0.25,
        "job_root": str(jobs),
        "env": {"SLEEPY_RUN_LOG": str(tmp_path / "runs.log")},
    }
    catalogue = {
        "command_oracles": {
            f"slurm-{name}": {
                "argv": [sys.executable, str(SOLVER), str(seconds)],
                "timeout_s": 60,
                "launcher": launcher,
            }
            for name, seconds in (("quick", 2), ("mid", 6), ("long", 300))
        }
    }
    path = tmp_path / "catalogue.yaml"
    path.write_text(yaml.safe_dump(catalogue))
    return path


@pytest.fixture
def env(pg_redis: dict[str, str], slurm: Path, monkeypatch: pytest.MonkeyPatch) -> dict[str, str]:
    """Settings of this process and its workers, with the Slurm catalogue."""
    from alcove.settings import get_settings

    monkeypatch.setenv("ALCOVE_COMMAND_ORACLES_FILE", str(slurm))
    get_settings.cache_clear()
    return {**pg_redis, "ALCOVE_COMMAND_ORACLES_FILE": str(slurm), **QUICK_DEATH}


def start(make_campaign: Any, oracle: str, q: int, **policies: Any) -> int:
    """A one-iteration batch campaign of ``q`` picks on a Slurm entry, started through the outbox."""
    from alcove.campaigns import service
    from alcove.db import run_transaction
    from alcove.jobs.campaign import send_committed, stage

    cid, _ = make_campaign(
        oracle=oracle,
        task=TASK,
        seed=7,
        settings={"strategy": "random-scenarios", "batch": q, "validation_motions": 0},
        stopping={"max_iterations": 1},
        policies=policies,
        start=False,
        **LIGHT,
    )
    send_committed(run_transaction(lambda s: stage(s, service.start(s, cid)[1])))
    return cid


def runs(tmp_path: Path) -> list[list[str]]:
    log = tmp_path / "runs.log"
    return [line.split() for line in log.read_text().splitlines()] if log.exists() else []


def scheduler_state(job_id: str) -> str:
    out = subprocess.run(["squeue", "-h", "-t", "all", "-j", job_id, "-o", "%t"], capture_output=True, text=True)
    return out.stdout.strip()


def test_a_batch_iterations_oracle_calls_run_as_slurm_jobs_at_once(
    env: dict[str, str], pg_url: str, tmp_path: Path, make_campaign: Any
) -> None:
    """q = 4 picks, each a 1-CPU job of about 2 s on the 2-CPU node: the four jobs run two at a
    time (their run intervals overlap), each call's result lands once, the campaign completes."""
    cid = start(make_campaign, "slurm-quick", 4)
    worker = start_worker(env, tmp_path / "w.log", unique("w"), concurrency=4)
    try:
        wait_for(lambda: db_rows(pg_url, ENDED, c=cid), 180, "the campaign to end", worker)
    finally:
        stop_all([worker])
    assert db_rows(pg_url, ENDED, c=cid) == [("completed", "max_iterations")]
    jobs = db_rows(pg_url, JOBS, c=cid)
    assert sorted(j[4] for j in jobs) == [0, 1, 2, 3]
    assert {j[1] for j in jobs} == {"collected"}
    assert len({j[0] for j in jobs}) == 4 and len(runs(tmp_path)) == 4
    assert {r[2] for r in runs(tmp_path)} == {"1"}  # the job's CPUs reach the program
    intervals = sorted((j[5], j[6]) for j in jobs)
    overlapping = sum(1 for a, b in itertools.pairwise(intervals) if b[0] < a[1])
    assert overlapping >= 1, intervals
    assert db_rows(pg_url, "SELECT count(*) FROM datasets WHERE campaign_id = :c AND origin = 'oracle'", c=cid) == [
        (4,)
    ]
    stored = db_rows(
        pg_url,
        "SELECT submitted_at, started_at, ended_at, collected_at FROM oracle_batch_jobs WHERE campaign_id = :c",
        c=cid,
    )
    print(  # the scheduler's overhead per call, from the rows (docs/scale.md; no timing asserts here)
        "\nBATCH end to result stored: mean "
        f"{sum((c - e).total_seconds() for _, _, e, c in stored) / len(stored):.2f} s; "
        f"submission to start (two wait for a CPU): {sorted(round((b - a).total_seconds(), 2) for a, b, *_ in stored)}"
    )
    # shown: each oracle step's job in the API's job list and in `alcove campaign status`
    from alcove.campaigns.views import detail
    from alcove.db import open_transaction

    with open_transaction() as s:
        listed = [j for j in detail.list_jobs(s, cid) if j["step"] == "oracle"]
    assert sorted((j["slot"], j["batch_jobs"][0]["state"]) for j in listed) == [(k, "collected") for k in range(4)]
    assert {j["batch_jobs"][0]["job_id"] for j in listed} == {j[0] for j in jobs}
    status = run_cli(["campaign", "status", str(cid)], env)
    assert status.returncode == 0, status.stderr
    for job_id, *_ in jobs:
        assert f"slurm job {job_id} collected" in status.stdout, status.stdout


def test_a_time_limit_fails_its_call_and_pausing_or_cancelling_the_campaign_cancels_its_jobs(
    env: dict[str, str], pg_url: str, tmp_path: Path, make_campaign: Any
) -> None:
    """Two picks whose program would run 300 s. Slot 0's job is brought to its time limit (its end
    moved to now: Slurm counts limits in minutes); Slurm kills it, and its oracle call fails
    naming the time limit (one attempt allowed). Then the campaign is paused: slot 1's running
    job is cancelled in Slurm and its step waits, pending; the resume submits the call again as
    a new job; cancelling the campaign cancels that one."""
    from alcove.campaigns import service
    from alcove.db import run_transaction

    slot_step = "SELECT status, error FROM iteration_steps WHERE campaign_id = :c AND step = 'oracle' AND slot = :k"
    cid = start(make_campaign, "slurm-long", 2, oracle_max_attempts=1)
    worker = start_worker(env, tmp_path / "w.log", unique("w"), concurrency=2)
    try:
        jobs = wait_for(
            lambda: (j := db_rows(pg_url, JOBS, c=cid)) and len(j) == 2 and all(r[1] == "running" for r in j) and j,
            180,
            "two running Slurm jobs",
            worker,
        )
        by_slot = {j[4]: j for j in jobs}
        subprocess.run(["scontrol", "update", f"JobId={by_slot[0][0]}", "EndTime=now"], check=True)
        step = wait_for(
            lambda: (r := db_rows(pg_url, slot_step, c=cid, k=0)) and r[0][0] == "failed" and r[0],
            90,
            "the time limit to end slot 0's job and fail its step",
            worker,
        )
        assert "the scheduler killed the job at its time limit" in step[1]
        assert [j[1] for j in db_rows(pg_url, JOBS, c=cid) if j[4] == 0] == ["failed"]
        assert scheduler_state(by_slot[0][0]) == "TO"

        run_transaction(lambda s: service.pause(s, cid))
        wait_for(
            lambda: db_rows(pg_url, "SELECT 1 FROM campaigns WHERE id = :c AND status = 'paused'", c=cid),
            60,
            "the campaign to pause",
            worker,
        )
        assert db_rows(pg_url, slot_step, c=cid, k=1)[0][0] == "pending"
        assert [j[1] for j in db_rows(pg_url, JOBS, c=cid) if j[4] == 1] == ["cancelled"]
        wait_for(lambda: scheduler_state(by_slot[1][0]) == "CA", 10, "Slurm to show the paused call's job cancelled")

        run_transaction(lambda s: service.resume(s, cid))
        again = wait_for(
            lambda: [j for j in db_rows(pg_url, JOBS, c=cid) if j[4] == 1 and j[1] == "running"],
            60,
            "the resumed call's new job to run",
            worker,
        )
        assert again[0][0] != by_slot[1][0]
        run_transaction(lambda s: service.cancel(s, cid))
        wait_for(lambda: db_rows(pg_url, ENDED, c=cid), 60, "the campaign to be cancelled", worker)
    finally:
        stop_all([worker])
    assert db_rows(pg_url, ENDED, c=cid)[0][0] == "cancelled"
    assert [j[1] for j in db_rows(pg_url, JOBS, c=cid) if j[4] == 1] == ["cancelled", "cancelled"]
    wait_for(lambda: scheduler_state(again[0][0]) == "CA", 10, "Slurm to show the job cancelled")


def test_a_worker_killed_while_its_job_runs_reattaches_and_the_job_runs_once(
    env: dict[str, str], pg_url: str, tmp_path: Path, make_campaign: Any
) -> None:
    """Two workers; the one waiting for the oracle step's Slurm job (6 s) is SIGKILLed while the
    job runs. The other takes the step as its next attempt (once the dead worker's heartbeat is
    stale) and attaches to the same job: one job, one run of the program, one result."""
    cid = start(make_campaign, "slurm-mid", 1)
    workers = {name: start_worker(env, tmp_path / f"{name}.log", name) for name in (unique("a"), unique("b"))}

    def alive() -> Any:
        return next(p for p in workers.values() if p.alive())

    try:
        job = wait_for(
            lambda: (j := db_rows(pg_url, JOBS, c=cid)) and j[0][1] == "running" and j[0],
            180,
            "the Slurm job to run",
            alive(),
        )
        workers[job[7].split("@")[0]].kill()
        wait_for(lambda: db_rows(pg_url, ENDED, c=cid), 120, "the campaign to end", alive())
    finally:
        stop_all(workers.values())
    assert db_rows(pg_url, ENDED, c=cid) == [("completed", "max_iterations")]
    jobs = db_rows(pg_url, JOBS, c=cid)
    assert [(j[0], j[1], j[3]) for j in jobs] == [(job[0], "collected", 1)]
    assert jobs[0][7] != job[7]  # collected by the second worker
    assert len(runs(tmp_path)) == 1
    assert db_rows(
        pg_url,
        "SELECT status, attempts FROM iteration_steps WHERE campaign_id = :c AND step = 'oracle'",
        c=cid,
    ) == [("succeeded", 2)]
    assert db_rows(pg_url, "SELECT count(*) FROM datasets WHERE campaign_id = :c AND origin = 'oracle'", c=cid) == [
        (1,)
    ]
