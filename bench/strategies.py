"""Acquisition strategies at equal oracle budgets, against the best possible at each budget.

``python -m bench.strategies`` runs one campaign per (strategy, seed) on ``fe-headrest-2d`` with
the task preset ``head-headrest-scenarios`` until it has made ``max(budgets)`` oracle calls, and
scores the model version trained on the pool after B oracle calls, for each budget B, on the
held-out validation suite (RMSE of the force and moment vectors and of fx, fz, my, and the
calibration, over the suite's 8 motions with unloads and re-loads, derived from the task). Every
campaign uses the same preliminary data (LHS seed 0), the same surrogate configuration and the
same validation suite (seed 0); the campaign seed drives the scenario draws, the training seeds
and the OCP.

Oracle calls are counted as the campaign counts them (``Iteration.oracle_calls``: every oracle
attempt, also those of failed iterations). The model for budget B is model version j + 1,
trained on pool version j, where j is the last iteration whose cumulative oracle calls are at
most B. A campaign stops once it has made ``max(budgets)`` calls: its last iteration's train
step (the model on the final pool) runs, the rest of that iteration does not.

Every campaign runs in this process's child (``--one``), its steps in that process
(``protocol.drive_inline``'s loop: the real step protocol and rows on an embedded SQLite store
in ``--work-dir``, no broker); ``--jobs`` children run at once. Each child writes its result
file after every budget it scores, so a cut-off run keeps its completed rows; ``--salvage``
rebuilds the results JSON, table and plot from those files, ``--report-only`` the table and plot
from the results JSON.

The pseudo-strategy ``best-possible`` runs no campaign: per seed, models trained from scratch on the
first B replays of the press family's space-filling sequence over the suite's box
(:mod:`bench.strategies_reference`; seed 0 is the line a campaign on this suite shows).

Usage: ``python -m bench.strategies [--seeds 0 1 2 3 4] [--budgets 4 8 16 32 64] [--candidates 16]
[--jobs 2]``, then ``--salvage`` after a cut-off run, ``--report-only``, ``--retrain S SEED B``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from bench.strategies_report import collect, merge, report, write_atomic
from bench.strategies_store import (
    TASK,
    cpu_seconds,
    cumulative_calls,
    fresh_store,
    iterations,
    retrain,
    run_suite,
    score,
)

ROOT = Path(__file__).resolve().parent.parent
RESULTS, PLOT = (
    ROOT / "docs" / "active-learning" / "strategies.json",
    ROOT / "docs" / "active-learning" / "strategies.png",
)
WORK_DIR = Path("/tmp/alcove-bench-strategies")

ORACLE = "fe-headrest-2d"
#: the campaigns' strategies, and the best-possible line (bench.strategies_reference: no campaign)
STRATEGIES = ("best-possible", "paper", "random-scenarios", "ensemble-disagreement", "press-family")
BUDGETS = (4, 8, 16, 32, 64)
SEEDS = (0, 1, 2, 3, 4)
BATCH = 4
CANDIDATES = 16
PRELIMINARY_SEED = 0
VALIDATION_SEED = 0


# ----------------------------------------------------------------------------- pure logic


def budget_models(cumulative: list[int], budgets: list[int]) -> dict[int, int | None]:
    """For each budget B the pool version j whose model (version j + 1) is scored: the last
    iteration j (0 = preliminary) whose cumulative oracle calls ``cumulative[j]`` are at most B,
    once the campaign has reached B (``cumulative[-1] >= B``); None while it has not."""
    out: dict[int, int | None] = {}
    for b in budgets:
        if not cumulative or cumulative[-1] < b:
            out[b] = None
            continue
        out[b] = max(j for j, c in enumerate(cumulative) if c <= b)
    return out


# ----------------------------------------------------------------------------- one campaign (child)


def _settings(strategy: str, batch: int, candidates: int) -> dict[str, Any]:
    # the suite of every run; its best-possible line is the ``best-possible`` runs' (no reference motions here)
    s: dict[str, Any] = {
        "strategy": strategy,
        "validation_motions": 8,
        "validation_seed": VALIDATION_SEED,
        "validation_reference_motions": 0,
    }
    if strategy != "paper":
        s["batch"] = batch
    if strategy == "ensemble-disagreement":
        s["candidates"] = candidates
    return s


def run_one(
    strategy: str,
    seed: int,
    budgets: list[int],
    out: Path,
    data_dir: Path,
    *,
    batch: int,
    candidates: int,
    surrogate: dict[str, Any],
    preliminary: dict[str, Any] | None = None,
    exploration_weight: float = 0.0,
) -> dict[str, Any]:
    """One campaign until max(budgets) oracle calls; writes ``out`` after every scored budget."""
    t0, cpu0 = time.perf_counter(), cpu_seconds()
    fresh_store(data_dir)
    from alcove.campaigns import presets, service
    from alcove.campaigns.run.protocol import run_step
    from alcove.campaigns.schemas import CampaignCreate
    from alcove.db import open_transaction, run_transaction

    settings = _settings(strategy, batch, candidates)

    def create(s: Any) -> int:
        from alcove.science.ocp.task_spec import task_preset

        user = presets.local_user(s)
        spec = None
        if exploration_weight:
            spec = task_preset(TASK).model_dump(mode="json") | {"exploration_weight": exploration_weight}
        data = CampaignCreate(
            name=f"bench {strategy} seed {seed}",
            description="python -m bench.strategies",
            seed=seed,
            task_version_id=presets.task_version_from_preset(s, user.id, TASK, spec),
            oracle_version_id=presets.oracle_version_for(s, user.id, ORACLE, {}),
            surrogate_config_version_id=presets.surrogate_config_version_for(s, user.id, surrogate),
            preliminary={**(preliminary or {}), "seed": PRELIMINARY_SEED},
            # a guard, not a budget: ensemble-disagreement picks at most q per iteration and none
            # when no candidate touches the headrest, so iterations can run without oracle calls
            stopping={"max_iterations": 4 * max(budgets)},
            settings=settings,
        )
        return service.create_campaign(s, user.id, data).id

    cid = run_transaction(create)
    _, jobs = run_transaction(lambda s: service.start(s, cid))
    result: dict[str, Any] = {
        "strategy": strategy,
        "seed": seed,
        "settings": settings,
        "surrogate": surrogate,
        "preliminary": preliminary or {},
        "exploration_weight": exploration_weight,
        "budgets": {},
        "complete": False,
    }
    top = max(budgets)
    queue, suite_id, steps = list(jobs), None, 0
    while queue:
        j = queue.pop(0)
        last = False
        if j.step.value == "train" and j.iteration > 1:
            with open_transaction() as s:
                last = cumulative_calls(s, cid, j.iteration - 1)[-1] >= top
        run_step(
            j.campaign_id, j.iteration, j.step.value, j.attempt, worker_name="bench", send=queue.extend, slot=j.slot
        )
        steps += 1
        if j.step.value != "train":
            continue
        if suite_id is None:
            suite_id = run_suite(cid)
        with open_transaction() as s:
            cum = cumulative_calls(s, cid, j.iteration - 1)
        for b, pv in budget_models(cum, budgets).items():
            if pv is None or str(b) in result["budgets"] or suite_id is None:
                continue
            result["budgets"][str(b)] = {"oracle_calls": cum[pv], "pool_version": pv, "model_version": pv + 1}
            result["budgets"][str(b)].update(score(cid, suite_id, pv + 1))
        if j.iteration == 1 and suite_id is not None:
            result["budgets"]["0"] = {
                "oracle_calls": 0,
                "pool_version": 0,
                "model_version": 1,
                **score(cid, suite_id, 1),
            }
        result.update(
            wall_s=time.perf_counter() - t0, cpu_s=cpu_seconds() - cpu0, iterations_run=j.iteration, steps=steps
        )
        print(
            f"[{strategy} seed {seed}] iteration {j.iteration} trained, {cum[-1]} oracle calls, "
            f"{result['wall_s'] / 60:.1f} min (CPU {result['cpu_s'] / 60:.1f} min); "
            + ", ".join(
                f"B={b}: {v['force_rmse']:.2f} N" for b, v in sorted(result["budgets"].items(), key=lambda x: int(x[0]))
            ),
            flush=True,
        )
        result["iterations"] = iterations(cid)
        write_atomic(out, result)
        if last:
            break
    result["complete"] = all(str(b) in result["budgets"] for b in budgets)
    result["iterations"] = iterations(cid)
    result.update(wall_s=time.perf_counter() - t0, cpu_s=cpu_seconds() - cpu0)
    write_atomic(out, result)
    return result


# ----------------------------------------------------------------------------- main


def _collected(args: argparse.Namespace, meta: dict[str, Any]) -> dict[str, Any]:
    """The run files in ``--work-dir``, with ``--merge``'s earlier runs if given."""
    results = collect(args.work_dir, meta)
    return merge(results, json.loads(args.merge.read_text())) if args.merge else results


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--strategies", nargs="+", default=list(STRATEGIES), choices=STRATEGIES)
    ap.add_argument("--seeds", nargs="+", type=int, default=list(SEEDS))
    ap.add_argument("--budgets", nargs="+", type=int, default=list(BUDGETS))
    ap.add_argument("--batch", type=int, default=BATCH, help="q of random-scenarios and ensemble-disagreement")
    ap.add_argument("--candidates", type=int, default=CANDIDATES, help="C of ensemble-disagreement")
    ap.add_argument("--surrogate", default="{}", help="surrogate config JSON (default: alcove's, an ensemble of 5)")
    ap.add_argument(
        "--preliminary",
        default="{}",
        help="the campaigns' preliminary settings JSON beside the seed, e.g. '{\"family_motions\": 4}'",
    )
    ap.add_argument(
        "--exploration-weight", type=float, default=0.0, help="the task's exploration_weight (0: the paper's cost)"
    )
    ap.add_argument("--jobs", type=int, default=1, help="campaigns run at once (child processes)")
    ap.add_argument("--work-dir", type=Path, default=WORK_DIR, help="stores and per-run result files")
    ap.add_argument("--out", type=Path, default=RESULTS)
    ap.add_argument("--plot", type=Path, default=PLOT)
    ap.add_argument("--report-only", action="store_true", help="table and plot from --out, nothing run")
    ap.add_argument("--salvage", action="store_true", help="--out, table and plot from the run files in --work-dir")
    ap.add_argument(
        "--retrain",
        nargs=3,
        metavar=("STRATEGY", "SEED", "BUDGET"),
        help="diagnostic: that run's pool after BUDGET calls trained from scratch, with --surrogate if given "
        "(appended to retrain.jsonl)",
    )
    ap.add_argument(
        "--merge",
        type=Path,
        help="an earlier results JSON: its runs of (strategy, seed) not run here join the report; those run "
        "here again are kept as '<strategy> (earlier)'",
    )
    ap.add_argument("--one", nargs=2, metavar=("STRATEGY", "SEED"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    budgets = sorted(set(args.budgets))
    if any(b < 1 for b in budgets):
        ap.error("--budgets: oracle call budgets must be at least 1")
    surrogate = json.loads(args.surrogate)
    preliminary = json.loads(args.preliminary)

    if args.one:
        strategy, seed = args.one[0], int(args.one[1])
        tag = f"{strategy}-{seed}"
        if strategy == "best-possible":
            from bench.strategies_reference import run_reference

            suite = {"validation_motions": 8, "validation_seed": VALIDATION_SEED}
            write_atomic(
                args.work_dir / f"run-{tag}.json", run_reference(seed, budgets, ORACLE, suite, args.work_dir, surrogate)
            )
            return 0
        run_one(
            strategy,
            seed,
            budgets,
            args.work_dir / f"run-{tag}.json",
            args.work_dir / f"store-{tag}",
            batch=args.batch,
            candidates=args.candidates,
            surrogate=surrogate,
            preliminary=preliminary,
            exploration_weight=args.exploration_weight,
        )
        return 0

    if args.retrain:
        st, sd, b = args.retrain[0], int(args.retrain[1]), int(args.retrain[2])
        override = surrogate if args.surrogate != "{}" else None  # --surrogate: train that config on the pool
        row = retrain(args.work_dir / f"run-{st}-{sd}.json", args.work_dir / f"store-{st}-{sd}", b, sd, override)
        print(json.dumps(row))
        if row is not None:
            with (args.work_dir / "retrain.jsonl").open("a") as f:
                f.write(json.dumps(row) + "\n")
        return 0

    if args.report_only:
        report(json.loads(args.out.read_text()), args.out, args.plot)
        return 0

    meta_path = args.work_dir / "meta.json"
    if args.salvage:
        meta = json.loads(meta_path.read_text())
        report(_collected(args, meta), args.out, args.plot)
        return 0

    args.work_dir.mkdir(parents=True, exist_ok=True)
    meta = {
        "oracle": ORACLE,
        "task": TASK,
        "strategies": args.strategies,
        "seeds": args.seeds,
        "budgets": budgets,
        "batch": args.batch,
        "candidates": args.candidates,
        "surrogate": surrogate,
        "preliminary": preliminary,
        "exploration_weight": args.exploration_weight,
        "preliminary_seed": PRELIMINARY_SEED,
        "validation_seed": VALIDATION_SEED,
        "jobs": args.jobs,
        "commit": subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=ROOT, check=False
        ).stdout.strip(),
        "machine": platform.platform(),
        "python": sys.version.split()[0],
        "started": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }
    write_atomic(meta_path, meta)
    # seed-major order: a cut-off run has whole seeds of every strategy
    todo = [(st, sd) for sd in args.seeds for st in args.strategies]
    running: list[tuple[subprocess.Popen[bytes], str]] = []
    env = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    t0 = time.perf_counter()
    while todo or running:
        while todo and len(running) < args.jobs:
            st, sd = todo.pop(0)
            log = open(args.work_dir / f"log-{st}-{sd}.txt", "ab")  # noqa: SIM115 (closed with the process)
            argv = [sys.executable, "-m", "bench.strategies", "--one", st, str(sd), "--work-dir", str(args.work_dir)]
            argv += ["--budgets", *map(str, budgets), "--batch", str(args.batch), "--candidates", str(args.candidates)]
            argv += ["--surrogate", args.surrogate, "--preliminary", args.preliminary]
            argv += ["--exploration-weight", str(args.exploration_weight)]
            running.append(
                (subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT, env=env, cwd=ROOT), f"{st}-{sd}")
            )
        time.sleep(5)
        for p, tag in list(running):
            if p.poll() is not None:
                running.remove((p, tag))
                print(f"{tag}: exit {p.returncode} after {(time.perf_counter() - t0) / 60:.1f} min", flush=True)
                meta["wall_s"] = time.perf_counter() - t0
                report(_collected(args, meta), args.out, args.plot)
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    meta["wall_s"], meta["children_cpu_s"] = time.perf_counter() - t0, r.ru_utime + r.ru_stime
    report(_collected(args, meta), args.out, args.plot)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
