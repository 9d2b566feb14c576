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
