"""Surrogate figures: training (K = 1, a K = 5 ensemble, and K = 5 gated), prediction, building the CasADi export.

The training pool has the size the paper's loop reaches after 200 iterations: the default
preliminary Latin hypercube (4,000 samples) and 190 simulated trajectories of 400 samples,
head motions toward the headrest and back replayed with the aux-penalty model. The
OCP-with-surrogate figures live in ``bench/figures/ocp.py``.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np

from bench.harness import figure, timed


def _training_pool() -> list[Any]:
    from alcove.science.geometry import DEFAULT_PRESET as P
    from alcove.science.geometry import relative_kinematics
    from alcove.science.oracles.aux_penalty import AuxPenaltyParams, aux_penalty_wrench
    from alcove.science.surrogate.dataset import PoolDataset
    from alcove.science.surrogate.preliminary import preliminary_pool

    rng = np.random.default_rng(0)
    pool = preliminary_pool(P)
    t = np.linspace(0.0, 1.0, 400)
    for i in range(190):
        # rest -> into the cushion (to a random depth, at a random time) -> back, smooth
        depth, t_peak, width = rng.uniform(0.32, 0.42), rng.uniform(0.3, 0.7), rng.uniform(0.1, 0.25)
        bump = np.exp(-0.5 * ((t - t_peak) / width) ** 2)
        q = P.theta0 + (depth - P.theta0) * bump
        qd = -(depth - P.theta0) * bump * (t - t_peak) / width**2
        force, moment = aux_penalty_wrench(P, AuxPenaltyParams(), relative_kinematics(P, q, qd))
        pool.append(PoolDataset(f"sim-{i:03d}", t, q, qd, force, moment))
    assert sum(ds.n_samples for ds in pool) == 80_000
    return pool


def _trained_model(k: int = 5) -> Any:
    from alcove.science.geometry import DEFAULT_PRESET
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.preliminary import preliminary_pool
    from alcove.science.surrogate.training import train_surrogate

    config = SurrogateConfig(max_epochs=50, ensemble_size=k)
    return train_surrogate(preliminary_pool(DEFAULT_PRESET, samples=2000), config, seed=0).model


def _seeded_pool() -> tuple[list[Any], Any]:
    return _training_pool(), itertools.count()


@figure(
    "surrogate training, K = 1 on 80,000 samples (paper protocol)",
    "s",
    target=6.0,
    setup=_seeded_pool,
    reps=5,
    quick_reps=2,
    group="surrogate",
    notes="one force/moment pair, float32 training (the default; the model is held in float64), batch 1024, early "
    "stopping (patience 6) on both nets, plain PyTorch, the two nets on two threads; seed = repetition (the "
    "epoch count, 70-120, varies with it)",
)
def surrogate_training(ctx: Any) -> float:
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import train_surrogate

    pool, seeds = ctx
    return timed(lambda: train_surrogate(pool, SurrogateConfig(ensemble_size=1), seed=next(seeds)))


@figure(
    "surrogate training, K = 5 ensemble on 80,000 samples",
    "s",
    target=12.0,
    setup=_seeded_pool,
    reps=3,
    quick_reps=1,
    group="surrogate",
    baseline="surrogate training, K = 1 on 80,000 samples (paper protocol)",
    notes="five members (own seeds and splits), both nets, trained together vectorised over the members, "
    "float32 training (the default), the force and moment nets on two threads",
)
def surrogate_training_ensemble(ctx: Any) -> float:
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import train_surrogate

    pool, seeds = ctx
    return timed(lambda: train_surrogate(pool, SurrogateConfig(ensemble_size=5), seed=next(seeds)))


@figure(
    "surrogate training, K = 5 ensemble on 80,000 samples, float64 training",
    "s",
    setup=_seeded_pool,
    reps=3,
    quick=False,
    group="surrogate",
    baseline="surrogate training, K = 5 ensemble on 80,000 samples",
    notes="as the K = 5 figure with dtype float64 (float32 is the default): the price of the precision",
)
def surrogate_training_ensemble_float64(ctx: Any) -> float:
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import train_surrogate

    pool, seeds = ctx
    return timed(lambda: train_surrogate(pool, SurrogateConfig(ensemble_size=5, dtype="float64"), seed=next(seeds)))


@figure(
    "surrogate training, K = 5 ensemble on 80,000 samples, gated architecture",
    "s",
    setup=_seeded_pool,
    reps=3,
    quick_reps=1,
    group="surrogate",
    baseline="surrogate training, K = 5 ensemble on 80,000 samples",
    notes="architecture 'gated' (contact-aware output layer: the gate of each sample is a data column, "
    "the softplus of fx and the de-standardisation are in the loss); otherwise as the K = 5 figure",
)
def surrogate_training_ensemble_gated(ctx: Any) -> float:
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import train_surrogate

    pool, seeds = ctx
    config = SurrogateConfig(ensemble_size=5, architecture="gated")
    return timed(lambda: train_surrogate(pool, config, seed=next(seeds)))


@figure(
    "surrogate training, K = 1, 80,000 samples: CPU time of the training process",
    "s",
    target=None,
    setup=_seeded_pool,
    reps=3,
    quick=False,
    group="surrogate",
    notes="the work of the training: both threads (force and moment nets) together, so above the wall time; "
    "no target (the targets are wall times)",
)
def surrogate_training_cpu(ctx: Any) -> float:
    import time

    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import train_surrogate

    pool, seeds = ctx
    start = time.process_time()
    train_surrogate(pool, SurrogateConfig(ensemble_size=1), seed=next(seeds))
    return time.process_time() - start


@figure(
    "surrogate training CPU, K = 5 ensemble on 80,000 samples",
    "cpu s",
    target=None,
    setup=_seeded_pool,
    reps=3,
    quick=False,
    group="surrogate",
    notes="process CPU time of the K = 5 training (both threads' work); no target (the targets are wall times)",
)
def surrogate_training_ensemble_cpu(ctx: Any) -> float:
    import time

    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import train_surrogate

    pool, seeds = ctx
    start = time.process_time()
    train_surrogate(pool, SurrogateConfig(ensemble_size=5), seed=next(seeds))
    return time.process_time() - start


def _step_setup(k: int) -> Any:
    """An :class:`EnsembleTrainer` of K members on random standardised data of 44 batches of 1024
    rows per member (the training part of the 80,000-sample pool), the paper's nets."""
    import torch

    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.ensemble import NETS, EnsembleTrainer, MemberTensors
    from alcove.science.surrogate.mlp import MLP

    cfg = SurrogateConfig(ensemble_size=k)
    dtype = getattr(torch, cfg.dtype)  # the default training precision
    generator = torch.Generator().manual_seed(0)
    n_train, n_val = 44 * cfg.batch_size, 11_000

    def rows(n: int, width: int) -> torch.Tensor:
        return torch.randn(n, width, dtype=dtype, generator=generator)

    nets: dict[str, list[MLP]] = {n: [] for n in NETS}
    data, generators = [], []
    for _ in range(k):
        for n in NETS:
            net = MLP.from_config(getattr(cfg, n), dtype=dtype)
            net.reset_parameters(generator)
            nets[n].append(net)
        z_train, z_val = rows(n_train, 19), rows(n_val, 19)
        z_train[:, 11:] = 0.0  # the 8 features that are exactly zero in planar motion (left out of training)
        z_val[:, 11:] = 0.0
        data.append(
            MemberTensors(
                z_train=z_train,
                y_train={n: rows(n_train, 3) for n in NETS},
                w_train=torch.ones(n_train, dtype=dtype),
                z_val=z_val,
                y_val={n: rows(n_val, 3) for n in NETS},
                w_val=torch.ones(n_val, dtype=dtype),
            )
        )
        generators.append(torch.Generator().manual_seed(len(generators)))
    return EnsembleTrainer(nets, data, cfg, generators)


def _step_cpu_ms(trainer: Any) -> float:
    """CPU time of one epoch of the trainer (its shuffle, 44 steps) per step, and of the validation after it."""
    import time

    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # as train_surrogate
    try:
        start = time.process_time()
        trainer.epoch()
        return 1e3 * (time.process_time() - start) / trainer.S
    finally:
        torch.set_num_threads(threads)


_STEP_NOTES = (
    "the training's own step (EnsembleTrainer.epoch: per batch and net one loss, one backward pass, one fused "
    "torch.optim.Adam step; the epoch's shuffle included), float32 (the default), batch 1024, one intra-op thread, "
    "the two nets on two threads (the CPU time is both threads' work); one epoch of 44 steps (the 80,000-sample "
    "pool's training part) per repetition, CPU time per step; a training takes 70-120 epochs"
)


@figure(
    "surrogate training step: both nets, K = 1, batch 1024 (CPU time per step)",
    "ms",
    target=None,
    setup=lambda: _step_setup(1),
    reps=5,
    quick_reps=3,
    group="surrogate",
    notes=_STEP_NOTES,
)
def surrogate_training_step(ctx: Any) -> float:
    return _step_cpu_ms(ctx)


@figure(
    "surrogate training step: both nets, K = 5 members vectorised, batch 1024 (CPU time per step)",
    "ms",
    target=None,
    setup=lambda: _step_setup(5),
    reps=5,
    quick_reps=3,
    group="surrogate",
    notes=_STEP_NOTES,
)
def surrogate_training_step_ensemble(ctx: Any) -> float:
    return _step_cpu_ms(ctx)


def _warm_setup() -> tuple[list[Any], Any]:
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import train_surrogate

    pool = _training_pool()
    previous = train_surrogate(pool[:-1], SurrogateConfig(ensemble_size=5), seed=0).model  # before the last append
    return pool, previous


@figure(
    "surrogate training, K = 5, 80,000 samples, warm start from the previous iteration's model",
    "s",
    target=2.0,
    setup=_warm_setup,
    reps=5,
    quick=False,
    group="surrogate",
    baseline="surrogate training, K = 5 ensemble on 80,000 samples",
    notes="the campaign's case: one trajectory appended, every member's weights carried over",
)
def surrogate_training_warm(ctx: Any) -> float:
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import train_surrogate

    pool, previous = ctx
    return timed(lambda: train_surrogate(pool, SurrogateConfig(ensemble_size=5), seed=1, warm_start=previous))


@figure(
    "surrogate training CPU, K = 5, 80,000 samples, warm start from the previous iteration's model",
    "cpu s",
    target=None,
    setup=_warm_setup,
    reps=3,
    quick=False,
    group="surrogate",
    notes="process CPU time of the warm-started training (both threads' work); no target",
)
def surrogate_training_warm_cpu(ctx: Any) -> float:
    import time

    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import train_surrogate

    pool, previous = ctx
    start = time.process_time()
    train_surrogate(pool, SurrogateConfig(ensemble_size=5), seed=1, warm_start=previous)
    return time.process_time() - start


def _predict_setup() -> tuple[Any, np.ndarray, np.ndarray, np.ndarray]:
    from alcove.science.geometry import DEFAULT_PRESET as P

    t = np.linspace(0.0, 1.0, 401)
    return _trained_model(), t, P.theta0 + 0.15 * np.sin(np.pi * t), 0.15 * np.pi * np.cos(np.pi * t)


@figure(
    "surrogate predict, 401 samples, K = 5 (features + both nets, mean and std)",
    "ms",
    target=5.0,
    setup=_predict_setup,
    reps=31,
    quick_reps=11,
    group="surrogate",
)
def surrogate_predict(ctx: Any) -> float:
    from alcove.science.surrogate.training import predict_ensemble

    model, _, q, qd = ctx
    return 1e3 * timed(lambda: predict_ensemble(model, q, qd))


@figure(
    "surrogate CasADi export: build the (q, qd) -> wrench function, K = 5 mean",
    "s",
    target=0.2,
    setup=_trained_model,
    reps=11,
    quick_reps=5,
    group="surrogate",
)
def surrogate_casadi_build(model: Any) -> float:
    from alcove.science.geometry import DEFAULT_PRESET
    from alcove.science.surrogate.casadi_contact import casadi_contact_function

    return timed(lambda: casadi_contact_function(model, DEFAULT_PRESET))
