"""The best-possible line of ``python -m bench.strategies`` (its pseudo-strategy ``best-possible``):
per seed s, the first max(budgets) motions of the campaign suite's box from the press family's
space-filling sequence for seed s, replayed with the oracle, and for each budget B the default
surrogate trained from scratch on the first B replays alone (FE data only), scored on the
campaigns' suite. Seed 0 is the line a campaign of this suite shows
(:mod:`alcove.surrogates.reference_line`, the same function); the other seeds give its spread
over the motions drawn and the training seed. Replays are cached in the work directory."""

from __future__ import annotations

import pickle
import time
from pathlib import Path
from typing import Any

from bench.strategies_store import TASK, cpu_seconds


def _replayed(oracle: Any, trajectory: Any, path: Path, part: str) -> dict[str, Any]:
    import numpy as np

    if not path.exists():
        result = oracle.run(trajectory)
        if not result.ok or result.forces is None:
            raise RuntimeError(f"the oracle failed on a motion: {result.failure_reason}")
        f = result.forces
        on_grid = trajectory if len(f.t) == len(trajectory.t) else trajectory.resample(f.t)
        arrays = {"t": f.t, "q": on_grid.q, "qd": on_grid.qd, "f": np.hstack([f.force, f.moment])}
        path.write_bytes(pickle.dumps(arrays))
    return {**pickle.loads(path.read_bytes()), "part": part}


def run_reference(
    seed: int,
    budgets: list[int],
    oracle_name: str,
    suite_settings: dict[str, Any],
    work: Path,
    surrogate: dict[str, Any] | None = None,
) -> dict:
    """The line for ``seed`` as a result row of ``bench.strategies`` (strategy ``best-possible``),
    with the surrogate configuration ``surrogate`` (default: alcove's)."""
    from alcove.campaigns.config import RunSettings
    from alcove.campaigns.suite import suite_model, suite_spec
    from alcove.science.ocp.task_spec import task_preset
    from alcove.science.oracles.registry import build_oracle
    from alcove.science.press_family import sequence_motion
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.validation_suite import motion_parameters
    from alcove.surrogates.reference_line import reference_line

    t0, cpu0 = time.perf_counter(), cpu_seconds()
    cache = work / "replays"
    cache.mkdir(parents=True, exist_ok=True)
    task = task_preset(TASK)
    model = suite_model(task)
    spec = suite_spec(RunSettings.model_validate({**suite_settings, "validation_reference_motions": 0}), task, model)
    oracle = build_oracle(oracle_name)
    scored = [
        _replayed(oracle, m.trajectory(spec.dt), cache / f"suite-{spec.seed}-{i:02d}.pkl", spec.part(i))
        for i, m in enumerate(motion_parameters(spec, model))
    ]
    theta = (model.theta_min, model.theta_max)
    reference = [
        _replayed(
            oracle,
            sequence_motion(spec.ranges, seed, i, theta).trajectory(spec.dt),
            cache / f"ref-{seed}-{i:03d}.pkl",
            "reference",
        )
        for i in range(max(budgets))
    ]
    config = SurrogateConfig.parse(surrogate or {})
    line = reference_line(reference, scored, sorted(budgets), None, model, seed=seed, config=config)
    rows = {}
    for p in line["points"]:
        c = p["components"]
        rows[str(p["budget"])] = {
            "oracle_calls": p["budget"],
            "force_rmse": p["force_rmse"],
            "moment_rmse": p["moment_rmse"],
            "calibration": p["calibration"],
            **{f"{k}_rmse": c.get(k) for k in ("fx", "fz", "my", "fx_contact", "fz_contact", "my_contact")},
            "train_s": p["train_s"],
        }
    return {
        "strategy": "best-possible",
        "seed": seed,
        "settings": {"motions": "press family sequence", "suite": spec.to_dict()},
        "surrogate": surrogate or {},
        "budgets": rows,
        "complete": True,
        "wall_s": time.perf_counter() - t0,
        "cpu_s": cpu_seconds() - cpu0,
        "iterations": [],
    }
