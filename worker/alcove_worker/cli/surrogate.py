"""`alcove surrogate ...` commands: train a model pair, predict with it, write preliminary data.

``alcove surrogate train --pool DIR|--campaign ID [--config F.json] [--seed N] --out model-dir [--json]``
    trains an ensemble of ``ensemble_size`` force and moment MLP pairs (the paper's protocol
    per member unless the config says otherwise) and writes the self-contained artifact
    (``surrogate.json``, ``force.pt``, ``moment.pt``) and the portable exports
    (``force.casadi``, ``moment.casadi``, for K > 1 ``force_std.casadi``, ``moment_std.casadi``;
    ``force.onnx``, ``moment.onnx``; docs/exports.md). A pool folder holds pairs
    ``NAME.traj.csv`` + ``NAME.forces.csv`` as ``alcove ocp solve`` and ``alcove oracle run``
    write them; ``--campaign`` trains on the campaign's latest pool version with its
    surrogate config, task geometry and seed.
``alcove surrogate predict --model model-dir --trajectory traj.csv --out pred.csv``
    writes ``t,fx,fy,fz,mx,my,mz`` (N, N m, headrest frame; the ensemble mean) and, for an
    ensemble (K > 1), ``fx_std,..,mz_std`` (the members' standard deviation).
``alcove surrogate preliminary --out DIR [--samples K] [--velocity-bound V] [--seed N]``
    writes the Latin hypercube aux-penalty preliminary data as a pool folder.
``alcove surrogate compare --pool DIR|--campaign ID [--suite DIR | --oracle TYPE] [--config F.json]``
    trains the ``paper`` and the ``gated`` architecture on the same pool (same config and seed)
    and scores both on the held-out validation suite (:mod:`alcove.science.surrogate.compare`):
    a table of force/moment vector RMSE (all samples and in contact) and the ghost force where
    the gap is open; ``--suite DIR`` reads replayed motions (a pool folder, e.g. from
    ``--suite-out``), otherwise the suite is replayed with ``--oracle`` here.

Bad input prints one line ``error: <field>: <reason>`` and exits with code 2.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

import typer

if TYPE_CHECKING:
    from alcove.science.geometry import HeadNeckPreset
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.dataset import PoolDataset

app = typer.Typer(
    help="Train contact surrogates (two MLPs), predict with them, write preliminary data.", no_args_is_help=True
)

EXIT_BAD_INPUT = 2


def _bad_input(field: str, reason: str) -> NoReturn:
    typer.echo(f"error: {field}: {reason}", err=True)
    raise typer.Exit(EXIT_BAD_INPUT)


def _task_preset(task: str | None, task_file: Path | None) -> HeadNeckPreset:
    preset, kinematics = _task_geometry(task, task_file)
    if kinematics is not None:
        _bad_input("task", "this command takes the head-neck-1dof model only so far, not a chain")
    return preset


def _task_geometry(task: str | None, task_file: Path | None) -> tuple[HeadNeckPreset, Any]:
    """The task's geometry: its 1-DOF preset (the head-neck-1dof preset by default) and, for a
    chain model, the kinematics of its contact body's pose (features from the head's pose)."""
    from alcove.science.geometry import DEFAULT_PRESET

    if task is None and task_file is None:
        return DEFAULT_PRESET, None
    from alcove.science.ocp.task_spec import TaskSpecError, parse_task, task_preset

    try:
        if task_file is not None:
            if not task_file.exists():
                _bad_input("task-file", f"{task_file} does not exist")
            spec = parse_task(task_file)
        else:
            assert task is not None  # task and task_file are not both None (returned above)
            spec = task_preset(task)
        if not spec.model.is_chain:
            return spec.preset(), None
        from alcove.science.surrogate.training import pose_kinematics

        return spec.model.oracle_preset(), pose_kinematics(spec.model.pose_function())
    except TaskSpecError as exc:
        _bad_input(exc.field, exc.reason)


def _campaign_inputs(
    campaign_id: int, database_url: str | None
) -> tuple[list[PoolDataset], dict[str, Any], HeadNeckPreset, int, dict[str, Any]]:
    """Pool, surrogate config, preset, seed and lineage of a campaign's latest pool version."""
    try:
        import sqlalchemy as sa

        from alcove.db.session import open_transaction
        from alcove.models import Campaign, PoolVersion
        from alcove.pool.service import load_training_pool
        from alcove.science.ocp.task_spec import TaskSpecError, parse_task
    except ImportError as exc:  # pragma: no cover - a worker without the database layer
        _bad_input("campaign", f"the database layer is not available ({exc})")
    if not database_url:
        from alcove.settings import get_settings

        database_url = get_settings().database_url
    if database_url.startswith("sqlite:///") and not Path(database_url[len("sqlite:///") :]).exists():
        _bad_input("campaign", f"no database at {database_url} (set ALCOVE_DATABASE_URL)")
    try:
        with open_transaction(database_url) as s:
            campaign = s.get(Campaign, campaign_id)
            if campaign is None:
                _bad_input("campaign", f"no campaign with id {campaign_id}")
            pv = s.scalars(
                sa.select(PoolVersion)
                .where(PoolVersion.campaign_id == campaign_id)
                .order_by(PoolVersion.version.desc())
                .limit(1)
            ).first()
            if pv is None:
                _bad_input(
                    "campaign",
                    f"campaign {campaign_id} has no pool version yet (its preliminary data is built when it starts)",
                )
            pool = load_training_pool(s, pv)
            config = dict(campaign.surrogate_config_version.spec or {})
            try:
                preset = parse_task(campaign.task_version.spec).preset()
            except TaskSpecError as exc:
                _bad_input(f"campaign task: {exc.field}", exc.reason)
            lineage = {
                "campaign_id": campaign_id,
                "pool_version_id": pv.id,
                "pool_version": pv.version,
                "pool_content_hash": pv.content_hash,
            }
            return pool, config, preset, int(campaign.seed), lineage
    except sa.exc.SQLAlchemyError as exc:
        _bad_input("campaign", f"cannot read the database ({type(exc).__name__}: {str(exc).splitlines()[0]})")


@dataclass(frozen=True)
class TrainingInputs:
    """What ``surrogate train`` and ``surrogate compare`` read: a pool, a config, the geometry."""

    pool: list[PoolDataset]
    config: SurrogateConfig
    preset: HeadNeckPreset
    default_seed: int | None
    lineage: dict[str, Any]
    #: a chain task's pose kinematics (None: the preset's own)
    kinematics: Any = None


def load_training_inputs(
    pool_dir: Path | None,
    campaign: int | None,
    config_file: Path | None,
    task: str | None,
    task_file: Path | None,
    database_url: str | None,
) -> TrainingInputs:
    """The pool (``--pool DIR`` or ``--campaign ID``), the surrogate config (``--config`` or the
    campaign's / the paper's) and the task geometry; bad input exits 2 naming the option."""
    from alcove.science.surrogate.config import SurrogateConfig, SurrogateConfigError
    from alcove.science.surrogate.dataset import PoolDataError, load_pool_dir

    if (pool_dir is None) == (campaign is None):
        _bad_input("pool", "give exactly one of --pool DIR and --campaign ID")
    config_data: dict[str, Any] = {}
    default_seed: int | None = None
    kinematics = None
    if campaign is not None:
        pool, config_data, preset, default_seed, lineage = _campaign_inputs(campaign, database_url)
    else:
        preset, kinematics = _task_geometry(task, task_file)
        assert pool_dir is not None  # exactly one of --pool and --campaign (checked above)
        try:
            pool = load_pool_dir(pool_dir)
        except PoolDataError as exc:
            _bad_input(f"pool: {exc.field}", exc.reason)
        lineage = {"pool_dir": str(pool_dir)}
    try:
        if config_file is not None:
            if not config_file.exists():
                _bad_input("config", f"{config_file} does not exist")
            config = SurrogateConfig.from_json(config_file)
        else:
            config = SurrogateConfig.parse(config_data)
    except SurrogateConfigError as exc:
        _bad_input(f"config: {exc.field}", exc.reason)
    return TrainingInputs(pool, config, preset, default_seed, lineage, kinematics)


def _print_metrics(metrics: dict[str, Any], out: Path) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"surrogate trained -> {out}")
    table.add_column("net")
    for split in ("train", "validation", "test"):
        table.add_column(f"RMSE {split}", justify="right")
    table.add_column("epochs (best)", justify="right")

    def fmt(v: float | None) -> str:
        return "-" if v is None else f"{v:.4g}"

    for net, unit in (("force", "N"), ("moment", "N m")):
        r = metrics["rmse"][net]
        table.add_row(
            f"{net} [{unit}]",
            fmt(r["train"]),
            fmt(r["validation"]),
            fmt(r["test"]),
            f"{metrics['epochs'][net]} ({metrics['best_epoch'][net]})",
        )
    console = Console()
    console.print(table)
    s = metrics["samples"]
    console.print(
        f"samples: {s['train']} train, {s['validation']} validation, {s['test']} test; "
        f"wall time {metrics['wall_time_s']:.2f} s; {len(metrics.get('members', [])) or 1} member(s), "
        "RMSE of the force (moment) error vector, the members' mean on their own splits"
    )


@app.command()
def train(
    pool_dir: Path | None = typer.Option(None, "--pool", help="pool folder of NAME.traj.csv + NAME.forces.csv pairs"),
    campaign: int | None = typer.Option(
        None, "--campaign", help="train on this campaign's latest pool version (needs the database)"
    ),
    config_file: Path | None = typer.Option(
        None, "--config", help="surrogate configuration as JSON (default: the paper's protocol)"
    ),
    seed: int | None = typer.Option(
        None,
        "--seed",
        min=0,
        help="seed of splits, initialisation and batch order (default: the config's / campaign's)",
    ),
    task: str | None = typer.Option(
        None, "--task", help="task preset whose geometry the pool refers to (default: head-neck-1dof)"
    ),
    task_file: Path | None = typer.Option(None, "--task-file", help="task definition as JSON (instead of --task)"),
    out: Path = typer.Option(
        ..., "--out", help="model folder to write (surrogate.json, force.pt, moment.pt, *.casadi, *.onnx)"
    ),
    json_output: bool = typer.Option(False, "--json", help="print a JSON summary on stdout"),
    database_url: str | None = typer.Option(None, "--database-url", envvar="ALCOVE_DATABASE_URL", hidden=True),
) -> None:
    """Train an ensemble of force and moment MLPs on a pool and write the model artifact and exports."""
    from alcove.science.surrogate.artifact import save_artifact
    from alcove.science.surrogate.config import SurrogateConfigError
    from alcove.science.surrogate.dataset import PoolDataError
    from alcove.science.surrogate.training import train_surrogate

    if out.exists() and not out.is_dir():
        _bad_input("out", f"{out} exists and is not a folder")
    inputs = load_training_inputs(pool_dir, campaign, config_file, task, task_file, database_url)
    config, default_seed = inputs.config, inputs.default_seed
    run_seed = seed if seed is not None else (default_seed if default_seed is not None else config.seed)
    try:
        result = train_surrogate(inputs.pool, config, run_seed, preset=inputs.preset, kinematics=inputs.kinematics)
    except PoolDataError as exc:
        _bad_input(f"pool: {exc.field}", exc.reason)
    except SurrogateConfigError as exc:
        _bad_input(f"config: {exc.field}", exc.reason)
    save_artifact(result.model, out, lineage=inputs.lineage, exports=True)
    metrics = result.metrics.to_dict()
    if json_output:
        summary = {
            "status": "ok",
            "out": str(out),
            "seed": run_seed,
            "datasets": len(inputs.pool),
            "test_sets": result.split.test_sets,
            "ensemble_size": result.model.ensemble_size,
            "files": sorted(p.name for p in out.iterdir()),
            **metrics,
        }
        typer.echo(json.dumps(summary, indent=2))
    else:
        _print_metrics(metrics, out)


@app.command()
def predict(
    model: Path = typer.Option(..., "--model", help="model folder written by `alcove surrogate train`"),
    trajectory: Path = typer.Option(..., "--trajectory", help="trajectory CSV (t,q_0,..,qd_0,..[,tau_0,..])"),
    out: Path = typer.Option(
        ..., "--out", help="forces CSV to write (t,fx,fy,fz,mx,my,mz; for K > 1 also fx_std,..,mz_std)"
    ),
) -> None:
    """Predict the contact force and moment (ensemble mean, and std for K > 1) along a trajectory."""
    import numpy as np

    from alcove.science.series import FORCE_COLUMNS, ForceSeries, SeriesFormatError, Trajectory
    from alcove.science.surrogate.artifact import ArtifactError, load_artifact
    from alcove.science.surrogate.dataset import PoolDataError
    from alcove.science.surrogate.training import predict_ensemble

    try:
        surrogate = load_artifact(model)
    except ArtifactError as exc:
        _bad_input(f"model: {exc.field}" if exc.field != "model" else "model", exc.reason)
    try:
        traj = Trajectory.from_csv(trajectory)
    except SeriesFormatError as exc:
        _bad_input(f"trajectory: {exc.field}", exc.reason)
    if not out.parent.is_dir():
        _bad_input("out", f"folder {out.parent} does not exist")
    kinematics = None
    if traj.q.shape[1] > 1:  # a chain: the features come from the head's pose columns of the file
        from alcove.science.geometry import kinematics_from_pose

        if traj.pose is None:
            _bad_input("trajectory", "a trajectory of several joints must carry the head pose columns (head_x, ...)")
        pose = traj.pose
        kinematics = lambda _q, _qd: kinematics_from_pose(pose)  # noqa: E731
    try:
        p = predict_ensemble(surrogate, traj.q, traj.qd, kinematics=kinematics, t=traj.t)
    except PoolDataError as exc:
        _bad_input(f"trajectory: {exc.field}", exc.reason)
    forces = ForceSeries(np.asarray(traj.t, float), p.force, p.moment)
    if surrogate.ensemble_size == 1:
        forces.to_csv(out)
    else:
        header = ["t", *FORCE_COLUMNS, *(f"{c}_std" for c in FORCE_COLUMNS)]
        table = np.column_stack([forces.to_array(), p.force_std, p.moment_std])
        np.savetxt(out, table, delimiter=",", header=",".join(header), comments="", fmt="%.17g")
    typer.echo(
        f"{len(forces)} samples, peak force {forces.peak_force:.4g} N"
        + (f" (ensemble of {surrogate.ensemble_size})" if surrogate.ensemble_size > 1 else "")
        + f" -> {out}"
    )


@app.command()
def preliminary(
    out: Path = typer.Option(
        ..., "--out", help="pool folder to write (preliminary-NN.traj.csv + .forces.csv, pool.json)"
    ),
    samples: int | None = typer.Option(None, "--samples", help="number K of Latin hypercube samples (default 4000)"),
    velocity_bound: float | None = typer.Option(
        None, "--velocity-bound", help="joint velocities drawn from [-V, V] rad/s (default 2)"
    ),
    chunks: int | None = typer.Option(None, "--chunks", help="datasets the samples are dealt into (default 10)"),
    seed: int = typer.Option(0, "--seed", min=0),
    task: str | None = typer.Option(
        None, "--task", help="task preset whose geometry and joint range to use (default: head-neck-1dof)"
    ),
    task_file: Path | None = typer.Option(None, "--task-file", help="task definition as JSON (instead of --task)"),
) -> None:
    """Write the aux-penalty Latin hypercube preliminary data set as a pool folder."""
    from alcove.science.surrogate.dataset import PoolDataError, save_pool_dir
    from alcove.science.surrogate.preliminary import (
        DEFAULT_CHUNKS,
        DEFAULT_SAMPLES,
        DEFAULT_VELOCITY_BOUND,
        preliminary_pool,
    )

    preset = _task_preset(task, task_file)
    try:
        pool = preliminary_pool(
            preset,
            samples=DEFAULT_SAMPLES if samples is None else samples,
            velocity_bound=DEFAULT_VELOCITY_BOUND if velocity_bound is None else velocity_bound,
            seed=seed,
            chunks=DEFAULT_CHUNKS if chunks is None else chunks,
        )
    except PoolDataError as exc:
        _bad_input(exc.field.replace("_", "-"), exc.reason)
    if out.exists() and not out.is_dir():
        _bad_input("out", f"{out} exists and is not a folder")
    save_pool_dir(pool, out)
    n = sum(ds.n_samples for ds in pool)
    in_contact = sum(int((ds.force[:, 0] > 0).sum()) for ds in pool)
    typer.echo(f"{n} samples ({in_contact} in contact) in {len(pool)} datasets -> {out}")
