"""`alcove campaign ...`: run and control active-learning campaigns without the REST API.

``alcove campaign run`` creates a campaign, starts it and follows it to the end with a Rich
progress display. The steps go through Celery exactly as for web-driven campaigns: a
worker process is spawned (``--worker``, the default) or external workers
(``alcove worker``) pick them up (``--no-worker``).

``--config F.yaml`` (or JSON) may hold: ``name``, ``seed``, ``preliminary``, ``stopping``,
``policies``, ``settings`` (see :mod:`alcove.campaigns.schemas`), ``surrogate`` (the
surrogate config), ``oracle_params`` (parameters of the oracle type) and ``task_spec``
(a full task instead of the preset).
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import typer

from alcove_worker.cli import follow as following
from alcove_worker.cli.campaign_config import create_campaign, ensure_database, read_config
from alcove_worker.cli.candidates import candidates
from alcove_worker.cli.follow import fail

app = typer.Typer(
    help=(
        "Active-learning campaigns: run, create, start, pause, resume, cancel, retry, fork, status, candidates, export."
    ),
    no_args_is_help=True,
)


def _control(action: str, campaign_id: int, **kwargs: Any) -> Any:
    from alcove.campaigns import service
    from alcove.db import run_transaction
    from alcove.errors import DomainError
    from alcove.jobs.campaign import send_committed, stage

    fn = getattr(service, action)

    def work(s: Any) -> tuple[Any, list[int]]:
        obj, jobs = fn(s, campaign_id, **kwargs)
        return obj, stage(s, jobs)  # recorded with the change, sent after its commit

    try:
        obj, staged = run_transaction(work)
    except DomainError as exc:
        fail("campaign", str(exc))
    send_committed(staged)
    return obj


@app.command()
def run(
    task: str = typer.Option("head-headrest-2phase", help="task preset"),
    oracle: str = typer.Option(
        "fe-headrest-2d", help="oracle type: fe-headrest-2d, fe-headrest-3d-ccx, aux-penalty or a catalogue entry"
    ),
    iterations: int | None = typer.Option(
        None, "--iterations", "-n", min=1, help="max_iterations stopping rule (default: the config's, else 200)"
    ),
    config: Path | None = typer.Option(None, "--config", help="YAML/JSON campaign settings"),
    name: str | None = typer.Option(None, help="campaign name"),
    seed: int | None = typer.Option(None, min=0, help="campaign seed"),
    strategy: str | None = typer.Option(
        None,
        help="acquisition strategy: paper (the task as written), random-scenarios (q scenarios drawn from the "
        "task's ranges every iteration), ensemble-disagreement (C candidates, the q most disputed replayed) or "
        "press-family (q prescribed press motions of the task's range, no OCP); "
        "default: the config's, else paper",
    ),
    candidates: int | None = typer.Option(
        None,
        "--candidates",
        help="candidate scenarios C per iteration (ensemble-disagreement; default: the config's, else 8)",
    ),
    min_disagreement: float | None = typer.Option(
        None,
        "--min-disagreement",
        help="stop when the highest candidate score falls below this [N] (ensemble-disagreement)",
    ),
    batch: int | None = typer.Option(
        None,
        "--batch",
        help="batch size q: trajectories replayed per iteration in parallel oracle jobs "
        "(default: the config's, else 1)",
    ),
    max_oracle_jobs: int | None = typer.Option(
        None,
        "--max-oracle-jobs",
        help="at most this many of the campaign's oracle jobs at once (default: the config's, else no cap)",
    ),
    as_json: bool = typer.Option(
        False,
        "--json",
        help="print the per-iteration metrics (with the scenario solved, oracle_calls and the picked scenarios) as "
        "JSON at the end",
    ),
    spawn: bool = typer.Option(
        True, "--worker/--no-worker", help="spawn a worker process (off: external `alcove worker`s run the steps)"
    ),
    concurrency: int = typer.Option(1, "--concurrency", "-c", min=1, help="processes of the spawned worker"),
    worker_log: Path | None = typer.Option(None, help="file for the spawned worker's log"),
    validation_timeout: float = typer.Option(
        600.0,
        min=0.0,
        help="after the campaign, wait at most this long [s] for the validation suite's replays and "
        "the generalisation error of every model version",
    ),
) -> None:
    """Create a campaign, run it to the end through Celery, and report its metrics (in-loop and
    on the held-out validation suite: ``validation_force_rmse``, ``validation_moment_rmse``,
    ``validation_calibration``, and per component ``fx_rmse`` .. ``mz_rmse`` and ``validation_fx_rmse`` ..
    ``validation_mz_rmse``, each also over the samples in contact, ``..._rmse_contact``)."""

    ensure_database()
    cfg = read_config(config)
    given = {
        "strategy": strategy,
        "batch": batch,
        "candidates": candidates,
        "max_concurrent_oracle_jobs": max_oracle_jobs,
    }
    if any(v is not None for v in given.values()):
        cfg["settings"] = {**(cfg.get("settings") or {}), **{k: v for k, v in given.items() if v is not None}}
    if min_disagreement is not None:
        cfg["stopping"] = {**(cfg.get("stopping") or {}), "min_disagreement": min_disagreement}
    campaign_id = create_campaign(task, oracle, iterations, cfg, name, seed)
    proc = following.spawn_worker(concurrency, log_path=worker_log) if spawn else None
    t0 = time.perf_counter()
    try:
        _control("start", campaign_id)
        try:
            detail = following.follow(campaign_id, quiet=as_json, worker=proc)
        except KeyboardInterrupt:
            _control("pause", campaign_id)
            typer.echo(
                f"\npausing campaign {campaign_id} after the running step; "
                f"continue with `alcove campaign resume {campaign_id}`",
                err=True,
            )
            detail = following.follow(campaign_id, quiet=True, worker=proc)
        if detail.campaign.status.value == "completed":
            detail = following.wait_validation(campaign_id, timeout=validation_timeout, worker=proc)
    finally:
        if proc is not None:
            following.stop_worker(proc)
    wall = time.perf_counter() - t0
    metrics = following.read_metrics(campaign_id)
    summary = following.summary(detail, metrics, wall)
    if as_json:
        typer.echo(json.dumps({**summary, "metrics": metrics}))
    else:
        typer.echo(json.dumps(summary, indent=1))
    if detail.campaign.status.value == "failed":
        raise typer.Exit(1)


@app.command()
def create(
    task: str = typer.Option("head-headrest-2phase"),
    oracle: str = typer.Option("fe-headrest-2d"),
    iterations: int | None = typer.Option(None, "--iterations", "-n", min=1),
    config: Path | None = typer.Option(None, "--config"),
    name: str | None = typer.Option(None),
    seed: int | None = typer.Option(None, min=0),
) -> None:
    """Create a draft campaign and print its id."""
    ensure_database()
    typer.echo(create_campaign(task, oracle, iterations, read_config(config), name, seed))


def _components_text(components: dict[str, float | None]) -> str:
    """The components that carry the error of a planar contact: fx, fz [N] and my [N m]."""
    parts = [
        f"{c} {v:.3g} {unit}"
        for c, unit in (("fx", "N"), ("fz", "N"), ("my", "N m"))
        if (v := components.get(c)) is not None
    ]
    return ", ".join(parts)


def batch_job_lines(iteration: Any) -> list[str]:
    """The current iteration's oracle calls that run as batch jobs: scheduler job id, state, times."""
    lines = []
    for st in iteration.steps or [] if iteration is not None else []:
        for job in st.batch_jobs:
            times = [f"submitted {job.submitted_at:%H:%M:%S}" if job.submitted_at else "not submitted"]
            if job.started_at and job.submitted_at:
                times.append(f"started +{(job.started_at - job.submitted_at).total_seconds():.1f} s")
            if job.ended_at and job.started_at:
                times.append(f"ran {(job.ended_at - job.started_at).total_seconds():.1f} s")
            lines.append(
                f"  oracle call {st.slot} (attempt {job.attempt}): {job.scheduler} job {job.job_id} {job.state}"
                + f" · {', '.join(times)}"
                + (f" · {job.worker_name}" if job.worker_name else "")
                + (f" · {job.reason}" if job.reason else "")
            )
    if lines:
        lines.insert(0, f"batch jobs of iteration {iteration.index}:")
    return lines


def _print_status(campaign_id: int, as_json: bool) -> None:
    detail = following.read_detail(campaign_id)
    if as_json:
        typer.echo(detail.model_dump_json())
        return
    c = detail.campaign
    m = detail.latest_metrics
    typer.echo(
        f"campaign {c.id} '{c.name}': {c.status.value}"
        + (f" ({c.stop_reason})" if c.stop_reason else "")
        + f" · iteration {c.current_iteration} {c.current_step or ''}"
        + f" · finished {detail.iterations_finished}, failed {detail.iterations_failed}"
        + (f" · last RMSE F {m.force_rmse:.4g} N, M {m.moment_rmse:.4g} N m" if m and m.force_rmse is not None else "")
        + (f" ({_components_text(m.components)})" if m and m.components else "")
        + (
            f" · validation F {m.validation_force_rmse:.4g} N, M {m.validation_moment_rmse:.4g} N m"
            if m and m.validation_force_rmse is not None and m.validation_moment_rmse is not None
            else ""
        )
        + (f" ({_components_text(m.validation_components)})" if m and m.validation_components else "")
        + (
            f" · validation calibration {m.validation_calibration:.3f}"
            if m and m.validation_calibration is not None
            else " · validation calibration not recorded (evaluated before migration 0019)"
            if m and m.validation_calibration_recorded is False
            else ""
        )
        + (f" · ETA {detail.eta_s:.0f} s" if detail.eta_s is not None else "")
    )
    if c.wait_reason:
        typer.echo(f"  {c.wait_reason}")
    for line in batch_job_lines(detail.current):
        typer.echo(line)
    v = detail.validation
    if v is not None:
        typer.echo(
            f"validation suite {v.id}: {v.status}, {v.motions_done}/{v.n_motions} motions replayed"
            + (f" ({v.n_stress_motions} stress)" if v.n_stress_motions else "")
            + (f" ({v.n_reference_motions} for the best-possible line)" if v.n_reference_motions else "")
            + f", shared by {v.shared_by} campaign(s)"
            + (f", replayed in {v.replay_wall_time_s:.1f} s" if v.replay_wall_time_s is not None else "")
            + (f" ({v.error})" if v.error else "")
        )
    if v is not None and v.best_possible_computed:
        from alcove_worker.cli.follow import best_possible_points

        points = best_possible_points(c.id) or []
        typer.echo(
            "best possible (models from scratch on that many oracle replays spread over the suite's range): "
            + ", ".join(f"{p['oracle_calls']} calls {p['force_rmse']:.3g} N (fx {p['fx_rmse']:.3g} N)" for p in points)
        )
    if c.error:
        typer.echo(f"error: {c.error}")


def _id_arg() -> Any:
    return typer.Argument(..., help="campaign id")


@app.command()
def start(campaign_id: int = _id_arg()) -> None:
    """Start a draft campaign (workers must be running)."""
    _control("start", campaign_id)
    _print_status(campaign_id, False)


@app.command()
def pause(campaign_id: int = _id_arg()) -> None:
    """Pause after the running step."""
    _control("pause", campaign_id)
    _print_status(campaign_id, False)


@app.command()
def resume(campaign_id: int = _id_arg()) -> None:
    """Resume a paused campaign."""
    _control("resume", campaign_id)
    _print_status(campaign_id, False)


@app.command()
def cancel(campaign_id: int = _id_arg()) -> None:
    """Cancel (cooperatively: the running job stops at its next check)."""
    _control("cancel", campaign_id)
    _print_status(campaign_id, False)


@app.command()
def retry(
    campaign_id: int = _id_arg(), iteration: int | None = typer.Option(None), step: str | None = typer.Option(None)
) -> None:
    """Run the failed step of a failed campaign again."""
    _control("retry_step", campaign_id, iteration=iteration, step=step)
    _print_status(campaign_id, False)


@app.command()
def fork(
    campaign_id: int = _id_arg(),
    iteration: int = typer.Option(
        ..., "--iteration", "-k", min=0, help="continue from this iteration's pool version and model"
    ),
    iterations: int | None = typer.Option(None, "--iterations", "-n", min=1, help="max_iterations of the fork"),
    config: Path | None = typer.Option(
        None, "--config", help="settings to change (stopping, policies, settings, surrogate, seed, name)"
    ),
    start_it: bool = typer.Option(False, "--start", help="start the fork at once"),
) -> None:
    """Create a new campaign continuing from iteration K of this one; prints its id."""
    from alcove.campaigns import presets
    from alcove.campaigns.config import StoppingRules
    from alcove.campaigns.schemas import ForkRequest
    from alcove.db import run_transaction

    cfg = read_config(config)
    detail = following.read_detail(campaign_id)
    stopping = dict(cfg.get("stopping") or detail.config.stopping.model_dump())
    if iterations is not None:
        stopping["max_iterations"] = iterations

    def scv(s: Any) -> int | None:
        return (
            presets.surrogate_config_version_for(s, presets.local_user(s).id, cfg["surrogate"])
            if "surrogate" in cfg
            else None
        )

    req = ForkRequest(
        iteration=iteration,
        name=cfg.get("name"),
        seed=cfg.get("seed"),
        stopping=StoppingRules(**stopping),
        policies=cfg.get("policies"),
        settings=cfg.get("settings"),
        surrogate_config_version_id=run_transaction(scv),
        start=start_it,
    )
    new = _control("fork", campaign_id, req=req, owner_id=detail.campaign.owner_id)
    typer.echo(new.id)


@app.command()
def status(campaign_id: int = _id_arg(), as_json: bool = typer.Option(False, "--json")) -> None:
    """Status, current iteration and step, latest RMSE, ETA."""
    _print_status(campaign_id, as_json)


app.command(name="candidates")(candidates)


@app.command(name="list")
def list_(as_json: bool = typer.Option(False, "--json")) -> None:
    """All campaigns."""
    from alcove.campaigns.views import detail
    from alcove.db import open_transaction

    with open_transaction() as s:
        rows = detail.list_campaigns(s)
    if as_json:
        typer.echo(json.dumps([r.model_dump(mode="json") for r in rows]))
        return
    for r in rows:
        waits = "  (waiting for a free place)" if r.wait_reason else ""
        typer.echo(f"{r.id:5d}  {r.status.value:10s}  k={r.current_iteration:<4d} {r.name}{waits}")


@app.command()
def export(
    campaign_id: int = _id_arg(),
    out: Path = typer.Option(..., "--out", "-o", help="folder to write into"),
    fmt: str = typer.Option("parquet", "--format", help="pool tables: parquet or csv"),
    models: bool = typer.Option(True, "--models/--no-models", help="include the model artifacts"),
) -> None:
    """Write pool versions (Parquet/CSV), models, metrics and curves to a folder."""
    from alcove.campaigns.views.export import export_campaign
    from alcove.db import open_transaction
    from alcove.errors import NotFound

    if fmt not in ("parquet", "csv"):
        fail("--format", f"expected parquet or csv, got {fmt!r}")
    with open_transaction() as s:
        try:
            root = export_campaign(s, campaign_id, out, pool_format=fmt, models=models)
        except NotFound as exc:
            fail("campaign", str(exc))
    typer.echo(str(root))
