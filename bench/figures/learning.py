"""Training on a campaign's pool of FE data: K = 5 on the preliminary data and 32 press motions replayed
with ``fe-headrest-2d``, from scratch and as a campaign's warm start (the default protocol: early stopping
after 6 epochs and 200 Adam steps without improvement, the preliminary samples in contact at weight 0).
"""

from __future__ import annotations

import itertools
from typing import Any

from bench.harness import figure, timed


def _fe_press_pool() -> tuple[list[Any], Any]:
    """The preliminary data and 32 press motions of the validation suite's family (seed 101: no suite's)
    replayed with ``fe-headrest-2d``: a campaign's pool after 32 oracle calls."""
    from alcove.science.geometry import DEFAULT_PRESET as P
    from alcove.science.oracles.registry import build_oracle
    from alcove.science.surrogate.compare import replay_suite
    from alcove.science.surrogate.preliminary import preliminary_pool
    from alcove.science.validation_suite import SuiteSpec, suite_trajectories
    from bench.learning import oracle_forces

    run = oracle_forces(build_oracle("fe-headrest-2d"))
    presses = replay_suite(run, suite_trajectories(SuiteSpec(motions=32, seed=101), P), prefix="press")
    return preliminary_pool(P) + presses, itertools.count()


@figure(
    "surrogate training, K = 5 on 32 FE press motions plus the preliminary data",
    "s",
    target=15.0,
    setup=_fe_press_pool,
    reps=3,
    quick=False,
    group="surrogate",
    notes="a campaign's model after 32 oracle calls, trained from scratch with the default protocol (early "
    "stopping after 6 epochs and 200 Adam steps without improvement; the preliminary samples in contact weigh 0); "
    "seed = repetition",
)
def surrogate_training_fe_pool(ctx: Any) -> float:
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import train_surrogate

    pool, seeds = ctx
    return timed(lambda: train_surrogate(pool, SurrogateConfig(), seed=next(seeds)))


@figure(
    "surrogate training, K = 5 warm start on 32 FE press motions (model of 31 carried)",
    "s",
    target=15.0,
    setup=_fe_press_pool,
    reps=3,
    quick=False,
    group="surrogate",
    baseline="surrogate training, K = 5 on 32 FE press motions plus the preliminary data",
    notes="a campaign's iteration: the model trained on the pool of 31 motions carried into a full training on 32 "
    "(the warm_* settings at their defaults, the cold training's); the carried model is trained once, untimed",
)
def surrogate_training_fe_pool_warm(ctx: Any) -> float:
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import train_surrogate

    pool, seeds = ctx
    seed = next(seeds)
    carried = train_surrogate(pool[:-1], SurrogateConfig(), seed=seed).model
    return timed(lambda: train_surrogate(pool, SurrogateConfig(), seed=seed + 100, warm_start=carried))


# ----------------------------------------------------------------------------- the paper's loop, held out

#: held-out press motions outside every default campaign's suite (seed 0): 16 of the suite's kind, seed 1
HELD_OUT = {"motions": 16, "seed": 1}
_paper_loop: dict[str, Any] = {}


def paper_loop_held_out() -> dict[str, Any]:
    """``alcove campaign run --oracle fe-headrest-2d -n 9`` with the defaults (the paper's task), then
    its last model scored on :data:`HELD_OUT` replayed with the oracle: the motions are in no pool
    and in no suite the campaign was measured on."""
    if _paper_loop:
        return _paper_loop
    import subprocess
    import sys
    import tempfile
    import zipfile
    from pathlib import Path

    from alcove.science.geometry import DEFAULT_PRESET as P
    from alcove.science.oracles.registry import build_oracle
    from alcove.science.surrogate.artifact import load_artifact
    from alcove.science.surrogate.compare import replay_suite, score_on_suite
    from alcove.science.validation_suite import SuiteSpec, suite_trajectories
    from bench.figures.campaign import _env, run_campaign
    from bench.learning import oracle_forces

    run = run_campaign("fe-headrest-2d", 9)
    out = Path(tempfile.mkdtemp(prefix="alcove-bench-paper-loop-"))
    subprocess.run(
        [sys.executable, "-m", "alcove_worker.cli.main", "campaign", "export", str(run["campaign_id"]), "-o", str(out)],
        env=_env(Path(run["data_dir"]) / "data"),
        check=True,
        capture_output=True,
        timeout=600,
    )
    last = sorted(out.rglob("models/model-*.zip"))[-1]
    unpacked = out / "last-model"
    with zipfile.ZipFile(last) as zf:
        zf.extractall(unpacked)
    model = load_artifact(next(unpacked.rglob("surrogate.json")))
    held = replay_suite(
        oracle_forces(build_oracle("fe-headrest-2d")), suite_trajectories(SuiteSpec(**HELD_OUT), P), prefix="held"
    )
    score = score_on_suite(model, held, P)
    calls = sum(1 for st in run["steps"] if st["step"] == "oracle")
    last_metrics = run.get("last") or {}
    print(
        f"  campaign {run['campaign_id']}: {calls} oracle calls, last model {last.name}; held-out "
        f"({HELD_OUT['motions']} motions, seed {HELD_OUT['seed']}): force {score['force_rmse']:.2f} N, "
        f"fx {score['fx_rmse']:.2f} N, fz {score['fz_rmse']:.2f} N, my {score['my_rmse']:.3f} N m; "
        f"its own suite (seed 0): fx {last_metrics.get('validation_fx_rmse')}, "
        f"force {last_metrics.get('validation_force_rmse')}"
    )
    _paper_loop.update(score=score, calls=calls, run=run)
    return _paper_loop


@figure(
    "paper loop, campaign run --oracle fe-headrest-2d -n 9: last model's fx on 16 held-out press motions",
    "N",
    target=4.0,
    reps=1,
    quick_reps=1,
    quick=False,
    group="surrogate",
    notes="the motions (the suite's kind, seed 1) are in no pool and not in the campaign's suite (seed 0)",
)
def paper_loop_held_out_fx(_: Any) -> float:
    return float(paper_loop_held_out()["score"]["fx_rmse"])


@figure(
    "paper loop, campaign run --oracle fe-headrest-2d -n 9: last model's force on 16 held-out press motions",
    "N",
    reps=1,
    quick_reps=1,
    quick=False,
    group="surrogate",
    notes="the same model and motions: the vector RMSE (fz is the friction, which depends on the motion's history)",
)
def paper_loop_held_out_force(_: Any) -> float:
    return float(paper_loop_held_out()["score"]["force_rmse"])
