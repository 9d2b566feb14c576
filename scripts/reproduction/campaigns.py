"""Running a reproduction campaign to its end: through the spawned ``alcove worker`` (default)
or in this process (``--inline``), with a progress line, and the breakdown of its step times."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import typer

from .record import TASK


@dataclass
class CampaignRun:
    campaign_id: int
    label: str
    status: str
    stop_reason: str | None
    error: str | None
    wall: float
    metrics: list[Any]
    curves: Any | None
    iterations_failed: int = 0
    steps: list[dict[str, Any]] = field(default_factory=list)
    breakdown: dict[str, Any] = field(default_factory=dict)


def fresh_store(data_dir: Path) -> None:
    """Point alcove at a fresh embedded store in ``data_dir`` (before alcove reads its settings)."""
    data_dir.mkdir(parents=True, exist_ok=True)
    os.environ["ALCOVE_DATA_DIR"] = str(data_dir)
    os.environ["ALCOVE_DATABASE_URL"] = ""
    os.environ["ALCOVE_BROKER_URL"] = ""
    from alcove.db import migrate
    from alcove.settings import get_settings

    get_settings.cache_clear()
    migrate.upgrade()


#: set by ``--celery``: the spawned `alcove worker` process that runs the steps
WORKER: dict[str, Any] = {}


class Progress:
    """A progress line on stderr at most every ``every`` s: iteration, RMSE, elapsed, ETA."""

    def __init__(self, campaign_id: int, label: str, t0: float, every: float = 30.0):
        self.campaign_id, self.label, self.t0, self.every = campaign_id, label, t0, every
        self.last = 0.0

    def __call__(self, force: bool = False) -> str:
        from alcove.campaigns.views import detail
        from alcove.db import open_transaction

        now = time.perf_counter()
        if not force and now - self.last < self.every:
            return ""
        self.last = now
        with open_transaction() as s:
            d = detail.get_detail(s, self.campaign_id)
        c, m = d.campaign, d.latest_metrics
        total = d.config.stopping.max_iterations
        rmse = (
            f"force RMSE {m.force_rmse:.3g} N, moment RMSE {m.moment_rmse:.3g} N m"
            if m is not None and m.force_rmse is not None
            else "no RMSE yet"
        )
        eta = f", ETA {d.eta_s / 60:.1f} min" if d.eta_s is not None else ""
        typer.echo(
            f"[reproduce]   {self.label}: iteration {c.current_iteration}/{total} ({c.status.value}), {rmse}, "
            f"{(now - self.t0) / 60:.1f} min{eta}",
            err=True,
        )
        return c.status.value


def _wait_for_workers(campaign_id: int, progress: Progress, poll: float = 0.5) -> None:
    from alcove.campaigns.views import detail
    from alcove.db import open_transaction

    while True:
        with open_transaction() as s:
            status = detail.get_campaign(s, campaign_id).status.value
        if status in ("completed", "cancelled", "failed"):
            return
        proc = WORKER["process"]
        if proc.poll() is not None:
            # a worker that died is replaced (twice at most): the campaign lives in the database
            # and the new worker's reconciler re-enqueues the step it was running once its lease expires
            WORKER["restarts"] = WORKER.get("restarts", 0) + 1
            if WORKER["restarts"] > 2:
                raise RuntimeError(f"the alcove worker exited with code {proc.returncode} (log: {WORKER['log']})")
            from alcove_worker.cli.follow import spawn_worker

            typer.echo(
                f"[reproduce]   the worker exited with code {proc.returncode}; "
                f"starting another one (log: {WORKER['log']})",
                err=True,
            )
            WORKER["process"] = spawn_worker(WORKER["concurrency"], log_path=WORKER["log"])
        progress()
        time.sleep(poll)


def _drive(campaign_id: int, jobs: list[Any], label: str, t0: float) -> CampaignRun:
    """Run the campaign's steps to its end: by the spawned Celery worker (default) or in this process."""
    from alcove.campaigns.run.protocol import run_step
    from alcove.campaigns.views import detail
    from alcove.db import open_transaction

    progress = Progress(campaign_id, label, t0)
    if WORKER:
        from alcove.jobs.campaign import enqueue

        enqueue(jobs)
        _wait_for_workers(campaign_id, progress)
    else:  # protocol.drive_inline with a progress line
        queue = list(jobs)
        while queue:
            j = queue.pop(0)
            run_step(j.campaign_id, j.iteration, j.step.value, j.attempt, worker_name="inline", send=queue.extend)
            progress()
    wall = time.perf_counter() - t0
    progress(force=True)
    _finish_validation(campaign_id)
    with open_transaction() as s:
        c = detail.get_campaign(s, campaign_id)
        failed = detail.get_detail(s, campaign_id).iterations_failed
        metrics = detail.metrics_series(s, campaign_id)
        done = [m for m in metrics if m.force_rmse is not None]
        curves = detail.iteration_curves(s, campaign_id, done[-1].iteration_index) if done else None
        steps = [j for j in detail.list_jobs(s, campaign_id, ["succeeded"]) if j["iteration"] > 0]
    return CampaignRun(campaign_id, label, c.status.value, c.stop_reason, c.error, wall, metrics, curves, failed, steps)


def _finish_validation(campaign_id: int) -> None:
    """The held-out validation suite's replays and the evaluation of every model version on it
    (not part of the campaign's wall time): by the worker, or in this process with --inline."""
    from alcove.campaigns.views import detail
    from alcove.db import open_transaction

    if WORKER:
        from alcove_worker.cli.follow import wait_validation

        wait_validation(campaign_id, timeout=900.0)
        return
    from alcove.models import ValidationMotion
    from alcove.oracles.validation import run_motion
    from alcove.surrogates.validation import evaluate_suite

    with open_transaction() as s:
        suite = detail.get_detail(s, campaign_id).validation
        ids = (
            []
            if suite is None
            else [m.id for m in s.query(ValidationMotion).filter_by(suite_id=suite.id, status="queued")]
        )
    for i in ids:
        run_motion(i, "inline")
    if suite is not None:
        evaluate_suite(suite.id)


def step_breakdown(steps: list[dict[str, Any]]) -> dict[str, Any]:
    """Per-step median wall and bare compute, per-iteration wall times and the orchestration
    share (queue latency + job wall - compute, summed over the steps, over the campaign's
    step time from the first queued message to the last finished step)."""
    import numpy as np

    by_step: dict[str, dict[str, list[float]]] = {}
    overhead, iterations, per_iteration = 0.0, {}, {}
    for j in steps:
        if j["wall_time_s"] is None:
            continue
        name = getattr(j["step"], "value", j["step"])
        compute = float((j["result"] or {}).get("compute_s", 0.0))
        latency = (j["started_at"] - j["queued_at"]).total_seconds() if j["started_at"] and j["queued_at"] else 0.0
        d = by_step.setdefault(name, {"wall": [], "compute": []})
        d["wall"].append(float(j["wall_time_s"]))
        d["compute"].append(compute)
        o = max(latency, 0.0) + max(float(j["wall_time_s"]) - compute, 0.0)
        overhead += o
        per_iteration[j["iteration"]] = per_iteration.get(j["iteration"], 0.0) + o
        if j["queued_at"] is None or j["finished_at"] is None:
            continue
        it = iterations.setdefault(j["iteration"], [j["queued_at"], j["finished_at"]])
        it[0], it[1] = min(it[0], j["queued_at"]), max(it[1], j["finished_at"])
    walls = {k: (b - a).total_seconds() for k, (a, b) in iterations.items() if a and b}
    span = sum(walls.values())
    warm = [k for k in walls if k > min(walls)] or list(walls)  # the first iteration carries the worker's warm-up
    shares = [100.0 * per_iteration[k] / walls[k] for k in warm if walls[k] > 0 and k in per_iteration]
    return {
        "steps": {
            k: {"wall": float(np.median(v["wall"])), "compute": float(np.median(v["compute"]))}
            for k, v in by_step.items()
        },
        "iteration_wall": walls,
        "overhead_s": overhead,
        "overhead_median_s": float(np.median([per_iteration[k] for k in warm if k in per_iteration]))
        if per_iteration
        else float("nan"),
        "share": float(np.median(shares)) if shares else float("nan"),
        "share_total": 100.0 * overhead / span if span else float("nan"),
    }


def run_campaign(
    label: str,
    *,
    oracle: str,
    oracle_params: dict[str, Any],
    iterations: int,
    surrogate: dict[str, Any],
    preliminary: dict[str, Any],
    task_spec: dict[str, Any] | None = None,
    seed: int = 0,
) -> CampaignRun:
    """Create and run a campaign to its end in this process (same step protocol and rows as Celery)."""
    from alcove.campaigns import presets, service
    from alcove.campaigns.schemas import CampaignCreate
    from alcove.db import run_transaction

    def create(s: Any) -> int:
        user = presets.local_user(s)
        data = CampaignCreate(
            name=label,
            description="scripts/reproduce.py",
            seed=seed,
            task_version_id=presets.task_version_from_preset(s, user.id, TASK, task_spec),
            oracle_version_id=presets.oracle_version_for(s, user.id, oracle, oracle_params),
            surrogate_config_version_id=presets.surrogate_config_version_for(s, user.id, surrogate),
            preliminary=preliminary,
            stopping={"max_iterations": iterations},
        )
        return service.create_campaign(s, user.id, data).id

    cid = run_transaction(create)
    t0 = time.perf_counter()
    _, jobs = run_transaction(lambda s: service.start(s, cid))
    return _drive(cid, jobs, label, t0)


def fork_campaign(
    label: str, source: CampaignRun, *, iteration: int, iterations: int, task_spec: dict[str, Any] | None = None
) -> CampaignRun:
    """Continue from ``iteration`` of ``source`` (its pool version and model), optionally on another task."""
    from alcove.campaigns import presets, service
    from alcove.campaigns.config import StoppingRules
    from alcove.campaigns.schemas import ForkRequest
    from alcove.db import run_transaction

    def fork(s: Any) -> tuple[Any, list[Any]]:
        user = presets.local_user(s)
        tv = presets.task_version_from_preset(s, user.id, TASK, task_spec) if task_spec is not None else None
        req = ForkRequest(
            iteration=iteration,
            name=label,
            task_version_id=tv,
            stopping=StoppingRules(max_iterations=iteration + iterations),
            start=True,
        )
        return service.fork(s, source.campaign_id, req, user.id)

    t0 = time.perf_counter()
    c, jobs = run_transaction(fork)
    return _drive(c.id, jobs, label, t0)


#: the training protocol docs/reproduction.md was recorded with: one model pair per iteration (the paper's
#: single model; alcove's default is an ensemble of 5) with the paper's force net (hidden layers shared by
#: the normal and the tangential force; alcove's default gives the normal force its own) in float64, early
#: stopping on epochs alone, every preliminary sample kept, and a warm start that fine-tunes (alcove's
#: defaults train fully from the carried weights and drop the auxiliary law's samples in contact once
#: oracle data exist; docs/concepts.md)
PAPER_PROTOCOL: dict[str, Any] = {
    "ensemble_size": 1,
    "normal_force": "shared",
    "dtype": "float64",
    "patience_steps": 0,
    "preliminary_in_contact": "keep",
    "warm_learning_rate": 0.001,
    "warm_max_epochs": 4,
    "warm_patience": 2,
    "warm_min_improvement": 0.01,
}


def campaign_settings(quick: bool, oracle: str) -> dict[str, Any]:
    """The paper's protocol (:data:`PAPER_PROTOCOL`)."""
    if quick:
        return {
            "oracle": "aux-penalty",
            "oracle_params": {},
            "surrogate": {**PAPER_PROTOCOL, "max_epochs": 30},
            "preliminary": {"samples": 600, "chunks": 4},
        }
    return {
        "oracle": oracle,
        "oracle_params": {},
        "surrogate": dict(PAPER_PROTOCOL),
        "preliminary": {"family_motions": 0},  # the paper's pool version 0: the auxiliary law alone
    }


def adjusted_task() -> dict[str, Any]:
    """The adjusted task for the warm-start remedy: the head starts 0.05 rad further from the headrest."""
    from alcove.science.ocp import task_preset

    spec = task_preset(TASK).model_dump(mode="json")
    theta0 = task_preset(TASK).preset().theta0
    spec["initial"]["q"] = [round(theta0 - 0.05, 6)]
    spec["name"] = f"{TASK}-start-{theta0 - 0.05:.3f}"
    return spec


def remedy_budget(baseline: CampaignRun, n: int, remaining_s: float, margin_s: float = 60.0, floor: int = 10) -> int:
    """The most remedy iterations m <= n whose estimated time fits in ``remaining_s``.

    Estimated from the baseline's own iteration wall times: the two remedy campaigns that
    start from the preliminary data (down-weighted, adjusted task) cost like the baseline's
    iterations 1..m each, plus its preliminary step; the warm start continues from the
    baseline's last pool, so each of its iterations costs like the baseline's last ones.
    At least ``floor`` (or n) iterations, so the comparison means something."""
    walls = baseline.breakdown.get("iteration_wall", {}) if baseline.breakdown else {}
    if not walls:
        return min(floor, n)
    ks = sorted(walls)
    late = sorted(walls[k] for k in ks[-20:])[len(ks[-20:]) // 2]  # median of the last 20
    prelim = 2 * max(baseline.wall - sum(walls.values()), 0.0)
    best, cum = min(floor, n), 0.0
    for m in range(1, n + 1):
        cum += walls.get(m, late)
        if prelim + 2 * cum + m * late + margin_s > remaining_s:
            break
        best = max(best, m)
    return min(best, n)
