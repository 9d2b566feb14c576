"""Training protocol of the surrogate (the paper's, as the default) and prediction.

1. Split the pool by simulation: ``test_fraction`` (30 %) of the datasets, whole, to the
   test set; the rest is split pointwise ``validation_fraction`` (20 %) into validation.
2. Features (:mod:`.features`) standardised with the mean and standard deviation of the
   train points; targets standardised the same way (``normalize_outputs``).
3. Force and moment MLPs trained individually (Adam, lr 0.01, batch 1024, weighted MSE),
   each with early stopping on its validation loss (patience 6), keeping its best weights.
   Both nets step through the same shuffled batches in one loop (their parameters are
   disjoint, so this equals training them one after the other); a net that has stopped is
   frozen. The epoch runs in the compiled kernel (:mod:`.kernel`, one C call per epoch) or,
   where that cannot be built or ``ALCOVE_TRAINING_KERNEL=torch``, in PyTorch
   (:class:`.fused.FusedNets`: both nets as one block-structured network with hand-written
   backpropagation, :class:`.adam.FlatAdam`); both engines are in :mod:`.trainers`. Early
   stopping, the batch order and the initialisation are shared.
4. Reproducible: splits come from ``numpy.random.default_rng(seed)``, initialisation and
   batch order from a local ``torch.Generator(seed)``; training runs on one thread, so the
   same pool and seed give bit-identical weights. The global RNGs are not touched.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray

from alcove.science.arrays import FloatArray
from alcove.science.geometry import DEFAULT_PRESET, HeadNeckPreset, RelativeKinematics, relative_kinematics
from alcove.science.series import ForceSeries
from alcove.science.surrogate.adam import FlatAdam
from alcove.science.surrogate.config import SurrogateConfig
from alcove.science.surrogate.dataset import PoolDataError, PoolDataset, check_pool
from alcove.science.surrogate.features import features
from alcove.science.surrogate.mlp import MLP, Standardization, SurrogateModel
from alcove.science.surrogate.trainers import NETS, EpochTrainer, make_trainer

KinematicsFn = Callable[[FloatArray, FloatArray], RelativeKinematics]
SPLITS = ("train", "validation", "test")


class TrainingCancelled(RuntimeError):
    """Training stopped cooperatively through the cancel check."""


@dataclass
class PoolSplit:
    """Which simulations went to the test set, and the pointwise train/validation masks."""

    training_sets: list[str]
    test_sets: list[str]
    sample_split: NDArray[np.object_]  # (N,) of "train" | "validation" | "test" over the stacked pool

    def counts(self) -> dict[str, int]:
        return {s: int(np.sum(self.sample_split == s)) for s in SPLITS}


@dataclass
class TrainingMetrics:
    """RMSE (physical units, all three components) per net and split; epochs; wall time."""

    rmse: dict[str, dict[str, float | None]]
    epochs: dict[str, int]
    best_epoch: dict[str, int]
    samples: dict[str, int]
    wall_time_s: float
    training_kernel: str = "torch"  # "c": the compiled kernel, "torch": the PyTorch implementation

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class TrainingResult:
    model: SurrogateModel
    metrics: TrainingMetrics
    split: PoolSplit
    history: dict[str, list[float]] = field(default_factory=dict)  # validation loss per epoch


def preset_kinematics(preset: HeadNeckPreset) -> KinematicsFn:
    """NumPy kinematics of the 1-DOF head-neck preset as a function of q, qd (n, 1)."""

    def kin(q: FloatArray, qd: FloatArray) -> RelativeKinematics:
        if q.shape[1] != 1:
            raise PoolDataError(
                "q",
                f"the head-neck preset has 1 degree of freedom, got {q.shape[1]}; pass kinematics= for other chains",
            )
        return relative_kinematics(preset, q[:, 0], qd[:, 0])

    return kin


def split_pool(pool: list[PoolDataset], config: SurrogateConfig, seed: int) -> PoolSplit:
    """Whole simulations to the test set, then the training part pointwise into train/validation."""
    check_pool(pool)
    rng = np.random.default_rng([seed, 0x5E1175])
    n = len(pool)
    n_test = round(config.test_fraction * n)
    if config.test_fraction > 0 and n >= 2:
        n_test = max(n_test, 1)
    n_test = min(n_test, n - 1)
    order = rng.permutation(n)
    test_ids = set(order[:n_test].tolist())
    labels = []
    for i, ds in enumerate(pool):
        labels.append(np.full(ds.n_samples, "test" if i in test_ids else "train", dtype=object))
    sample_split = np.concatenate(labels)
    train_pos = np.flatnonzero(sample_split == "train")
    m = train_pos.size
    if m < 2:
        raise PoolDataError(
            "pool", f"the training part has {m} sample(s); at least 2 are needed for a train/validation split"
        )
    n_val = min(max(round(config.validation_fraction * m), 1), m - 1)
    sample_split[rng.choice(train_pos, size=n_val, replace=False)] = "validation"
    return PoolSplit(
        training_sets=[ds.name for i, ds in enumerate(pool) if i not in test_ids],
        test_sets=[pool[i].name for i in sorted(test_ids)],
        sample_split=sample_split,
    )


def pool_features(pool: list[PoolDataset], kinematics: KinematicsFn) -> FloatArray:
    return np.concatenate([features(kinematics(ds.q, ds.qd)) for ds in pool])


def sample_weights(pool: list[PoolDataset], config: SurrogateConfig) -> FloatArray:
    n_oracle = sum(ds.origin == "oracle" for ds in pool)
    w = [
        np.full(ds.n_samples, ds.weight if ds.weight is not None else config.weight_for(ds.origin, n_oracle))
        for ds in pool
    ]
    return np.concatenate(w)


def train_surrogate(
    pool: list[PoolDataset],
    config: SurrogateConfig,
    seed: int,
    warm_start: SurrogateModel | None = None,
    cancel: Callable[[], bool] | None = None,
    *,
    preset: HeadNeckPreset = DEFAULT_PRESET,
    kinematics: KinematicsFn | None = None,
) -> TrainingResult:
    """Train a force/moment MLP pair on ``pool`` (see the module docstring)."""
    t_start = time.perf_counter()
    split = split_pool(pool, config, seed)
    kin = kinematics or preset_kinematics(preset)
    x = pool_features(pool, kin)
    y = {"force": np.concatenate([ds.force for ds in pool]), "moment": np.concatenate([ds.moment for ds in pool])}
    w = sample_weights(pool, config)
    is_train = split.sample_split == "train"
    if not np.any(w[is_train] > 0):
        raise PoolDataError(
            "weight", "every training sample has weight 0 (check preliminary_weight and the dataset weights)"
        )
    input_norm = Standardization.fit(x[is_train])
    out_norm = {
        k: Standardization.fit(y[k][is_train], constant_scale=0.0)
        if config.normalize_outputs
        else Standardization.identity(3)
        for k in NETS
    }

    dtype = torch.float64 if config.dtype == "float64" else torch.float32
    generator = torch.Generator().manual_seed(int(seed))
    nets = {k: MLP.from_config(getattr(config, k), dtype=dtype) for k in NETS}
    warm: dict[str, bool | str] = {}
    for k in NETS:
        nets[k].reset_parameters(generator)
        if warm_start is not None and config.warm_start:
            previous = getattr(warm_start, f"{k}_net")
            if nets[k].same_architecture(previous):
                nets[k].load_state_dict({n: p.to(dtype) for n, p in previous.state_dict().items()})
                warm[k] = True
            else:  # the campaign changed the architecture: this net starts afresh
                before, now = f"{previous.hidden}/{previous.activation}", f"{nets[k].hidden}/{nets[k].activation}"
                warm[k] = f"cold: architecture {before} -> {now}"

    def tensor(a: FloatArray) -> torch.Tensor:
        return torch.as_tensor(np.ascontiguousarray(a), dtype=dtype)

    z = tensor((x - input_norm.mean) / input_norm.divisor)
    yz = {k: tensor((y[k] - out_norm[k].mean) / out_norm[k].divisor) for k in NETS}
    train_idx = torch.as_tensor(np.flatnonzero(is_train))
    val_idx = torch.as_tensor(np.flatnonzero(split.sample_split == "validation"))
    w_all = tensor(w / w[is_train].mean())
    z_train, w_train = z[train_idx], w_all[train_idx]
    y_train = {k: yz[k][train_idx] for k in NETS}
    z_val, w_val = z[val_idx], w_all[val_idx]
    y_val = {k: yz[k][val_idx] for k in NETS}
    w_val_sum = float(w_val.sum()) or 1.0

    n_threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        with torch.no_grad():
            trainer = make_trainer(nets, z_train, y_train, w_train, config)
            history, epochs, best_epoch = _fit(
                trainer, z_train.shape[0], z_val, y_val, w_val, w_val_sum, config, generator, cancel
            )
    finally:
        torch.set_num_threads(n_threads)

    model = SurrogateModel(
        force_net=nets["force"],
        moment_net=nets["moment"],
        input_norm=input_norm,
        force_norm=out_norm["force"],
        moment_norm=out_norm["moment"],
        config=config,
        preset=preset,
        ndof=pool[0].ndof,
        lineage={
            "seed": int(seed),
            "datasets": [ds.name for ds in pool],
            "test_sets": split.test_sets,
            "samples": int(x.shape[0]),
            "warm_start": warm or False,
            "training_kernel": trainer.name,
        },
    )
    rmse: dict[str, dict[str, float | None]] = {k: {} for k in NETS}
    pred = dict(zip(NETS, model.predict_features(x), strict=False))
    for k in NETS:
        for s in SPLITS:
            mask = split.sample_split == s
            rmse[k][s] = float(np.sqrt(np.mean((pred[k][mask] - y[k][mask]) ** 2))) if mask.any() else None
    metrics = TrainingMetrics(
        rmse=rmse,
        epochs=epochs,
        best_epoch=best_epoch,
        samples=split.counts(),
        wall_time_s=time.perf_counter() - t_start,
        training_kernel=trainer.name,
    )
    model.lineage["metrics"] = metrics.to_dict()
    return TrainingResult(model=model, metrics=metrics, split=split, history=history)


def _fit(
    trainer: EpochTrainer,
    n: int,
    z_val: torch.Tensor,
    y_val: dict[str, torch.Tensor],
    w_val: torch.Tensor,
    w_val_sum: float,
    config: SurrogateConfig,
    generator: torch.Generator,
    cancel: Callable[[], bool] | None,
) -> tuple[dict[str, list[float]], dict[str, int], dict[str, int]]:
    """Epochs until every net has stopped early (or ``max_epochs``); each net ends with its best weights.

    Returns the validation loss of every epoch, the number of epochs and the best epoch, per net.
    """
    best = {k: float("inf") for k in NETS}
    for k in NETS:
        trainer.remember_best(k)
    best_epoch = dict.fromkeys(NETS, 0)
    epochs = dict.fromkeys(NETS, 0)
    history: dict[str, list[float]] = {k: [] for k in NETS}
    for epoch in range(1, config.max_epochs + 1):
        if cancel is not None and cancel():
            raise TrainingCancelled(f"training cancelled in epoch {epoch}")
        trainer.epoch(torch.randperm(n, generator=generator))
        stopped = []
        for k, out in trainer.validation_outputs(z_val):
            val = float(((out - y_val[k]) ** 2).mean(1) @ w_val) / w_val_sum
            history[k].append(val)
            epochs[k] = epoch
            if val < best[k]:
                best[k], best_epoch[k] = val, epoch
                trainer.remember_best(k)
            elif epoch - best_epoch[k] >= config.patience:
                stopped.append(k)
        if stopped and not trainer.stop(stopped):
            break  # every net has stopped
    for k in NETS:
        trainer.restore_best(k)
    return history, epochs, best_epoch


def predict_arrays(
    model: SurrogateModel, q: FloatArray, qd: FloatArray, kinematics: KinematicsFn | None = None
) -> tuple[FloatArray, FloatArray]:
    """Predicted force (n, 3) and moment (n, 3) at states q, qd ((n,) or (n, ndof))."""
    q = np.asarray(q, float)
    qd = np.asarray(qd, float)
    q = q[:, None] if q.ndim == 1 else q
    qd = qd[:, None] if qd.ndim == 1 else qd
    if q.shape != qd.shape:
        raise PoolDataError("qd", f"has shape {qd.shape} but q has {q.shape}")
    if q.shape[1] != model.ndof:
        raise PoolDataError("q", f"has {q.shape[1]} degrees of freedom, the model was trained on {model.ndof}")
    kin = (kinematics or preset_kinematics(model.preset))(q, qd)
    return model.predict_features(features(kin))


def predict(
    model: SurrogateModel, t: FloatArray, q: FloatArray, qd: FloatArray, kinematics: KinematicsFn | None = None
) -> ForceSeries:
    """Predicted contact force and moment (headrest frame) along a trajectory."""
    force, moment = predict_arrays(model, q, qd, kinematics)
    return ForceSeries(np.asarray(t, float), force, moment)


__all__ = [
    "FlatAdam",
    "PoolSplit",
    "TrainingCancelled",
    "TrainingMetrics",
    "TrainingResult",
    "predict",
    "predict_arrays",
    "preset_kinematics",
    "sample_weights",
    "split_pool",
    "train_surrogate",
]
