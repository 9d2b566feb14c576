"""A node failure under a running oracle call, on the real test cluster (``.ci/slurm-up``): the
node is taken down while the program runs. Slurm ends the job as NODE_FAIL (alcove submits
with ``--no-requeue``, so Slurm does not run the program again behind the campaign's back), the
call fails naming the node failure, and the oracle's retry policy decides what follows.

Runs alone (``tests/conftest.py``): the cluster has one node, so every Slurm job beside this
test would fail with it."""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from alcove.science.oracles.command import CommandOracleSpec
from alcove.science.oracles.command.batch import JOB_TIMES, MemoryBook, SchedulerFailure, job_times
from alcove.science.oracles.command.launcher import LauncherSpec
from alcove.science.oracles.command.oracle import CommandOracle
from tests.oracles.slurm import SOLVER, slurm_is_up
from tests.oracles.test_batch_launcher import trajectory

pytestmark = pytest.mark.integration


def _scontrol(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(["scontrol", *args], capture_output=True, text=True, timeout=30)


def _node_state(node: str) -> str:
    got = subprocess.run(["sinfo", "-h", "-n", node, "-o", "%T"], capture_output=True, text=True, timeout=30)
    return got.stdout.strip()


def _bring_back(node: str, timeout: float = 60) -> None:
    """Wait until ``node`` is up again (``ReturnToService=2`` brings a node back when its slurmd
    registers again), resuming it where that has not happened yet."""
    deadline = time.monotonic() + timeout
    while _node_state(node) not in ("idle", "mixed", "allocated") and time.monotonic() < deadline:
        if _node_state(node).startswith("down"):
            _scontrol("update", f"nodename={node}", "state=resume")
        time.sleep(0.5)


@pytest.fixture
def node() -> Iterator[str]:
    """The cluster's node, up again after the test."""
    why = slurm_is_up()
    if why:
        pytest.skip(why)
    name = subprocess.run(["sinfo", "-h", "-o", "%N"], capture_output=True, text=True, timeout=30).stdout.strip()
    yield name
    _bring_back(name)
    assert slurm_is_up() is None, f"the test cluster's node {name} did not come back: {_node_state(name)}"


def test_a_node_failing_under_a_running_call_fails_the_call_naming_it_and_slurm_does_not_rerun_it(
    node: str, tmp_path: Path
):
    runs = tmp_path / "runs.log"
    spec = CommandOracleSpec(
        name="sleepy",
        argv=[sys.executable, str(SOLVER), "30"],
        timeout_s=120,
        workdir_root=tmp_path / "jobs",
        launcher=LauncherSpec(scheduler="slurm", poll_s=0.2, env={"SLEEPY_RUN_LOG": str(runs)}),
    )
    book = MemoryBook()
    downed: list[float] = []

    def node_fails_once_the_program_runs() -> bool:  # polled while the call waits; never cancels
        if not downed and runs.exists() and book.jobs and book.jobs[-1].state == "running":
            got = _scontrol("update", f"nodename={node}", "state=down", "reason=alcove-test-node-failure")
            assert got.returncode == 0, got.stderr
            downed.append(time.monotonic())
        return False

    started = time.monotonic()
    with pytest.raises(SchedulerFailure, match=r"^slurm job \d+: a node of the job failed$"):
        CommandOracle(spec).run(trajectory(), cancel=node_fails_once_the_program_runs, batch_book=book)
    assert downed, "the program never ran"
    assert time.monotonic() - started < 25, "the call waited for the program instead of failing with the node"
    (job,) = book.jobs
    assert (job.state, job.reason) == ("failed", "a node of the job failed")
    workdir = Path(job.workdir)
    assert job_times(workdir)[1] is None, f"the program ended normally: {(workdir / JOB_TIMES).read_text()}"
    # Slurm did not requeue it: the job stays ended and the program ran once, also after the node is back
    _bring_back(node)
    time.sleep(3)
    shown = _scontrol("show", "job", job.job_id).stdout
    assert "JobState=NODE_FAIL" in shown and "Restarts=0" in shown, shown
    assert len(runs.read_text().splitlines()) == 1
