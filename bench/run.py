"""Run every registered benchmark figure and print one table (also bench/results.json).

Usage: python -m bench.run [--quick] [--only SUBSTRING] [--out bench/results.json]
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import pkgutil
import platform
import sys
import time
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from bench import figures as figures_pkg
from bench import harness
from bench.harness import FIGURES, summarize


def load_figures() -> None:
    for mod in sorted(pkgutil.iter_modules(figures_pkg.__path__), key=lambda m: m.name):
        importlib.import_module(f"bench.figures.{mod.name}")


def _cpu_seconds() -> float:
    import resource

    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def machine() -> dict[str, Any]:
    """What the figures were measured on: CPU model, CPUs this process may use, load average, and two
    reference timings (best of 3), so that runs on different machines can be compared: a pure-Python loop
    (interpreter speed: the OCP's setup, the API) and PyTorch's float64 softplus on 30,720 values, one thread
    (the training's dominant kernel: members x hidden units x batch of the K = 5 training)."""
    import torch

    from alcove.science.parallel import usable_cpus

    model = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass

    def best_of_3(fn: Any) -> float:
        times = []
        for _ in range(3):
            start = time.perf_counter()
            fn()
            times.append(time.perf_counter() - start)
        return min(times)

    def python_loop() -> None:
        total = 0
        for i in range(2_000_000):
            total += i

    x = torch.linspace(-5.0, 5.0, 30_720, dtype=torch.float64)
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        softplus = best_of_3(lambda: [torch.nn.functional.softplus(x) for _ in range(100)]) / 100
    finally:
        torch.set_num_threads(threads)
    return {
        "cpu": model,
        "cpus": usable_cpus(),
        "load_average": [round(v, 2) for v in os.getloadavg()],
        "python_loop_2e6_s": round(best_of_3(python_loop), 4),
        "softplus_30720_f64_us": round(softplus * 1e6, 1),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="fewer repetitions, skip the long figures (< 2 min)")
    ap.add_argument("--only", default=None, help="run only figures whose name contains this text")
    ap.add_argument("--out", default=str(Path(__file__).with_name("results.json")))
    args = ap.parse_args(argv)
    load_figures()
    # a wide table when written to a file or pipe (a terminal keeps its own width)
    console = Console() if sys.stdout.isatty() else Console(width=220)
    rows = []
    t_start = time.perf_counter()
    cpu_start = _cpu_seconds()
    harness.MODE = "quick" if args.quick else "full"
    host = machine()
    console.print(
        f"machine: {host['cpu']}, {host['cpus']} CPUs, load {host['load_average']}; reference: Python loop of "
        f"2e6 additions {host['python_loop_2e6_s']:.3f} s, float64 softplus of 30,720 values "
        f"{host['softplus_30720_f64_us']:.0f} us (compare these before comparing figures across machines)"
    )
    # a setup shared by several figures (the same function) runs once per bench run
    setups: dict[Any, Any] = {}
    failed: list[str] = []
    for fig in FIGURES:
        if args.only and args.only not in fig.name:
            continue
        if args.quick and not fig.quick:
            continue
        reason = fig.requires() if fig.requires else None
        if reason:
            console.print(f"[yellow]skip[/] {fig.name}: {reason}")
            row = summarize(fig)
            row["skipped"] = reason
            rows.append(row)
            continue
        reps = fig.quick_reps if args.quick else fig.reps
        console.print(f"[bold]{fig.name}[/] ({reps} reps)")
        t_fig = time.perf_counter()
        ctx = None
        t_setup = 0.0
        error = None
        try:
            if fig.setup is not None:
                if fig.setup not in setups:
                    try:
                        setups[fig.setup] = fig.setup()
                    except Exception as exc:
                        setups[fig.setup] = _SetupFailed(exc)
                ctx = setups[fig.setup]
                if isinstance(ctx, _SetupFailed):
                    raise ctx.exc
            t_setup = time.perf_counter() - t_fig
            for _ in range(reps):
                fig.values.append(float(fig.run(ctx)))
        except Exception as exc:
            error = f"{type(exc).__name__}: {exc}".strip()[:300]
            console.print(f"[red]error[/] {fig.name}: {error}")
            failed.append(fig.name)
        row = summarize(fig)
        row["bench_setup_s"], row["bench_total_s"] = t_setup, time.perf_counter() - t_fig
        if error is not None:
            row["error"] = error
        rows.append(row)
    by_name = {r["figure"]: r for r in rows}
    for r in rows:
        b = by_name.get(r["baseline"]) if r["baseline"] else None
        r["ratio_to_baseline"] = (r["median"] / b["median"]) if b and b["median"] and r["median"] is not None else None

    table = Table(title=f"alcove benchmarks ({'quick' if args.quick else 'full'})")
    for c in ("figure", "unit", "median", "min", "max", "reps", "target", "ok", "ratio"):
        table.add_column(c, justify="left" if c in ("figure", "unit") else "right")
    fmt = lambda x: "-" if x is None else (f"{x:.4g}")  # noqa: E731
    for r in rows:
        ok = (
            "skip"
            if r.get("skipped")
            else "ERROR"
            if r.get("error")
            else ("-" if r["within_target"] is None else ("yes" if r["within_target"] else "NO"))
        )
        target = "-" if r["target"] is None else f"{r['target_kind']} {r['target']:g}"
        table.add_row(
            r["figure"],
            r["unit"],
            fmt(r["median"]),
            fmt(r["min"]),
            fmt(r["max"]),
            str(r["repetitions"]),
            target,
            ok,
            fmt(r["ratio_to_baseline"]),
        )
    console.print(table)
    slow = sorted((r for r in rows if r.get("bench_total_s")), key=lambda r: -r["bench_total_s"])[:8]
    if slow:
        console.print(
            "slowest figures (setup + repetitions): "
            + "; ".join(
                f"{r['figure'][:60]} {r['bench_total_s']:.1f} s (setup {r['bench_setup_s']:.1f} s)" for r in slow
            )
        )
    cpu = _cpu_seconds() - cpu_start
    console.print(
        f"bench wall time {time.perf_counter() - t_start:.1f} s, CPU time {cpu:.1f} s "
        "(this process and its finished children: less sensitive to the machine's load than the wall time)"
    )
    out = {
        "mode": "quick" if args.quick else "full",
        "python": sys.version.split()[0],
        "machine": platform.platform(),
        "host": host,
        "load_average_end": [round(v, 2) for v in os.getloadavg()],
        "wall_time_s": time.perf_counter() - t_start,
        "cpu_time_s": _cpu_seconds() - cpu_start,
        "figures": rows,
    }
    Path(args.out).write_text(json.dumps(out, indent=2))
    console.print(f"wrote {args.out}")
    if failed:
        console.print(f"[red]{len(failed)} figure(s) failed[/]: " + "; ".join(failed))
        return 1
    return 0


class _SetupFailed:
    """A setup that raised: every figure sharing it reports the same error."""

    def __init__(self, exc: Exception) -> None:
        self.exc = exc


if __name__ == "__main__":
    raise SystemExit(main())
