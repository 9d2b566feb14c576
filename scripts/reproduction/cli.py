"""The command line of the reproduction: ``python scripts/reproduce.py [OPTIONS]`` (``make reproduce``)."""

from __future__ import annotations

import sys
import tempfile
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any

import typer

from .campaigns import WORKER, fresh_store, remedy_budget
from .figures import matplotlib_missing
from .loop import part_campaign, part_remedies
from .record import REPO, Report
from .report import SECTION_TITLES, machine, write_markdown
from .solution import part_fe, part_multibody
from .sweep import part_sweep

app = typer.Typer(add_completion=False)


@app.command()
def main(
    quick: bool = typer.Option(
        False, "--quick", help="smoke run: aux-penalty campaigns with a small preliminary set, few iterations"
    ),
    iterations: int | None = typer.Option(
        None, "--iterations", "-n", min=1, help="baseline campaign iterations (default 200, quick 3)"
    ),
    remedy_iterations: int | None = typer.Option(
        None,
        "--remedy-iterations",
        min=1,
        help="iterations of each remedy campaign "
        "(at most --iterations; default: as many as fit in --budget-min, quick 1)",
    ),
    budget_min: float = typer.Option(
        35.0,
        "--budget-min",
        min=1.0,
        help="wall-time budget of the whole run in minutes: sets the default --remedy-iterations",
    ),
    oracle: str = typer.Option("fe-headrest-2d", help="oracle of the campaigns (quick: aux-penalty)"),
    preliminary_weight: float = typer.Option(
        0.1, min=0.0, help="sample weight of the preliminary data in the down-weighting remedy"
    ),
    out: Path = typer.Option(REPO / "docs", help="folder for reproduction.md and reproduction/*.png"),
    data_dir: Path | None = typer.Option(
        None, help="alcove data dir for the run's database and artifacts (default: a fresh temporary folder)"
    ),
    skip: list[str] = typer.Option([], help="parts to skip: multibody, fe, campaign, remedies"),
    celery: bool = typer.Option(
        True,
        "--celery/--inline",
        help="campaign steps through Celery with a spawned `alcove worker` on the embedded broker "
        "(default, as `alcove campaign run`), or in this process (--inline: same protocol and rows, no broker)",
    ),
    concurrency: int = typer.Option(1, min=1, help="processes of the spawned worker (with --celery)"),
    render_only: Path | None = typer.Option(
        None,
        "--render-only",
        help="run nothing: re-render OUT/reproduction.md from a run's reproduction/run.json with the current "
        "verdict rules (its numbers, date and figures stay those of that run)",
    ),
) -> None:
    """Run the paper's proof of concept with alcove and write OUT/reproduction.md with figures."""
    if render_only is not None:
        import json

        data = json.loads(render_only.read_text())
        args = {"rendered": f"re-rendered from {render_only.name} with the current verdict rules", **data["args"]}
        path = write_markdown(Report.from_json(data, out), data["info"], args, float(data["total"]), data["date"])
        typer.echo(f"[reproduce] wrote {path}", err=True)
        return
    missing = matplotlib_missing()
    if missing:  # before anything runs: every part draws a figure
        typer.echo(f"[reproduce] {missing}", err=True)
        raise typer.Exit(1)
    n = iterations or (3 if quick else 200)
    m = (
        min(remedy_iterations, n) if remedy_iterations else (1 if quick else None)
    )  # None: chosen after the baseline from the budget
    (out / "reproduction").mkdir(parents=True, exist_ok=True)
    tmp = None
    if data_dir is None:
        tmp = tempfile.TemporaryDirectory(prefix="alcove-reproduce-")
        data_dir = Path(tmp.name)
    rep = Report(quick=quick, out=out)
    info = machine()
    t_start = time.perf_counter()

    def part(name: str, fn: Callable[[], Any]) -> Any:
        if name in skip:
            rep.errors[name] = "skipped (--skip)"
            return None
        typer.echo(f"[reproduce] {SECTION_TITLES[name]} ...", err=True)
        t0 = time.perf_counter()
        try:
            return fn()
        except Exception:
            rep.errors[name] = traceback.format_exc(limit=4)
            typer.echo(rep.errors[name], err=True)
            return None
        finally:
            typer.echo(f"[reproduce]   {time.perf_counter() - t0:.1f} s", err=True)

    try:
        mb = part("multibody", lambda: part_multibody(rep))
        if mb is not None:
            part("fe", lambda: part_fe(rep, *mb))
        elif "fe" not in skip:
            rep.errors["fe"] = "needs the multibody solution (part 1 failed)"
        part("sweep", lambda: part_sweep(rep))
        fresh_store(data_dir)
        if celery:
            from alcove_worker.cli.follow import spawn_worker

            WORKER["log"], WORKER["concurrency"] = data_dir / "worker.log", concurrency
            WORKER["process"] = spawn_worker(concurrency, log_path=WORKER["log"])
        rep.timings_note = (
            "steps run by a spawned Celery worker (embedded default: SQLite + filesystem broker)"
            if celery
            else "steps run in this process (protocol.drive_inline)"
        )
        base = part("campaign", lambda: part_campaign(rep, n, oracle))
        if base is not None:
            if m is None:
                m = remedy_budget(base, n, budget_min * 60.0 - (time.perf_counter() - t_start))
                typer.echo(
                    f"[reproduce] {m} iterations per remedy campaign "
                    f"(as many as fit in the {budget_min:g} min budget; --remedy-iterations to choose)",
                    err=True,
                )
            part("remedies", lambda: part_remedies(rep, base, m, oracle, preliminary_weight))
        elif "remedies" not in skip:
            rep.errors["remedies"] = "needs the baseline campaign (part 3 failed)"
        argv = " ".join(["scripts/reproduce.py", *sys.argv[1:]])
        path = write_markdown(
            rep, info, {"command": argv, "iterations": n, "remedy_iterations": m or 0}, time.perf_counter() - t_start
        )
        typer.echo(f"[reproduce] wrote {path}", err=True)
    finally:
        if WORKER:
            from alcove_worker.cli.follow import stop_worker

            stop_worker(WORKER.pop("process"))
            WORKER.clear()
        if tmp is not None:
            from alcove.db import dispose_engines

            dispose_engines()
            tmp.cleanup()
    failed = [k for k, v in rep.errors.items() if not v.startswith("skipped")]
    if failed:
        typer.echo(f"[reproduce] failed parts: {', '.join(failed)}", err=True)
        raise typer.Exit(1)
