"""Command oracles as Slurm jobs on the local test cluster (``.ci/slurm-up``: one node, 2 CPUs).

Four oracle calls of a batch iteration, each a program computing for 3 s of CPU
(``tests/oracles/sleepy_solver.py 3 burn``), run as four 1-CPU Slurm jobs at once (four
threads waiting, as four oracle-worker processes would), against one worker running the same
four calls one after the other with the local launcher. And the scheduler's overhead per call:
from the submission to the program's start, and from the program's end to the forces read
back by the oracle call (PSI/J polling squeue every 0.25 s).

The same pair with the real 3D oracle: four ``fe-headrest-3d-ccx`` replays of the paper's
example motion (about a minute of ccx CPU each, one thread), one after the other on one worker
against four 1-CPU Slurm jobs at once. With 3 s calls the scheduler's fixed costs (a pending job
starts at Slurm's next scheduling pass, up to 1 s after a CPU comes free) are a large share of the
wall time; with calls of an FE model they are not.
"""

from __future__ import annotations

import heapq
import statistics
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from bench.harness import figure, timed

ROOT = Path(__file__).resolve().parents[2]
SOLVER = ROOT / "tests" / "oracles" / "sleepy_solver.py"
CALLS = 4
CPU_SECONDS = 3.0
_last: dict[str, list[float]] = {}


def _requires() -> str | None:
    sys.path.insert(0, str(ROOT))
    from tests.oracles.slurm import slurm_is_up

    return slurm_is_up()


def _trajectory() -> Any:
    from alcove.science.series import Trajectory

    t = np.linspace(0.0, 0.4, 41)
    q = 0.2 * np.sin(np.pi * t / 0.4)
    return Trajectory(t=t, q=q[:, None], qd=np.gradient(q, t)[:, None])


def _oracle(scheduler: str) -> Any:
    import psij  # noqa: F401  (in the main thread: PSI/J wants its signal handlers there)

    from alcove.science.oracles.command import CommandOracleSpec
    from alcove.science.oracles.command.oracle import CommandOracle

    launcher: dict[str, Any] = {"scheduler": scheduler}
    if scheduler != "local":
        launcher.update(cpus_per_task=1, poll_s=0.25)
    spec = CommandOracleSpec(
        name=f"burn-{scheduler}",
        argv=[sys.executable, str(SOLVER), str(CPU_SECONDS), "burn"],
        timeout_s=120,
        workdir_root=Path(tempfile.mkdtemp(prefix="alcove-bench-batch-")),
        launcher=launcher,
    )
    return CommandOracle(spec), _trajectory()


def _ccx(scheduler: str) -> Any:
    import psij  # noqa: F401  (in the main thread, as above)

    from alcove.science.oracles.command.launcher import LauncherSpec
    from alcove.science.oracles.fe_headrest import reference_motion
    from alcove.science.oracles.fe_headrest_3d import CcxHeadrestOracle, CcxHeadrestParams

    batch = {"cpus_per_task": 1, "poll_s": 0.25} if scheduler != "local" else {}
    launcher = LauncherSpec(scheduler=scheduler, **batch)
    return CcxHeadrestOracle(CcxHeadrestParams(), launcher=launcher), reference_motion()


def _ccx_requires() -> str | None:
    from alcove.science.oracles.fe_headrest_3d import ccx_available

    return _requires() or ccx_available()


def waits_for_start(jobs: list[dict[str, Any]], cpus: int) -> list[float]:
    """Each job's wait from the moment it could have started (submitted, and a CPU free: the end
    of the job before it on that CPU) to its start: the scheduler's own latency, not the queue."""
    free = [0.0] * cpus
    heapq.heapify(free)
    waits = []
    for job in sorted(jobs, key=lambda j: j["started_at"]):
        could = max(job["submitted_at"], heapq.heappop(free))
        waits.append(job["started_at"] - could)
        heapq.heappush(free, job["ended_at"])
    return waits


def _run_ok(oracle: Any, trajectory: Any) -> Any:
    result = oracle.run(trajectory)
    assert result.ok, result.failure_reason
    return result


def _in_sequence(ctx: Any) -> float:
    """Wall time of the four calls one after the other (one worker)."""
    oracle, trajectory = ctx
    return timed(lambda: [_run_ok(oracle, trajectory) for _ in range(CALLS)])


def _at_once(ctx: Any) -> tuple[float, list[Any], list[float]]:
    """The four calls at once (four waiting threads, as four oracle-worker processes): wall time,
    results, and when each result was back (epoch seconds, in the order they came back)."""
    oracle, trajectory = ctx
    returned: list[float] = []

    def one(_: int) -> Any:
        result = _run_ok(oracle, trajectory)
        returned.append(time.time())
        return result

    t0 = time.perf_counter()
    with ThreadPoolExecutor(CALLS) as pool:
        results = list(pool.map(one, range(CALLS)))
    return time.perf_counter() - t0, results, returned


@figure(
    "batch oracle: 4 calls in sequence on one worker (local launcher, 3 s CPU each)",
    "s",
    setup=lambda: _oracle("local"),
    reps=2,
    quick_reps=1,
    group="oracles",
    requires=_requires,
    quick=False,
)
def sequential_four(ctx: Any) -> float:
    return _in_sequence(ctx)


@figure(
    "batch oracle: 4 calls as 1-CPU Slurm jobs at once (2-CPU node), wall",
    "s",
    setup=lambda: _oracle("slurm"),
    reps=2,
    quick_reps=1,
    group="oracles",
    requires=_requires,
    quick=False,
    baseline="batch oracle: 4 calls in sequence on one worker (local launcher, 3 s CPU each)",
    notes="target: <= 0.6x the sequential baseline (ratio column)",
)
def slurm_four(ctx: Any) -> float:
    wall, results, returned = _at_once(ctx)
    jobs = [r.diagnostics["batch_job"] for r in results]
    _last["to_start"] = waits_for_start(jobs, cpus=2)
    ends = sorted(j["ended_at"] for j in jobs)
    _last["to_result"] = [max(0.0, back - end) for back, end in zip(sorted(returned), ends, strict=True)]
    return wall


@figure(
    "batch oracle: 4 fe-headrest-3d-ccx replays in sequence on one worker (local launcher, 1 thread each)",
    "s",
    setup=lambda: _ccx("local"),
    reps=1,
    quick_reps=1,
    group="oracles",
    requires=_ccx_requires,
    quick=False,
    notes="the paper's example motion (1 s, 401 outputs), default mesh",
)
def ccx_sequential_four(ctx: Any) -> float:
    return _in_sequence(ctx)


@figure(
    "batch oracle: 4 fe-headrest-3d-ccx replays as 1-CPU Slurm jobs at once (2-CPU node), wall",
    "s",
    setup=lambda: _ccx("slurm"),
    reps=1,
    quick_reps=1,
    group="oracles",
    requires=_ccx_requires,
    quick=False,
    baseline="batch oracle: 4 fe-headrest-3d-ccx replays in sequence on one worker (local launcher, 1 thread each)",
    notes="target: <= 0.6x the sequential baseline (ratio column); ccx's threads = the job's CPUs (1)",
)
def ccx_slurm_four(ctx: Any) -> float:
    wall, results, _ = _at_once(ctx)
    forces = [r.forces.force for r in results]
    # the same motion gives the same forces whichever way it ran: nothing was lost in the batch jobs
    assert all(np.allclose(f, forces[0], rtol=1e-6, atol=1e-6) for f in forces), "batch replays differ"
    return wall


@figure(
    "batch oracle: Slurm overhead per call, submission (or a CPU free) to start (mean of 4)",
    "s",
    target=2.0,
    reps=1,
    quick_reps=1,
    group="oracles",
    requires=_requires,
    quick=False,
    notes="the last run of the 4 jobs: from its submission, or the end of the job before it on its CPU",
)
def overhead_to_start(_: Any) -> float:
    return statistics.mean(_last["to_start"]) if _last else float("nan")


@figure(
    "batch oracle: Slurm overhead per call, end to result read back (mean of 4)",
    "s",
    target=2.0,
    reps=1,
    quick_reps=1,
    group="oracles",
    requires=_requires,
    quick=False,
    notes="squeue polled every 0.25 s, then the forces file read and checked",
)
def overhead_to_result(_: Any) -> float:
    return statistics.mean(_last["to_result"]) if _last else float("nan")
