"""Campaign engine (``python -m bench.run --only "campaign:"``): orchestration overhead per step
and per iteration, a short campaign's wall time, and the paper's 200-iteration campaign (full
mode only).

Every campaign here runs the real path: ``alcove campaign run`` in a subprocess, which
spawns one ``alcove worker`` on the embedded default (SQLite + filesystem broker, with the
polling interval ``alcove campaign run`` gives its worker) in a temporary ``ALCOVE_DATA_DIR``.
The numbers come from the step rows:

* bare compute = the science call of a step (``result.compute_s``: training, IPOPT, the
  oracle, the metrics);
* orchestration overhead of a step = time from its message being queued to its claim
  (``started_at - queued_at``: broker, polling, pickup) + its job's wall time minus the
  bare compute (claim, reading inputs, writing results, next message).
"""

from __future__ import annotations

import functools
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from bench import harness
from bench.harness import figure

SHORT_ITERATIONS = 4
STEPS = ("train", "ocp", "oracle", "evaluate", "append")


def short_iterations() -> int:
    """Iterations of the short campaigns: 4 (3 in --quick: iterations 2 and 3 are measured)."""
    return 3 if harness.quick() else SHORT_ITERATIONS


def _env(data_dir: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ALCOVE_")}
    env.update(ALCOVE_DATA_DIR=str(data_dir))
    return env


def run_campaign(oracle: str, iterations: int, config_yaml: str = "", extra: tuple[str, ...] = ()) -> dict[str, Any]:
    """Run a campaign through a spawned worker; return the CLI's JSON and per-step rows."""
    import sqlalchemy as sa

    tmp = Path(tempfile.mkdtemp(prefix="alcove-bench-campaign-"))
    argv = [
        sys.executable,
        "-m",
        "alcove_worker.cli.main",
        "campaign",
        "run",
        "--oracle",
        oracle,
        "--iterations",
        str(iterations),
        "--json",
        "--worker-log",
        str(tmp / "worker.log"),
        *extra,
    ]
    if config_yaml:
        (tmp / "config.yaml").write_text(config_yaml)
        argv += ["--config", str(tmp / "config.yaml")]
    r = subprocess.run(argv, env=_env(tmp / "data"), capture_output=True, text=True, timeout=4 * 3600)
    if r.returncode != 0:
        raise RuntimeError(f"campaign run failed ({r.returncode}):\n{r.stderr[-3000:]}")
    out = json.loads(r.stdout.strip().splitlines()[-1])
    eng = sa.create_engine(f"sqlite:///{tmp / 'data' / 'alcove.db'}")
    with eng.connect() as c:
        steps = [
            dict(row._mapping)
            for row in c.execute(
                sa.text(
                    'SELECT i."index" AS k, s.step, s.slot, s.wall_time_s, s.result, s.queued_at, s.started_at, '
                    "s.finished_at "
                    "FROM iteration_steps s JOIN iterations i ON i.id = s.iteration_id "
                    "WHERE s.campaign_id = :c ORDER BY s.id"
                ),
                {"c": out["campaign_id"]},
            )
        ]
    eng.dispose()
    for st in steps:
        st["result"] = json.loads(st["result"]) if isinstance(st["result"], str) else st["result"]
    out["steps"] = steps
    out["data_dir"] = str(tmp)
    return out


def _seconds(a: Any, b: Any) -> float:
    from datetime import datetime

    a, b = (datetime.fromisoformat(str(x)) for x in (a, b))
    return (b - a).total_seconds()


def breakdown(run: dict[str, Any]) -> dict[str, Any]:
    """Per-step overhead and per-iteration shares (iterations k >= 2: the worker is warm)."""
    per_step, per_iteration = [], {}
    step_compute: dict[str, list[float]] = {}
    for st in run["steps"]:
        if st["k"] < 1 or st["wall_time_s"] is None:
            continue
        latency = _seconds(st["queued_at"], st["started_at"])
        compute = float(st["result"].get("compute_s", 0.0))
        overhead = latency + max(st["wall_time_s"] - compute, 0.0)
        it = per_iteration.setdefault(
            st["k"],
            {"overhead": 0.0, "compute": 0.0, "first_queued": st["queued_at"], "last_finished": st["finished_at"]},
        )
        it["overhead"] += overhead
        it["compute"] += compute
        it["last_finished"] = st["finished_at"]
        if st["k"] >= 2:
            per_step.append((st["step"], overhead))
            step_compute.setdefault(st["step"], []).append(compute)
    shares, walls = [], []
    for k, it in per_iteration.items():
        if k < 2:
            continue
        wall = _seconds(it["first_queued"], it["last_finished"])
        walls.append(wall)
        shares.append(100.0 * it["overhead"] / wall)
    by_step: dict[str, list[float]] = {}
    for name, o in per_step:
        by_step.setdefault(name, []).append(o)
    return {
        "step_overhead_ms": [1000 * o for _, o in per_step],
        "by_step_ms": {k: 1000 * statistics.median(v) for k, v in by_step.items()},
        "compute_by_step_s": {k: statistics.median(v) for k, v in step_compute.items()},
        "overhead_per_iteration_ms": [1000 * it["overhead"] for k, it in per_iteration.items() if k >= 2],
        "share_percent": shares,
        "iteration_s": walls,
        "compute_s": [it["compute"] for k, it in per_iteration.items() if k >= 2],
    }


@functools.lru_cache
def short_campaign() -> dict[str, Any]:
    """fe-headrest-2d, the paper's settings, short_iterations() iterations."""
    run = run_campaign("fe-headrest-2d", short_iterations())
    run["breakdown"] = breakdown(run)
    b = run["breakdown"]
    compute = {k: round(v, 3) for k, v in b["compute_by_step_s"].items()}
    overhead = {k: round(v, 1) for k, v in b["by_step_ms"].items()}
    walls = [f"{w:.2f}" for w in b["iteration_s"]]
    shares = [f"{s:.1f}" for s in b["share_percent"]]
    print(
        f"  per-step compute medians [s]: {json.dumps(compute)}; "
        f"per-step overhead medians [ms]: {json.dumps(overhead)}; "
        f"iteration wall {walls} s, overhead share {shares} %"
    )
    return run


@figure(
    "campaign: orchestration overhead per step (median, fe-headrest-2d)",
    "ms",
    target=100.0,
    setup=short_campaign,
    reps=1,
    quick_reps=1,
    group="campaign",
    notes=f"steps of iterations 2..{SHORT_ITERATIONS} (3 in --quick); queue latency + job wall - compute; "
    "embedded default, 1 spawned worker",
)
def step_overhead(run: dict[str, Any]) -> float:
    return statistics.median(run["breakdown"]["step_overhead_ms"])


@figure(
    "campaign: orchestration overhead per step (max)",
    "ms",
    target=100.0,
    setup=short_campaign,
    reps=1,
    quick_reps=1,
    group="campaign",
)
def step_overhead_max(run: dict[str, Any]) -> float:
    return max(run["breakdown"]["step_overhead_ms"])


def _step_compute(step: str):
    def fn(run: dict[str, Any]) -> float:
        return run["breakdown"]["compute_by_step_s"].get(step, float("nan"))

    return fn


for _step in STEPS:
    figure(
        f"campaign: {_step} step bare compute (median, fe-headrest-2d)",
        "s",
        setup=short_campaign,
        reps=1,
        quick_reps=1,
        group="campaign",
        notes="the science call of the step (result.compute_s), iterations >= 2",
    )(_step_compute(_step))


@figure(
    "campaign: orchestration per iteration (median, sum over its 5 steps)",
    "ms",
    setup=short_campaign,
    reps=1,
    quick_reps=1,
    group="campaign",
    notes="its share of the iteration wall time is the next figure; "
    "the bare compute baseline is measured in the same run",
)
def iteration_overhead(run: dict[str, Any]) -> float:
    return statistics.median(run["breakdown"]["overhead_per_iteration_ms"])


@figure(
    "campaign: orchestration share of an iteration (median)",
    "%",
    target=5.0,
    setup=short_campaign,
    reps=1,
    quick_reps=1,
    group="campaign",
    notes="sum of the steps' overheads / iteration wall time (first message queued to append committed)",
)
def overhead_share(run: dict[str, Any]) -> float:
    return statistics.median(run["breakdown"]["share_percent"])


@figure(
    "campaign: iteration bare compute (train + ocp + oracle + evaluate)",
    "s",
    setup=short_campaign,
    reps=1,
    quick_reps=1,
    group="campaign",
    notes="baseline of the iteration wall time",
)
def iteration_compute(run: dict[str, Any]) -> float:
    return statistics.median(run["breakdown"]["compute_s"])


@figure(
    "campaign: iteration wall time (fe-headrest-2d)",
    "s",
    setup=short_campaign,
    reps=1,
    quick_reps=1,
    group="campaign",
    baseline="campaign: iteration bare compute (train + ocp + oracle + evaluate)",
    notes="target for the paper campaign with K = 5: 200 x 6 s = 20 min",
)
def iteration_wall(run: dict[str, Any]) -> float:
    return statistics.median(run["breakdown"]["iteration_s"])


@figure(
    f"campaign: short campaign wall time (aux-penalty, {SHORT_ITERATIONS} iterations (3 in --quick), "
    "30 intervals per phase, 1000 LHS samples)",
    "s",
    reps=1,
    quick_reps=1,
    group="campaign",
    notes="`alcove campaign run` end to end, including worker start-up and migrations",
)
def short_campaign_wall(_: Any) -> float:
    run = run_campaign(
        "aux-penalty", short_iterations(), "preliminary: {samples: 1000}\nsettings: {ocp_intervals: 30}\n"
    )
    return float(run["wall_time_s"])


@figure(
    "campaign: paper campaign, head-headrest-2phase x fe-headrest-2d, 200 iterations, K = 5 (the default)",
    "min",
    target=30.0,
    reps=1,
    quick_reps=1,
    quick=False,
    group="campaign",
    notes="target <= 30 min with the defaults: an ensemble of 5, each model version trained fully; the paper's "
    "final RMSE: force 3.32 N, moment 0.265 N m (its FE runs alone took about 10 h)",
)
def paper_campaign(_: Any) -> float:
    run = run_campaign("fe-headrest-2d", 200)
    b = breakdown(run)
    print(
        f"  first iteration RMSE: {run.get('first')}, last: {run.get('last')}; "
        f"status {run['status']} ({run['stop_reason']}); "
        f"median iteration {statistics.median(b['iteration_s']):.2f} s, "
        f"overhead share {statistics.median(b['share_percent']):.1f} %"
    )
    return float(run["wall_time_s"]) / 60.0


# ----------------------------------------------------------------------------- batches

BATCH_Q = 4


@functools.lru_cache
def batch_campaign(processes: int) -> dict[str, Any]:
    """random-scenarios with q = 4 on fe-headrest-2d (head-headrest-scenarios), 2 iterations,
    one spawned worker with ``processes`` pool processes (its oracle jobs run that many at once)."""
    run = run_campaign(
        "fe-headrest-2d",
        2,
        "settings: {validation_motions: 0}\n",
        (
            "--task",
            "head-headrest-scenarios",
            "--strategy",
            "random-scenarios",
            "--batch",
            str(BATCH_Q),
            "-c",
            str(processes),
        ),
    )
    oracle = [st for st in run["steps"] if st["k"] == 2 and st["step"] == "oracle"]
    wall = _seconds(min(st["queued_at"] for st in oracle), max(st["finished_at"] for st in oracle))
    run["oracle_wall_per_call_s"] = wall / len(oracle)
    # orchestration of iteration 2: every job's wall time minus its bare compute (claim, inputs, writes,
    # the fan-in, the next messages), plus the queue latency of the serial steps; the ocp and oracle
    # slots' queue time is mostly waiting for a free process behind their siblings (capacity, not overhead)
    steps = [st for st in run["steps"] if st["k"] == 2 and st["wall_time_s"] is not None]
    overhead = sum(max(st["wall_time_s"] - float(st["result"].get("compute_s", 0.0)), 0.0) for st in steps)
    overhead += sum(_seconds(st["queued_at"], st["started_at"]) for st in steps if st["step"] not in ("ocp", "oracle"))
    iteration = _seconds(min(st["queued_at"] for st in steps), max(st["finished_at"] for st in steps))
    run["overhead_share"] = 100.0 * overhead / iteration
    print(
        f"  {processes} process(es): iteration 2 took {iteration:.2f} s, its {len(oracle)} oracle jobs {wall:.2f} s "
        f"(bare compute {[round(float(st['result'].get('compute_s', 0)), 2) for st in oracle]} s); "
        f"orchestration {overhead:.2f} s"
    )
    return run


@figure(
    "campaign: batch q = 4, oracle wall time per oracle call, 2 worker processes / 1",
    "ratio",
    target=0.6,
    reps=1,
    quick_reps=1,
    group="campaign",
    notes="random-scenarios, fe-headrest-2d, iteration 2: first oracle job queued to last one finished, / q; "
    "one spawned worker with 2 pool processes vs 1 (on a shared machine the ratio also measures the load)",
)
def batch_parallel_ratio(_: Any) -> float:
    return batch_campaign(2)["oracle_wall_per_call_s"] / batch_campaign(1)["oracle_wall_per_call_s"]


@figure(
    "campaign: orchestration share of a batch iteration (q = 4, 2 processes)",
    "%",
    target=5.0,
    reps=1,
    quick_reps=1,
    group="campaign",
    notes="iteration 2: every job's wall time minus its bare compute (parallel slots counted each) + the queue "
    "latency of train, evaluate and append, over the iteration's wall time (first message queued to append "
    "committed); the slots' queue time, waiting for a free process behind their siblings, is not counted",
)
def batch_overhead_share(_: Any) -> float:
    return float(batch_campaign(2)["overhead_share"])
