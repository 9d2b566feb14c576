"""Surrogate figures: training one model pair, prediction, building the CasADi export.

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


def _trained_model() -> Any:
    from alcove.science.geometry import DEFAULT_PRESET
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.preliminary import preliminary_pool
    from alcove.science.surrogate.training import train_surrogate

    return train_surrogate(preliminary_pool(DEFAULT_PRESET, samples=2000), SurrogateConfig(max_epochs=50), seed=0).model


def _seeded_pool() -> tuple[list[Any], Any]:
    return _training_pool(), itertools.count()


@figure(
    "surrogate training, one model pair on 80,000 samples (paper protocol)",
    "s",
    target=3.0,
    setup=_seeded_pool,
    reps=5,
    quick_reps=2,
    group="surrogate",
    notes="float64, batch 1024, early stopping (patience 6) on both nets; "
    "seed = repetition (the epoch count, 70-120, varies with it)",
)
def surrogate_training(ctx: Any) -> float:
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import train_surrogate

    pool, seeds = ctx
    return timed(lambda: train_surrogate(pool, SurrogateConfig(), seed=next(seeds)))


@figure(
    "surrogate training, 80,000 samples: CPU time of the training process",
    "s",
    target=3.0,
    setup=_seeded_pool,
    reps=3,
    quick=False,
    group="surrogate",
    notes="training is single-threaded, so on an idle machine wall time ~ CPU time; less sensitive to load",
)
def surrogate_training_cpu(ctx: Any) -> float:
    import time

    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import train_surrogate

    pool, seeds = ctx
    start = time.process_time()
    train_surrogate(pool, SurrogateConfig(), seed=next(seeds))
    return time.process_time() - start


def _step_setup() -> Any:
    import torch

    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.fused import FusedNets
    from alcove.science.surrogate.kernel import KernelNets
    from alcove.science.surrogate.mlp import MLP
    from alcove.science.surrogate.training import FlatAdam

    cfg = SurrogateConfig()
    generator = torch.Generator().manual_seed(0)
    nets = [MLP.from_config(cfg.force), MLP.from_config(cfg.moment)]
    for net in nets:
        net.reset_parameters(generator)
    fused = FusedNets(nets)
    optimizer = FlatAdam(fused.parameter, lr=cfg.learning_rate, grad=fused.grad)
    kernel = KernelNets(nets, y_cols=[19, 22])
    table = torch.randn(44 * cfg.batch_size, 26, dtype=torch.float64, generator=generator)  # one epoch
    table[:, 25] = 1.0 + 0.1 * table[:, 25].abs()
    order = torch.randperm(table.shape[0], generator=generator)
    return fused, optimizer, kernel, table, order


_STEP_NOTES = (
    "gradient of both nets + Adam, batch 1024, one thread; one epoch of 44 shuffled steps per repetition; "
    "a training on 80,000 samples takes 70-120 epochs"
)


@figure(
    "surrogate training step: both nets, batch 1024, C kernel (CPU time per step)",
    "ms",
    target=None,
    setup=_step_setup,
    reps=5,
    quick_reps=3,
    group="surrogate",
    notes=_STEP_NOTES + "; the implementation training uses (alcove.science.surrogate.kernel)",
)
def surrogate_training_step(ctx: Any) -> float:
    import time

    _, _, kernel, table, order = ctx
    t, o = table.numpy(), order.numpy()
    start = time.process_time()
    kernel.train_epoch(t, 25, o, 1024, 0.01)
    return 1e3 * (time.process_time() - start) / 44


@figure(
    "surrogate training step: both nets, batch 1024, PyTorch fallback (CPU time per step)",
    "ms",
    target=None,
    setup=_step_setup,
    reps=5,
    quick_reps=3,
    group="surrogate",
    notes=_STEP_NOTES + "; FusedNets + FlatAdam, used where no C compiler is available (ALCOVE_TRAINING_KERNEL=torch)",
)
def surrogate_training_step_torch(ctx: Any) -> float:
    import time

    import torch

    fused, optimizer, _, table, order = ctx
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        start = time.process_time()
        shuffled = table.index_select(0, order)
        for i in range(44):
            b = shuffled[i * 1024 : (i + 1) * 1024]
            fused.set_loss_gradient(b[:, :19], [b[:, 19:22], b[:, 22:25]], b[:, 25])
            optimizer.step()
        return 1e3 * (time.process_time() - start) / 44
    finally:
        torch.set_num_threads(threads)


@figure(
    "surrogate training kernel: compile (first training on a machine)",
    "s",
    target=None,
    reps=3,
    quick_reps=1,
    group="surrogate",
    notes="gcc -O3 -march=native into an empty cache; later processes load the cached library in milliseconds",
)
def surrogate_kernel_build(_: Any) -> float:
    import tempfile
    import time
    from pathlib import Path

    from alcove.science.surrogate.kernel import _build, _compiler

    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        _build(_compiler(), Path(tmp))
        return time.perf_counter() - start


@figure(
    "surrogate training, 80,000 samples, PyTorch fallback",
    "s",
    target=None,
    setup=_seeded_pool,
    reps=3,
    quick=False,
    group="surrogate",
    baseline="surrogate training, one model pair on 80,000 samples (paper protocol)",
    notes="ALCOVE_TRAINING_KERNEL=torch: what training costs where no C compiler is available",
)
def surrogate_training_torch(ctx: Any) -> float:
    import os

    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import train_surrogate

    pool, seeds = ctx
    previous = os.environ.get("ALCOVE_TRAINING_KERNEL")
    os.environ["ALCOVE_TRAINING_KERNEL"] = "torch"
    try:
        return timed(lambda: train_surrogate(pool, SurrogateConfig(), seed=next(seeds)))
    finally:
        if previous is None:
            os.environ.pop("ALCOVE_TRAINING_KERNEL")
        else:
            os.environ["ALCOVE_TRAINING_KERNEL"] = previous


def _warm_setup() -> tuple[list[Any], Any]:
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import train_surrogate

    pool = _training_pool()
    previous = train_surrogate(pool[:-1], SurrogateConfig(), seed=0).model  # the model before the last append
    return pool, previous


@figure(
    "surrogate training, 80,000 samples, warm start from the previous iteration's model",
    "s",
    target=3.0,
    setup=_warm_setup,
    reps=5,
    quick=False,
    group="surrogate",
    baseline="surrogate training, one model pair on 80,000 samples (paper protocol)",
    notes="the campaign's case: one trajectory appended, weights carried over",
)
def surrogate_training_warm(ctx: Any) -> float:
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import train_surrogate

    pool, previous = ctx
    return timed(lambda: train_surrogate(pool, SurrogateConfig(), seed=1, warm_start=previous))


def _predict_setup() -> tuple[Any, np.ndarray, np.ndarray, np.ndarray]:
    from alcove.science.geometry import DEFAULT_PRESET as P

    t = np.linspace(0.0, 1.0, 401)
    return _trained_model(), t, P.theta0 + 0.15 * np.sin(np.pi * t), 0.15 * np.pi * np.cos(np.pi * t)


@figure(
    "surrogate predict, 401 samples (features + both nets)",
    "ms",
    target=5.0,
    setup=_predict_setup,
    reps=31,
    quick_reps=11,
    group="surrogate",
)
def surrogate_predict(ctx: Any) -> float:
    from alcove.science.surrogate.training import predict

    model, t, q, qd = ctx
    return 1e3 * timed(lambda: predict(model, t, q, qd))


@figure(
    "surrogate CasADi export: build the (q, qd) -> wrench function",
    "s",
    target=0.2,
    setup=_trained_model,
    reps=11,
    quick_reps=5,
    group="surrogate",
)
def surrogate_casadi_build(model: Any) -> float:
    from alcove.science.geometry import DEFAULT_PRESET
    from alcove.science.surrogate.export import casadi_contact_function

    return timed(lambda: casadi_contact_function(model, DEFAULT_PRESET))
