"""`alcove surrogate compare`: surrogate variants (the paper's model, the gated architecture, the
history feature set) trained on one pool and scored side by side on the held-out validation suite
(:mod:`alcove.science.surrogate.compare`).

Registered on the ``surrogate`` group by :mod:`alcove_worker.cli.main`; bad input prints one line
``error: <field>: <reason>`` and exits with code 2, a failed oracle replay exits with code 1.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer

from alcove_worker.cli.surrogate import _bad_input, load_training_inputs

if TYPE_CHECKING:
    from alcove.science.geometry import HeadNeckPreset
    from alcove.science.surrogate.dataset import PoolDataset


def _print_comparison(scores: list[dict[str, Any]], title: str) -> None:
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    def fmt(v: float | None) -> str:
        return "-" if v is None else f"{v:.4g}"

    rows = [
        ("force RMSE [N]", "force_rmse"),
        ("moment RMSE [N m]", "moment_rmse"),
        ("force RMSE in contact [N]", "force_rmse_contact"),
        ("moment RMSE in contact [N m]", "moment_rmse_contact"),
        ("fx RMSE [N]", "fx_rmse"),
        ("fz RMSE [N]", "fz_rmse"),
        ("my RMSE [N m]", "my_rmse"),
        ("ghost |F| max, gap open [N]", "ghost_force_max"),
        ("ghost |F| RMS, gap open [N]", "ghost_force_rms"),
        ("ghost |M| max, gap open [N m]", "ghost_moment_max"),
        ("oracle |F| max, gap open [N]", "oracle_force_open_max"),
        ("ghost |F| max, state grid [N]", "grid_ghost_force_max"),
        ("test force RMSE (in training) [N]", "test_force_rmse"),
        ("test moment RMSE (in training) [N m]", "test_moment_rmse"),
    ]
    table = Table(title=title)
    table.add_column("metric")
    for sc in scores:
        table.add_column(sc["variant"], justify="right")
    for label, key in rows:
        table.add_row(escape(label), *(fmt(sc[key]) for sc in scores))
    table.add_row("epochs force / moment", *(f"{sc['epochs']['force']} / {sc['epochs']['moment']}" for sc in scores))
    console = Console()
    console.print(table)
    s0 = scores[0]
    console.print(
        f"suite: {s0['n_samples']} samples, {s0['n_contact_samples']} in contact, {s0['n_open_samples']} with the "
        "gap open (signed gap >= 2 mm); RMSE of the force (moment) error vector over the suite"
    )


def compare(
    pool_dir: Path | None = typer.Option(None, "--pool", help="pool folder of NAME.traj.csv + NAME.forces.csv pairs"),
    campaign: int | None = typer.Option(
        None, "--campaign", help="the campaign's latest pool version, surrogate config, task geometry and seed"
    ),
    suite_dir: Path | None = typer.Option(
        None, "--suite", help="held-out motions already replayed (a pool folder; none of them in the pool)"
    ),
    oracle: str = typer.Option(
        "fe-headrest-2d", "--oracle", help="without --suite: the oracle that replays the validation suite here"
    ),
    oracle_params: Path | None = typer.Option(None, "--oracle-params", help="JSON object of oracle parameters"),
    motions: int = typer.Option(8, "--motions", min=1, max=64, help="without --suite: motions of the suite"),
    suite_seed: int = typer.Option(0, "--suite-seed", min=0, help="without --suite: seed of the suite's motions"),
    suite_out: Path | None = typer.Option(None, "--suite-out", help="save the replayed suite as a pool folder"),
    config_file: Path | None = typer.Option(
        None, "--config", help="surrogate configuration as JSON (its architecture is overridden; default: the paper's)"
    ),
    seed: int | None = typer.Option(None, "--seed", min=0, help="training seed of both (default: config's/campaign's)"),
    task: str | None = typer.Option(
        None, "--task", help="task preset of the pool's geometry (default: head-neck-1dof)"
    ),
    task_file: Path | None = typer.Option(None, "--task-file", help="task definition as JSON (instead of --task)"),
    variants: str = typer.Option(
        "paper,gated,history",
        "--variants",
        help="comma-separated variants: paper (the paper's model), gated (its contact-aware output layer), history "
        "(the paper's features and the history states)",
    ),
    models_out: Path | None = typer.Option(
        None, "--models-out", help="write each variant's model to DIR/<variant> (with its exports)"
    ),
    json_output: bool = typer.Option(False, "--json", help="print the scores as JSON"),
    database_url: str | None = typer.Option(None, "--database-url", envvar="ALCOVE_DATABASE_URL", hidden=True),
) -> None:
    """Train surrogate variants (paper, gated, history) on one pool and score each on the validation suite."""
    from alcove.science.surrogate.artifact import save_artifact
    from alcove.science.surrogate.compare import VARIANTS, compare_variants, replay_suite
    from alcove.science.surrogate.dataset import PoolDataError, load_pool_dir, save_pool_dir

    chosen = [v.strip() for v in variants.split(",") if v.strip()]
    unknown = [v for v in chosen if v not in VARIANTS]
    if not chosen or unknown or len(set(chosen)) != len(chosen):
        _bad_input(
            "variants",
            f"give distinct variants among {', '.join(VARIANTS)}, comma-separated"
            + (f" ({', '.join(map(repr, unknown))} is not one)" if unknown else ""),
        )
    inputs = load_training_inputs(pool_dir, campaign, config_file, task, task_file, database_url)
    if inputs.kinematics is not None:
        _bad_input("task", "surrogate compare takes the head-neck-1dof model only so far, not a chain")
    pool, config, preset, default_seed = inputs.pool, inputs.config, inputs.preset, inputs.default_seed
    if suite_dir is not None:
        try:
            suite = load_pool_dir(suite_dir)
        except PoolDataError as exc:
            _bad_input(f"suite: {exc.field}", exc.reason)
    else:
        suite = _replay_suite(oracle, oracle_params, motions, suite_seed, preset, replay_suite)
        if suite_out is not None:
            save_pool_dir(suite, suite_out)
    if suite_dir is not None and pool_dir is not None and suite_dir.resolve() == pool_dir.resolve():
        _bad_input("suite", "is the pool itself: the suite must be held out")
    run_seed = seed if seed is not None else (default_seed if default_seed is not None else config.seed)
    try:
        scores, models = compare_variants(pool, suite, config, run_seed, preset, chosen)
    except PoolDataError as exc:
        _bad_input(f"pool: {exc.field}", exc.reason)
    if models_out is not None:
        for variant, model in models.items():
            save_artifact(model, models_out / variant, exports=True)
    rows = [sc.to_dict() for sc in scores]
    if json_output:
        typer.echo(json.dumps({"seed": run_seed, "datasets": len(pool), "suite_motions": len(suite), "scores": rows}))
    else:
        title = f"{' vs '.join(chosen)}: {len(pool)} datasets, {len(suite)} held-out motions, seed {run_seed}"
        _print_comparison(rows, title)


def _replay_suite(
    oracle: str, params_file: Path | None, motions: int, seed: int, preset: HeadNeckPreset, replay: Any
) -> list[PoolDataset]:
    """The validation suite's motions replayed with ``oracle`` in this process."""
    from alcove.science.oracles.base import OracleInputError
    from alcove.science.oracles.registry import build_oracle
    from alcove.science.validation_suite import SuiteSpec, suite_trajectories

    values: dict[str, Any] = {}
    if params_file is not None:
        try:
            values = json.loads(params_file.read_text())
        except (FileNotFoundError, json.JSONDecodeError, UnicodeDecodeError) as exc:
            _bad_input("oracle-params", f"cannot read {params_file}: {exc}")
        if not isinstance(values, dict):
            _bad_input("oracle-params", "must hold a JSON object")
    try:
        instance = build_oracle(oracle, values, preset=preset)
        trajectories = suite_trajectories(SuiteSpec(motions=motions, seed=seed), preset)
    except OracleInputError as exc:
        _bad_input(f"oracle: {exc.field}", exc.reason)
    except ValueError as exc:
        _bad_input("suite", str(exc))

    def run(traj: Any) -> Any:
        result = instance.run(traj)
        if not result.ok:
            typer.echo(f"error: suite: the oracle failed a motion: {result.failure_reason}", err=True)
            raise typer.Exit(1)
        return result.forces

    typer.echo(f"replaying {len(trajectories)} validation-suite motions with {oracle} ...", err=True)
    suite: list[PoolDataset] = replay(run, trajectories)
    return suite
