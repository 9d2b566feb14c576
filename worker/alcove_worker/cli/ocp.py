"""`alcove ocp ...` commands: solve an optimal-control task, list and show task presets.

``alcove ocp solve --task head-headrest-2phase [--task-file F.json] [--contact aux|none|model:FILE]
[--intervals N] [--trust-region-max-std N] [--pool DIR] --out traj.csv [--json]`` writes the
solution on the OCP grid as a trajectory CSV (``t,q_0,..,qd_0,..,tau_0,..`` and the head's pose
``head_x,head_z,head_angle,head_vx,head_vz,head_omega``) and prints a
summary (status, iterations, cost, constraint violation, wall time). A task file may use any
model (``head-neck-1dof``, ``head-neck-2dof``, ``trunk-neck-head-3dof`` or a user-defined
``chain``, docs/multibody.md) with any contact. Bad input prints
``error: <field>: <reason>`` and exits with code 2; a solve that does not converge still
writes the CSV (when its numbers are finite) but exits with code 1.

With a surrogate (``model:FILE``) the solution's trust diagnostics
(:mod:`alcove.science.surrogate.trust`) are printed: a solution that relies on force outside
the data prints ``warning: untrusted solution: <reason>`` to stderr and its ``--json`` has
``"trusted": false`` with ``"trust_reasons"`` (the exit code stays that of the solve).
``--trust-region-max-std`` bounds the ensemble's force std [N] along the solution;
``--pool DIR`` adds the distance to the nearest pool sample.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

import typer

if TYPE_CHECKING:
    from alcove.science.ocp.task_spec import TaskSpec
    from alcove_worker.cli.trust import TrustInputs

app = typer.Typer(help="Optimal control of the multibody model (DMOCC + IPOPT).", no_args_is_help=True)

EXIT_NOT_CONVERGED = 1
EXIT_BAD_INPUT = 2


def _bad_input(field: str, reason: str) -> NoReturn:
    typer.echo(f"error: {field}: {reason}", err=True)
    raise typer.Exit(EXIT_BAD_INPUT)


def _load_task(task: str | None, task_file: Path | None, intervals: int | None) -> TaskSpec:
    from alcove.science.ocp.task_spec import TaskSpecError, parse_task, task_preset

    try:
        if task_file is not None:
            if not task_file.exists():
                _bad_input("task-file", f"{task_file} does not exist")
            spec = parse_task(task_file)
        elif task is not None and task.endswith(".json"):  # --task FILE.json: a task definition file
            path = Path(task)
            if not path.is_file():
                _bad_input("task", f"{task} does not exist (a task preset name or a task definition .json file)")
            spec = parse_task(path)
        else:
            spec = task_preset(task or "head-headrest-2phase")
        if intervals is not None:
            spec = spec.with_intervals(intervals)
    except TaskSpecError as exc:
        _bad_input(exc.field, exc.reason)
    return spec


@app.command()
def solve(
    task: str = typer.Option(
        "head-headrest-2phase", help="task preset name, or a task definition FILE.json (ignored with --task-file)"
    ),
    task_file: Path | None = typer.Option(None, "--task-file", help="task definition as JSON (see `alcove ocp show`)"),
    contact: str = typer.Option("aux", help="contact model: aux, none or model:FILE (a trained surrogate artifact)"),
    intervals: int | None = typer.Option(None, min=1, help="DMOCC intervals per phase (overrides the task)"),
    max_iter: int | None = typer.Option(None, "--max-iter", min=1, help="IPOPT iterations per attempt (default 500)"),
    out: Path = typer.Option(..., help="output trajectory CSV on the OCP grid"),
    as_json: bool = typer.Option(False, "--json", help="print the summary as JSON"),
    trust_region_max_std: float | None = typer.Option(
        None, "--trust-region-max-std", help="with model:FILE, bound the ensemble's force std along the solution [N]"
    ),
    pool: Path | None = typer.Option(None, help="with model:FILE, the pool folder: distance to the nearest sample"),
) -> None:
    """Solve a task and write the optimal trajectory."""
    from alcove.science.ocp.contact import ContactModelError, contact_from_spec, contact_history_from_spec
    from alcove.science.ocp.solve import solve_task
    from alcove.science.series import SeriesFormatError

    if out.is_dir():
        _bad_input("out", f"{out} is a directory; give the CSV file to write")
    if not out.parent.is_dir():
        _bad_input("out", f"directory {out.parent} does not exist")
    spec = _load_task(task if task_file is None else None, task_file, intervals)
    try:
        # a chain model (n-DOF preset or user-defined): the aux contact fed by its head's pose
        body = spec.chain() if spec.model.is_chain else spec.preset()
        contact_fn = contact_from_spec(contact, body)
        history = contact_history_from_spec(contact, body)  # a model with memory: the NLP carries its states
    except ContactModelError as exc:
        _bad_input(exc.field, exc.reason)
    except ImportError as exc:
        _bad_input("contact", f"surrogate models are not available ({exc})")
    except (ValueError, OSError) as exc:
        _bad_input("contact", str(exc))
    trust = _trust_inputs(contact, spec, trust_region_max_std, pool)
    solution = solve_task(
        spec,
        contact_fn,
        ipopt_options=None if max_iter is None else {"ipopt.max_iter": max_iter},
        path=None if trust is None else trust.path,
        history=history,
    )
    try:
        solution.trajectory.to_csv(out)
        written = str(out)
    except SeriesFormatError as exc:  # a failed solve may hold non-finite numbers
        typer.echo(f"warning: no trajectory written ({exc})", err=True)
        written = None
    summary: dict[str, object] = {**solution.summary(), "contact": contact, "out": written}
    if trust is not None:
        report = trust.assess(solution.t, solution.q)
        summary.update(trusted=report.trusted, trust_reasons=report.reasons, trust=report.to_dict())
        summary["trust_region_max_std"] = trust_region_max_std
        for reason in report.reasons:
            typer.echo(f"warning: untrusted solution: {reason}", err=True)
    if as_json:
        typer.echo(json.dumps(summary, indent=2))
    else:
        typer.echo(
            f"{summary['status']}: {summary['iterations']} iterations, cost {summary['cost']:.6g}, "
            f"constraint violation {summary['constraint_violation']:.2g}, {summary['wall_time_s']:.3f} s -> {out}"
        )
    if not solution.converged:
        typer.echo("warning: IPOPT did not converge; the trajectory is not an optimum", err=True)
        raise typer.Exit(EXIT_NOT_CONVERGED)


def _trust_inputs(contact: str, spec: TaskSpec, max_std: float | None, pool: Path | None) -> TrustInputs | None:
    """The surrogate's trust diagnostics and trust region for ``model:FILE`` (None for other contacts)."""
    if not contact.startswith("model:"):
        if max_std is not None:
            _bad_input("trust-region-max-std", "needs a surrogate contact model (model:FILE)")
        if pool is not None:
            _bad_input("pool", "needs a surrogate contact model (model:FILE)")
        return None
    from alcove_worker.cli.trust import TrustInputError, TrustInputs

    try:
        chain = spec.chain() if spec.model.is_chain else None
        model_path = Path(contact.removeprefix("model:"))
        return TrustInputs.load(model_path, spec.model.oracle_preset(), max_std, pool, chain)
    except TrustInputError as exc:
        _bad_input(exc.field, exc.reason)


@app.command("tasks")
def list_tasks() -> None:
    """List the task presets."""
    from alcove.science.ocp.task_spec import TASK_PRESETS

    for name, data in TASK_PRESETS.items():
        typer.echo(f"{name}: {data.get('description', '')}")


@app.command()
def show(
    name: str | None = typer.Argument(None, help="task preset name (as --task)"),
    task: str = typer.Option("head-headrest-2phase", help="task preset name"),
) -> None:
    """Print a task preset as JSON, its model included (a starting point for --task-file)."""
    spec = _load_task(name or task, None, None)
    typer.echo(spec.model_dump_json(indent=2))
