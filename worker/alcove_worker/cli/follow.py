"""Following a campaign from the command line: a spawned worker process for the steps,
a progress display until the campaign ends, and the summary ``alcove campaign run`` prints."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path
from typing import Any, NoReturn

import typer

TERMINAL = {"completed", "cancelled", "failed"}


def fail(field: str, reason: str, code: int = 2) -> NoReturn:
    """One line on stderr naming the field and the reason, then exit ``code``."""
    typer.echo(f"error: {field}: {reason}", err=True)
    raise typer.Exit(code)


def read_detail(campaign_id: int) -> Any:
    from alcove.campaigns.views import detail
    from alcove.db import open_transaction
    from alcove.errors import NotFound

    try:
        with open_transaction() as s:
            return detail.get_detail(s, campaign_id)
    except NotFound as exc:
        fail("campaign", exc.message)


def read_metrics(campaign_id: int) -> list[dict[str, Any]]:
    from alcove.campaigns.views import detail
    from alcove.db import open_transaction

    with open_transaction() as s:
        rows = [m.model_dump(mode="json") for m in detail.metrics_series(s, campaign_id)]
        # the scenario each iteration's OCP solved (null: the task as written), its oracle calls and,
        # for a batch, the picked scenarios with each one's in-loop RMSE
        its = {it.index: it for it in detail.list_iterations(s, campaign_id)}
    return [{**row, **_iteration_fields(its.get(row["iteration_index"]))} for row in rows]


def _iteration_fields(it: Any) -> dict[str, Any]:
    if it is None:
        return {"scenario": None, "oracle_calls": None, "picks": []}
    picks = sorted((c for c in it.candidates if c.pick is not None), key=lambda c: c.pick)
    return {
        "scenario": it.scenario,
        "oracle_calls": it.oracle_calls,
        "picks": [
            {
                "pick": c.pick,
                "slot": c.slot,
                "scenario": c.scenario,
                "score": c.score,
                "force_rmse": c.force_rmse,
                "moment_rmse": c.moment_rmse,
            }
            for c in picks
        ],
    }


def spawn_worker(
    concurrency: int = 1, queues: str = "default,ocp,oracle,train", log_path: Path | None = None
) -> subprocess.Popen[bytes]:
    """An `alcove worker` child process in its own session (stopped by :func:`stop_worker`)."""
    argv = [
        sys.executable,
        "-m",
        "alcove_worker.cli.main",
        "worker",
        "--queues",
        queues,
        "--concurrency",
        str(concurrency),
        "--name",
        f"campaign-run-{uuid.uuid4().hex[:6]}",
        "--loglevel",
        "WARNING",
    ]
    out = open(log_path, "ab") if log_path else subprocess.DEVNULL  # noqa: SIM115
    env = dict(os.environ)
    # lean hand-over between steps on the filesystem broker: the worker polls the folder only
    # while it has no job running (prefetch 1, acks late), so a short interval costs no CPU during a step
    env.setdefault("ALCOVE_BROKER_POLLING_INTERVAL", "0.005")
    return subprocess.Popen(
        argv, stdout=out, stderr=subprocess.STDOUT, start_new_session=True, env=env, preexec_fn=_die_with_parent
    )


def _die_with_parent() -> None:
    """Linux: the spawned worker gets SIGTERM if this CLI process dies (even by SIGKILL)."""
    try:
        import ctypes

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def stop_worker(p: subprocess.Popen[bytes], timeout: float = 20.0) -> None:
    if p.poll() is None:
        p.send_signal(signal.SIGTERM)
        with contextlib.suppress(subprocess.TimeoutExpired):
            p.wait(timeout=timeout)
    with contextlib.suppress(ProcessLookupError):
        os.killpg(p.pid, signal.SIGKILL)
    p.wait(timeout=5)


def queue_without_worker(step: str | None) -> str | None:
    """The queue of ``step`` when no live worker (heartbeat within ``worker_stale_seconds``) serves it."""
    from alcove.jobs.campaign import STEP_JOBS, step_queue
    from alcove.jobs.heartbeat import live_workers
    from alcove.settings import get_settings

    if step not in STEP_JOBS:
        return None
    queue = step_queue(step)
    served = {q for w in live_workers(get_settings().worker_stale_seconds) for q in (w.queues or [])}
    return None if queue in served else queue


class _WorkerWatch:
    """Tells once (on stderr, also without a terminal) when the campaign waits on a queue no
    live worker serves, and again when one turns up; checked every ``every`` seconds
    (``ALCOVE_WORKER_WATCH_SECONDS``)."""

    def __init__(self, console: Any, every: float = 5.0, grace: float = 3.0) -> None:
        self.console, self.every = console, every
        self.next_check = time.monotonic() + grace  # a worker started with the campaign beats at once
        self.waiting_on: str | None = None

    def check(self, step: str | None) -> None:
        if time.monotonic() < self.next_check:
            return
        self.next_check = time.monotonic() + self.every
        queue = queue_without_worker(step)
        if queue is not None and queue != self.waiting_on:
            self.console.print(
                f"waiting: no live worker serves queue '{queue}' (step {step}); "
                f"start one with `alcove worker --queues {queue}` on this database and broker",
                soft_wrap=True,
            )
        elif queue is None and self.waiting_on is not None:
            self.console.print(f"a worker now serves queue '{self.waiting_on}'", soft_wrap=True)
        self.waiting_on = queue


def follow(
    campaign_id: int, *, quiet: bool = False, poll: float = 0.25, worker: subprocess.Popen[bytes] | None = None
) -> Any:
    """Poll the campaign until it reaches a terminal state (or paused), with a progress display.

    Without a spawned ``worker`` the steps wait for external workers: a step whose queue no
    live worker serves is reported (even with ``quiet``) instead of waiting silently."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from alcove.settings import get_settings

    console = Console(stderr=True)
    watch = _WorkerWatch(console, every=get_settings().worker_watch_seconds) if worker is None else None
    detail = read_detail(campaign_id)
    total = detail.config.stopping.max_iterations
    start_k = detail.campaign.source_iteration or 0
    with Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[info]}"),
        TimeElapsedColumn(),
        console=console,
        disable=quiet,
        transient=False,
    ) as progress:
        bar = progress.add_task(f"campaign {campaign_id}", total=(total - start_k) if total else None, info="")
        while True:
            detail = read_detail(campaign_id)
            c = detail.campaign
            m = detail.latest_metrics
            rmse = f"F {m.force_rmse:.3g} N  M {m.moment_rmse:.3g} N m" if m and m.force_rmse is not None else "-"
            eta = f"ETA {detail.eta_s:.0f} s" if detail.eta_s is not None else "ETA -"
            progress.update(
                bar,
                completed=detail.iterations_finished + detail.iterations_failed,
                description=(
                    f"campaign {campaign_id} · k={c.current_iteration} {c.current_step or ''} · {c.status.value}"
                ),
                info=f"{rmse} · {eta}",
            )
            if c.status.value in TERMINAL or c.status.value == "paused":
                return detail
            if worker is not None and worker.poll() is not None:
                console.print(f"[red]the worker exited with code {worker.returncode}[/red]")
                return detail
            if watch is not None and c.status.value in ("queued", "running"):
                watch.check(c.current_step)
            time.sleep(poll)


def wait_validation(
    campaign_id: int, *, timeout: float = 600.0, poll: float = 0.25, worker: subprocess.Popen[bytes] | None = None
) -> Any:
    """After the campaign: wait until its validation suite is replayed, every model version is
    evaluated on it (the suite's motions may still be running on the oracle workers) and its
    best-possible line is computed (if it asks for one), or the suite failed."""
    end = time.monotonic() + timeout
    while True:
        detail = read_detail(campaign_id)
        v = detail.validation
        if v is None or v.status == "failed":
            return detail
        line_done = v.n_reference_motions == 0 or v.best_possible_computed
        if (
            v.status == "complete"
            and line_done
            and all(m["validation_force_rmse"] is not None for m in read_metrics(campaign_id) if m["model_version_id"])
        ):
            return detail
        if time.monotonic() > end or (worker is not None and worker.poll() is not None):
            return detail
        time.sleep(poll)


_FIRST_LAST = (
    "iteration_index",
    "force_rmse",
    "moment_rmse",
    "force_rmse_contact",
    "moment_rmse_contact",
    "calibration",
    "validation_force_rmse",
    "validation_moment_rmse",
    "validation_calibration",
    "validation_calibration_recorded",
)


_COMPONENTS = ("fx", "fy", "fz", "mx", "my", "mz")


def component_fields(row: dict[str, Any]) -> dict[str, Any]:
    """One metrics row's RMSE per component as flat keys: in-loop ``fx_rmse`` .. ``mz_rmse`` (and
    ``fx_rmse_contact`` ..), on the validation suite ``validation_fx_rmse`` .. (and ``_contact``)."""
    out: dict[str, Any] = {}
    for prefix, comps in (("", row.get("components")), ("validation_", row.get("validation_components"))):
        comps = comps or {}
        for c in _COMPONENTS:
            out[f"{prefix}{c}_rmse"] = comps.get(c)
            out[f"{prefix}{c}_rmse_contact"] = comps.get(f"{c}_contact")
    return out


def summary(detail: Any, metrics: list[dict[str, Any]], wall: float | None = None) -> dict[str, Any]:
    c = detail.campaign
    out = {
        "campaign_id": c.id,
        "status": c.status.value,
        "stop_reason": c.stop_reason,
        "error": c.error,
        "iterations_finished": detail.iterations_finished,
        "iterations_failed": detail.iterations_failed,
        "mean_iteration_s": detail.mean_iteration_s,
        "oracle_wall_time_s": c.oracle_wall_time_s,
    }
    if wall is not None:
        out["wall_time_s"] = wall
    out["step_median_s"] = _step_medians(c.id)
    v = detail.validation
    out["validation_suite"] = v.model_dump(mode="json") if v is not None else None
    out["best_possible"] = best_possible_points(c.id) if v is not None and v.best_possible_computed else None
    if metrics:
        out["first"] = {**{k: metrics[0].get(k) for k in _FIRST_LAST}, **component_fields(metrics[0])}
        out["last"] = {**{k: metrics[-1].get(k) for k in _FIRST_LAST}, **component_fields(metrics[-1])}
    return out


def best_possible_points(campaign_id: int) -> list[dict[str, Any]] | None:
    """The suite's best-possible line: per oracle budget, force, fx, fz and my RMSE and the calibration."""
    from alcove.campaigns.views.validation import validation_series
    from alcove.db import open_transaction
    from alcove.models import Campaign

    with open_transaction() as s:
        c = s.get(Campaign, campaign_id)
        line = validation_series(s, c).best_possible if c is not None else None
    if line is None:
        return None
    return [
        {
            "oracle_calls": p.budget,
            "force_rmse": p.force_rmse,
            "moment_rmse": p.moment_rmse,
            **{f"{k}_rmse": p.components.get(k) for k in ("fx", "fz", "my")},
            "calibration": p.calibration,
        }
        for p in line.points
    ]


def _step_medians(campaign_id: int) -> dict[str, dict[str, float]]:
    """Median wall time and bare compute of each step type (the per-step breakdown)."""
    import statistics

    from alcove.campaigns.views import detail
    from alcove.db import open_transaction

    with open_transaction() as s:
        jobs = [
            j
            for j in detail.list_jobs(s, campaign_id, ["succeeded"])
            if j["iteration"] > 0 and j["wall_time_s"] is not None
        ]
    out: dict[str, dict[str, float]] = {}
    for step in ("train", "ocp", "oracle", "evaluate", "append"):
        mine = [j for j in jobs if j["step"].value == step]
        if mine:
            out[step] = {
                "wall": statistics.median(j["wall_time_s"] for j in mine),
                "compute": statistics.median(j["result"].get("compute_s", 0.0) for j in mine),
            }
    return out
