"""The best a surrogate can do with B oracle calls: the reference line the strategies are measured against.

``python -m bench.learning`` replays press motions of the family :mod:`alcove.science.press_family`
(a seeded Latin hypercube over its box: press, dwell, partial unload, re-load) with ``fe-headrest-2d``,
trains the default surrogate (K = 5) from scratch on the first B of them for each budget B and
seed, and scores every model on the campaign's held-out validation suite (8 press motions, seed 0:
the suite every default campaign on this oracle shares). Per component (fx, fz, my) and as the
force vector, median and range over the seeds, for:

* ``reference``: FE data only, trained from scratch (the best found per budget: no prior, no
  training path);
* ``with prior``: the same motions and the preliminary data (4000 auxiliary-law samples; the
  default keeps only its samples out of contact once oracle data are there);
* ``aux law``: the auxiliary penalty law's own error on the suite (what the preliminary data teach).

``cal`` is the models' calibration on the suite (share of oracle values inside the ensemble's
mean +- 2 std, :func:`alcove.science.surrogate.metrics.calibration`). ``--member-data split bootstrap``
trains each line once per value of the surrogate's ``member_data`` (the members' own splits, or
bootstrap resamples over the FE motions as well), labelled ``(bootstrap)``.

The replays are cached in ``--work-dir`` (by family seed and index), so a second run trains and
scores only. Usage: ``python -m bench.learning [--budgets 4 8 16 32 64] [--seeds 0 1 2]
[--family history|simple] [--member-data split bootstrap] [--json OUT]``; ``simple`` fixes release 1
and reload 0 (the suite's own kind of motion).
"""

from __future__ import annotations

import argparse
import json
import pickle
import statistics
import time
from pathlib import Path
from typing import Any

import numpy as np

WORK_DIR = Path("/tmp/alcove-bench-learning")
BUDGETS = (4, 8, 16, 32, 64)
SEEDS = (0, 1, 2)
COLUMNS = ("F", "fx", "fz", "my", "cal")


def _family(kind: str) -> Any:
    from alcove.science.press_family import PressFamily

    return PressFamily() if kind == "history" else PressFamily(release=(1.0, 1.0), reload=(0.0, 0.0))


def oracle_forces(oracle: Any) -> Any:
    """The oracle as ``trajectory -> forces`` for :func:`alcove.science.surrogate.compare.replay_suite`,
    raising on a failed replay."""

    def run(trajectory: Any) -> Any:
        result = oracle.run(trajectory)
        if not result.ok:
            raise RuntimeError(f"the oracle failed on a motion: {result.failure_reason}")
        return result.forces

    return run


def replays(kind: str, seed: int, n: int, work: Path) -> list[Any]:
    """The first ``n`` motions of the family (seed ``seed``) with the oracle's forces, cached per motion."""
    from alcove.science.geometry import DEFAULT_PRESET as P
    from alcove.science.oracles.registry import build_oracle
    from alcove.science.press_family import family_motions
    from alcove.science.surrogate.compare import replay_suite

    motions = family_motions(_family(kind), n, seed, (P.theta_min, P.theta_max))
    run = oracle_forces(build_oracle("fe-headrest-2d"))
    out = []
    for i, m in enumerate(motions):
        path = work / f"{kind}-{seed}-{n}-{i:03d}.pkl"
        if not path.exists():
            replayed = replay_suite(run, [m.trajectory(0.0025)], prefix=f"{kind}-{seed}-{i:03d}")
            path.write_bytes(pickle.dumps(replayed[0]))
        out.append(pickle.loads(path.read_bytes()))
    return out


def suite(work: Path) -> list[Any]:
    """The default campaign suite (8 motions, seed 0) replayed with the oracle (cached)."""
    from alcove.science.geometry import DEFAULT_PRESET as P
    from alcove.science.oracles.registry import build_oracle
    from alcove.science.surrogate.compare import replay_suite
    from alcove.science.validation_suite import SuiteSpec, suite_trajectories

    path = work / "suite-0-8.pkl"
    if not path.exists():
        run = oracle_forces(build_oracle("fe-headrest-2d"))
        path.write_bytes(pickle.dumps(replay_suite(run, suite_trajectories(SuiteSpec(), P))))
    return list(pickle.loads(path.read_bytes()))


def score(pred: np.ndarray, held: list[Any], std: np.ndarray | None = None) -> dict[str, float | None]:
    from alcove.science.surrogate.metrics import wrench_metrics

    true = np.concatenate([np.hstack([d.force, d.moment]) for d in held])
    m = wrench_metrics(pred, true, std)
    return {"F": m["force_rmse"], "fx": m["rmse_fx"], "fz": m["rmse_fz"], "my": m["rmse_my"], "cal": m["calibration"]}


def model_score(model: Any, held: list[Any]) -> dict[str, float | None]:
    from alcove.science.surrogate.training import predict_ensemble

    preds = [predict_ensemble(model, d.q, d.qd) for d in held]
    pred = np.concatenate([np.hstack([p.force, p.moment]) for p in preds])
    return score(pred, held, np.concatenate([np.hstack([p.force_std, p.moment_std]) for p in preds]))


def cell(v: Any) -> str:
    return "" if v is None else f"{v:.2f}"


def aux_law_score(held: list[Any]) -> dict[str, float | None]:
    from alcove.science.geometry import DEFAULT_PRESET as P
    from alcove.science.geometry import relative_kinematics
    from alcove.science.oracles.aux_penalty import AuxPenaltyParams, aux_penalty_wrench

    preds = [
        np.hstack(aux_penalty_wrench(P, AuxPenaltyParams(), relative_kinematics(P, d.q[:, 0], d.qd[:, 0])))
        for d in held
    ]
    return score(np.concatenate(preds), held)


def main(argv: list[str] | None = None) -> int:
    from alcove.science.geometry import DEFAULT_PRESET as P
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.preliminary import preliminary_pool
    from alcove.science.surrogate.training import train_surrogate

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--budgets", type=int, nargs="+", default=list(BUDGETS))
    ap.add_argument("--seeds", type=int, nargs="+", default=list(SEEDS))
    ap.add_argument("--family", choices=("history", "simple"), default="history")
    ap.add_argument("--member-data", choices=("split", "bootstrap"), nargs="+", default=["split"])
    ap.add_argument("--work-dir", type=Path, default=WORK_DIR)
    ap.add_argument("--json", type=Path, default=None, help="write the rows here")
    args = ap.parse_args(argv)
    args.work_dir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    held = suite(args.work_dir)
    prior = preliminary_pool(P)
    rows: list[dict[str, Any]] = [{"line": "aux law", "budget": None, "seed": None, **aux_law_score(held)}]
    for seed in args.seeds:
        data = replays(args.family, 1000 + seed, max(args.budgets), args.work_dir)
        for b in sorted(args.budgets):
            for md in args.member_data:
                config = SurrogateConfig(member_data=md)
                for line, pool in (("reference", data[:b]), ("with prior", prior + data[:b])):
                    t1 = time.perf_counter()
                    model = train_surrogate(pool, config, seed=seed).model
                    label = line if md == "split" else f"{line} ({md})"
                    row = {"line": label, "budget": b, "seed": seed, **model_score(model, held)}
                    row["train_s"] = time.perf_counter() - t1
                    rows.append(row)
                    print(
                        f"{label:22s} B={b:3d} seed {seed}: "
                        + " ".join(f"{c} {cell(row[c])}" for c in COLUMNS)
                        + f" ({row['train_s']:.1f} s)",
                        flush=True,
                    )
    print(f"\nfamily {args.family}, suite: 8 motions (seed 0), {time.perf_counter() - t0:.0f} s in all")
    print("| line | budget | " + " | ".join(f"{c} median (range)" for c in COLUMNS) + " |")
    print("| --- | --- | " + " | ".join("---" for _ in COLUMNS) + " |")
    groups: dict[tuple[str, Any], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["line"], r["budget"]), []).append(r)
    for (line, b), rs in groups.items():
        cells = []
        for c in COLUMNS:
            v = [r[c] for r in rs if r[c] is not None]
            one = cell(v[0] if v else None)
            cells.append(f"{statistics.median(v):.2f} ({min(v):.2f}-{max(v):.2f})" if len(v) > 1 else one)
        print(f"| {line} | {'' if b is None else b} | " + " | ".join(cells) + " |")
    if args.json is not None:
        args.json.write_text(json.dumps({"family": args.family, "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
