"""`alcove oracle ...` commands: replay a trajectory with an oracle, list the types, show schemas.

Bad input (files, columns, parameters, unknown types) prints one line ``error: <field>:
<reason>`` and exits with code 2; an oracle run that fails its quality gate exits with
code 1 and writes no forces file.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

import typer

if TYPE_CHECKING:
    from alcove.science.oracles.base import OracleResult
    from alcove.science.oracles.command import CommandOracleSpec

app = typer.Typer(help="Run oracles (the ground truth of a campaign) and inspect their types.", no_args_is_help=True)

EXIT_FAILED_RUN = 1
EXIT_BAD_INPUT = 2


def _bad_input(field: str, reason: str) -> NoReturn:
    typer.echo(f"error: {field}: {reason}", err=True)
    raise typer.Exit(EXIT_BAD_INPUT)


def _catalogue(path: Path | None, needed: bool) -> dict[str, CommandOracleSpec] | None:
    """The command catalogue from ``--catalogue`` or ``ALCOVE_COMMAND_ORACLES_FILE`` (None if neither)."""
    from alcove.science.oracles.command import CatalogueError, load_command_catalogue

    if path is None and needed:
        from alcove.settings import get_settings

        path = get_settings().command_oracles_file
    if path is None:
        return None
    try:
        return load_command_catalogue(path)
    except CatalogueError as exc:
        _bad_input(f"catalogue: {exc.field}", exc.reason)


def _read_params(path: Path | None) -> dict[str, Any]:
    if path is None:
        return {}
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        _bad_input("params", f"{path} does not exist")
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        _bad_input("params", f"{path} is not valid JSON ({exc})")
    if not isinstance(data, dict):
        _bad_input("params", f"{path} must hold a JSON object of parameter values")
    return data


def run_summary(oracle_name: str, result: OracleResult, out: Path | None) -> dict[str, Any]:
    """The ``--json`` summary: status, wall time, peak force, max penetration, dissipated energy, Newton iterations."""
    from alcove.science.json_values import json_safe
    from alcove.science.oracles.registry import SUMMARY_DIAGNOSTICS as SUMMARY_KEYS

    headline = {k: result.diagnostics.get(k) for k in SUMMARY_KEYS}
    if headline["newton_iterations"] is None:  # the FE oracle reports its total under this name
        headline["newton_iterations"] = result.diagnostics.get("newton_iterations_total")
    extra = {k: v for k, v in result.diagnostics.items() if k not in SUMMARY_KEYS}
    summary: dict[str, Any] = json_safe(  # typed Any; a dict in, a dict out
        {
            "status": "ok" if result.ok else "failed",
            "oracle": oracle_name,
            "failure_reason": result.failure_reason,
            "wall_time_s": result.wall_time,
            "peak_force_n": None if result.forces is None else result.forces.peak_force,
            **headline,
            "samples": None if result.forces is None else len(result.forces),
            "out": None if out is None else str(out),
            "diagnostics": extra,
        }
    )
    return summary


@app.command("run")
def run(
    oracle: str = typer.Option(
        ..., "--oracle", help="fe-headrest-2d, fe-headrest-3d-ccx, aux-penalty or a command oracle of the catalogue"
    ),
    trajectory: Path = typer.Option(
        ..., "--trajectory", help="trajectory CSV (t,q_i,qd_i[,tau_i],head_x..head_omega; docs/external-solvers.md)"
    ),
    out: Path = typer.Option(..., "--out", help="forces CSV to write (t,fx,fy,fz,mx,my,mz; N, N m, headrest frame)"),
    params: Path | None = typer.Option(None, "--params", help="JSON object of oracle parameters"),
    catalogue: Path | None = typer.Option(
        None, "--catalogue", help="YAML catalogue of command oracles (default: $ALCOVE_COMMAND_ORACLES_FILE)"
    ),
    json_output: bool = typer.Option(False, "--json", help="print a JSON summary of the run on stdout"),
) -> None:
    """Replay a trajectory with an oracle and write the contact force and moment on the head."""
    from alcove.science.oracles.base import OracleCancelled, OracleInputError
    from alcove.science.oracles.registry import BUILTIN_TYPE_NAMES, build_oracle
    from alcove.science.series import SeriesFormatError, Trajectory

    values = _read_params(params)
    cat = _catalogue(catalogue, needed=oracle not in BUILTIN_TYPE_NAMES)
    if not out.parent.is_dir():
        _bad_input("out", f"folder {out.parent} does not exist")
    try:
        traj = Trajectory.from_csv(trajectory)
    except SeriesFormatError as exc:
        _bad_input(f"trajectory: {exc.field}", exc.reason)
    try:
        instance = build_oracle(oracle, values, catalogue=cat)
        result = instance.run(traj)
    except OracleInputError as exc:
        _bad_input(exc.field, exc.reason)
    except (OracleCancelled, KeyboardInterrupt):
        typer.echo("error: cancelled", err=True)
        raise typer.Exit(130) from None
    forces = result.forces if result.ok else None
    if result.ok:
        assert forces is not None  # an oracle's result that passed its quality gate carries the forces
        forces.to_csv(out)
    if json_output:
        typer.echo(json.dumps(run_summary(oracle, result, out if result.ok else None), indent=2))
    elif forces is not None:
        peak = forces.peak_force
        typer.echo(f"ok: {len(forces)} samples, peak force {peak:.4g} N, {result.wall_time:.3g} s -> {out}")
    if not result.ok:
        typer.echo(f"failed: {result.failure_reason}", err=True)
        raise typer.Exit(EXIT_FAILED_RUN)


@app.command("list")
def list_types(
    catalogue: Path | None = typer.Option(
        None, "--catalogue", help="YAML catalogue of command oracles (default: $ALCOVE_COMMAND_ORACLES_FILE)"
    ),
    json_output: bool = typer.Option(False, "--json", help="print JSON instead of a table"),
) -> None:
    """List the oracle types: built-in ones and the administrator's command oracles."""
    from alcove.science.oracles.registry import list_oracle_types

    rows = list_oracle_types(_catalogue(catalogue, needed=True))
    if json_output:
        typer.echo(json.dumps(rows, indent=2))
        return
    from rich.console import Console
    from rich.table import Table

    table = Table("name", "kind", "available", "description")
    for row in rows:
        table.add_row(
            row["name"],
            row["kind"],
            "yes" if row["available"] else f"no: {row['unavailable_reason']}",
            row["description"],
        )
    Console().print(table)


@app.command("schema")
def schema(
    oracle_type: str = typer.Argument(
        ..., metavar="TYPE", help="fe-headrest-2d, fe-headrest-3d-ccx, aux-penalty or a command oracle's name"
    ),
    catalogue: Path | None = typer.Option(
        None, "--catalogue", help="YAML catalogue of command oracles (default: $ALCOVE_COMMAND_ORACLES_FILE)"
    ),
) -> None:
    """Print the JSON schema of an oracle type's parameters."""
    from alcove.science.oracles.base import OracleInputError
    from alcove.science.oracles.registry import BUILTIN_TYPE_NAMES, params_json_schema

    cat = _catalogue(catalogue, needed=oracle_type not in BUILTIN_TYPE_NAMES)
    try:
        typer.echo(json.dumps(params_json_schema(oracle_type, cat), indent=2))
    except OracleInputError as exc:
        _bad_input(exc.field, exc.reason)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(app())
