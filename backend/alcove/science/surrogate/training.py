"""Training protocol of the surrogate (the paper's, as the default) and prediction.

1. Split the pool by simulation: ``test_fraction`` (30 %) of the datasets, whole, to the
   test set; the rest is split pointwise ``validation_fraction`` (20 %) into validation
   (:func:`split_pool`, the paper's split, with the member's seed). A warm-started chain keeps
   its split (:class:`SplitPlan`, recorded in the model's lineage): the datasets of the chain's
   first, cold training (its *base*) keep the labels of that paper's split, and every dataset
   added later is labelled by a function of (member split seed, dataset name) alone
   (:func:`stable_dataset_labels`: test with probability ``test_fraction``, else each sample
   validation with probability ``validation_fraction``). So no sample ever moves between
   train, validation and test along a campaign, and the carried weights are judged on the same
   validation samples as before. A cold training (K = 1: the paper's protocol) is unchanged.
2. Features (:mod:`.features`) standardised with the mean and standard deviation of the
   train points; targets standardised the same way (``normalize_outputs``).
3. Ensemble of ``ensemble_size`` K members (default 5; K = 1 is the paper's single model):
   member k has its own seed (:func:`member_seed`; member 0 the model's seed) and so its own
   70/30 and 80/20 splits, standardisations, initialisation and batch order. Force and moment
   MLPs of all members are trained together, vectorised over the members
   (:mod:`.ensemble`: batched weights, autograd, ``torch.optim.Adam``; lr 0.01, batch 1024,
   weighted MSE), each net of each member with early stopping on its validation loss
   (patience 6 epochs and at least ``patience_steps``, 200, Adam steps), keeping its best weights.
   A warm start (``warm_start``: the previous model's weights per member) makes those weights the
   first candidate (epoch 0) and trains from them as fully as a cold training (the same learning
   rate, early stopping and epoch limit unless the ``warm_*`` settings say otherwise), so a
   campaign's model absorbs each new trajectory: a chain of warm starts from a model of another
   law reaches a cold training's error on the final pool (tested: within 5 %, at the noise floor).
   A member keeps its carried weights when no epoch beats them. Prediction is the members' mean, with their
   standard deviation (:meth:`.mlp.SurrogateModel.predict_ensemble`).
   With ``member_data: "bootstrap"`` the members differ in their data as well: member k draws as many
   measured (non-preliminary) simulations of its training part as there are, with replacement, from its
   own seeded generator (:func:`bootstrap_counts`), and a simulation drawn c times weighs c times as much
   in its train and validation samples (0 if never drawn: no data are copied, and its samples still
   enter the member's standardisation). The preliminary data keep their weights: they are independent
   points of one known law, dealt into chunks, not trajectories with a history of their own. The test
   split is the member's split as with ``"split"``; the model's lineage lists per member the draws
   (``member_data``). With ``"split"`` (the default) the training is the one without the option, bit
   for bit.
   With ``architecture: "gated"`` the loss is taken on the gated output (:mod:`.gated`,
   :class:`.ensemble.GatedOutputs`): each sample's gate comes from its signed gap, computed
   from its features and the preset's head profile.
4. Reproducible: a member's splits come from ``numpy.random.default_rng(seed_k)``, its
   initialisation and batch order from a local ``torch.Generator(seed_k)``; each net trains on one intra-op
   thread (the force and moment nets on two threads at once, :mod:`.ensemble`), so the same pool, seed and
   ``dtype`` give bit-identical weights. The global RNGs are not touched. The model is held in float64
   whatever the training's ``dtype`` (float32 by default).
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from functools import cached_property
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray

from alcove.science.arrays import FloatArray
from alcove.science.geometry import (
    DEFAULT_PRESET,
    HeadNeckPreset,
    PoseFunction,
    RelativeKinematics,
    kinematics_from_pose,
    preset_pose,
)
from alcove.science.series import ForceSeries
from alcove.science.surrogate.config import SurrogateConfig
from alcove.science.surrogate.dataset import PoolDataError, PoolDataset, check_pool
from alcove.science.surrogate.ensemble import NETS, EnsembleTrainer, GatedOutputs, MemberTensors
from alcove.science.surrogate.features import N_FEATURES, features
from alcove.science.surrogate.gated import gap_from_features, gate_params, gate_value
from alcove.science.surrogate.history import HistoryError, HistoryInputs, history_inputs
from alcove.science.surrogate.metrics import vector_rmse
from alcove.science.surrogate.mlp import MLP, Member, Prediction, Standardization, SurrogateModel

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

    @cached_property
    def masks(self) -> dict[str, NDArray[np.bool_]]:
        """Per split, its boolean mask over the stacked pool (computed once: comparing the object array is slow)."""
        return {s: self.sample_split == s for s in SPLITS}

    def counts(self) -> dict[str, int]:
        return {s: int(np.count_nonzero(self.masks[s])) for s in SPLITS}


@dataclass
class TrainingMetrics:
    """Per net and split, the members' mean RMSE of the force (moment) vector on their own splits,
    ``sqrt(mean |pred - true|^2)`` (:mod:`.metrics`); epochs (the most over members) and member 0's
    best epoch; member 0's split sizes; wall time; per member the same figures in ``members``, with why
    each net stopped (``stop_reason``: ``patience`` or ``max_epochs``) and whether it was still improving
    then; ``stopped_improving`` counts those nets."""

    rmse: dict[str, dict[str, float | None]]
    epochs: dict[str, int]
    best_epoch: dict[str, int]
    samples: dict[str, int]
    wall_time_s: float
    members: list[dict[str, Any]] = field(default_factory=list)
    steps_per_epoch: int | None = None  # Adam steps an epoch (every member the same)
    batch_size: int | None = None
    #: nets (over members) that stopped at max_epochs while still improving: more epochs would likely help
    stopped_improving: int = 0
    rmse_definition: str = "vector"  # sqrt(mean |e|^2) over samples; "component-mean" before migration 0007

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class TrainingResult:
    model: SurrogateModel
    metrics: TrainingMetrics
    split: PoolSplit  # member 0's
    history: dict[str, list[float]] = field(default_factory=dict)  # member 0's validation loss per epoch
    splits: list[PoolSplit] = field(default_factory=list)  # every member's


def _architecture_text(net: MLP) -> str:
    """``(6, 6, 4)/softplus``; a net of blocks adds its output blocks (and their inputs where one reads
    fewer than all): ``(6, 6, 4)/softplus/blocks [0] [1, 2]``."""
    if not net.blocks:
        return f"{net.hidden}/{net.activation}"
    blocks = " ".join(str(list(b)) for b in net.blocks)
    inputs = "" if all(i is None for i in net.block_inputs) else f" inputs {list(net.block_inputs)}"
    return f"{net.hidden}/{net.activation}/blocks {blocks}{inputs}"


def preset_kinematics(preset: HeadNeckPreset) -> KinematicsFn:
    """NumPy kinematics of the 1-DOF head-neck preset as a function of q, qd (n, 1), through
    the head's pose (:func:`alcove.science.geometry.preset_pose`; the same numbers, bit for bit,
    as :func:`alcove.science.geometry.relative_kinematics`)."""

    def kin(q: FloatArray, qd: FloatArray) -> RelativeKinematics:
        if q.shape[1] != 1:
            raise PoolDataError(
                "q",
                f"the head-neck preset has 1 degree of freedom, got {q.shape[1]}; pass kinematics= for other chains",
            )
        return kinematics_from_pose(preset_pose(preset, q[:, 0], qd[:, 0]))

    return kin


def pose_kinematics(pose: PoseFunction) -> KinematicsFn:
    """The kinematics of any model from its head pose function ``(q, qd) -> pose (n, 6)``
    (e.g. ``ModelSpec.pose_function()`` of a chain task)."""
    return lambda q, qd: kinematics_from_pose(pose(q, qd))


def _paper_labels(counts: list[int], config: SurrogateConfig, seed: int) -> tuple[NDArray[np.object_], set[int]]:
    """The paper's split of datasets with ``counts`` samples: labels over the stacked samples and the
    test datasets' indices. Depends on the counts and the seed only (not on the values)."""
    rng = np.random.default_rng([seed, 0x5E1175])
    n = len(counts)
    n_test = round(config.test_fraction * n)
    if config.test_fraction > 0 and n >= 2:
        n_test = max(n_test, 1)
    n_test = min(n_test, n - 1)
    order = rng.permutation(n)
    test_ids = set(order[:n_test].tolist())
    labels = [np.full(c, "test" if i in test_ids else "train", dtype=object) for i, c in enumerate(counts)]
    sample_split = np.concatenate(labels) if labels else np.zeros(0, dtype=object)
    train_pos = np.flatnonzero(sample_split == "train")
    m = train_pos.size
    if m < 2:
        raise PoolDataError(
            "pool", f"the training part has {m} sample(s); at least 2 are needed for a train/validation split"
        )
    n_val = min(max(round(config.validation_fraction * m), 1), m - 1)
    sample_split[rng.choice(train_pos, size=n_val, replace=False)] = "validation"
    return sample_split, test_ids


def _split_from_labels(pool: list[PoolDataset], sample_split: NDArray[np.object_]) -> PoolSplit:
    offsets = np.cumsum([0] + [ds.n_samples for ds in pool])
    test = [bool(ds.n_samples) and sample_split[offsets[i]] == "test" for i, ds in enumerate(pool)]
    return PoolSplit(
        training_sets=[ds.name for ds, t in zip(pool, test, strict=True) if not t],
        test_sets=[ds.name for ds, t in zip(pool, test, strict=True) if t],
        sample_split=sample_split,
    )


def split_pool(pool: list[PoolDataset], config: SurrogateConfig, seed: int) -> PoolSplit:
    """The paper's split: whole simulations to the test set (``test_fraction`` of them, at least one
    from two on, never all), then the training part pointwise into train/validation
    (``validation_fraction`` of its samples, at least one of each)."""
    check_pool(pool)
    sample_split, _ = _paper_labels([ds.n_samples for ds in pool], config, seed)
    return _split_from_labels(pool, sample_split)


@dataclass(frozen=True)
class SplitPlan:
    """How a warm-started chain of trainings splits its pool (the stable split; module docstring).

    ``base``: the (content key, samples) of the datasets of the chain's first (cold) training,
    split as the paper does with the member's split seed; every other dataset is split by
    :func:`stable_dataset_labels` of its content key (:attr:`PoolDataset.content_key`: the data,
    not the name, which holds a database id, so a campaign splits alike in any database).
    ``seeds``: one split seed per member.
    """

    seeds: tuple[int, ...]
    base: tuple[tuple[str, int], ...]
    test_fraction: float
    validation_fraction: float

    def to_dict(self) -> dict[str, Any]:
        return {
            "protocol": "stable",
            "seeds": list(self.seeds),
            "base": [list(b) for b in self.base],
            "test_fraction": self.test_fraction,
            "validation_fraction": self.validation_fraction,
        }

    def fits(self, config: SurrogateConfig) -> bool:
        """Whether ``config`` splits with the same shares (else the chain's split starts anew)."""
        return self.test_fraction == config.test_fraction and self.validation_fraction == config.validation_fraction

    @classmethod
    def from_lineage(cls, lineage: dict[str, Any]) -> SplitPlan | None:
        """The plan a model was trained with (its first cold training's base, if that was recorded)."""
        doc = lineage.get("split")
        if not isinstance(doc, dict) or doc.get("protocol") != "stable":
            return None
        try:
            seeds = tuple(int(s) for s in doc["seeds"])
            base = tuple((str(name), int(n)) for name, n in doc["base"])
            fractions = float(doc["test_fraction"]), float(doc["validation_fraction"])
        except (KeyError, TypeError, ValueError):
            return None
        return cls(seeds, base, *fractions) if seeds and base else None


def stable_dataset_labels(key: str, n_samples: int, config: SurrogateConfig, seed: int) -> NDArray[np.object_]:
    """The stable split of one dataset outside the base: a function of (split seed, key) only, so a
    dataset keeps its labels in every later training of the chain. The whole dataset is test with
    probability ``test_fraction``; otherwise each sample is validation with probability
    ``validation_fraction`` (the shares hold in expectation)."""
    digest = int.from_bytes(hashlib.blake2b(key.encode(), digest_size=8).digest(), "little")
    rng = np.random.default_rng([int(seed), 0x57AB1E, digest])
    is_test = rng.random() < config.test_fraction
    validation = rng.random(n_samples) < config.validation_fraction
    if is_test:
        return np.full(n_samples, "test", dtype=object)
    return np.where(validation, "validation", "train").astype(object)


def stable_split(
    pool: list[PoolDataset], config: SurrogateConfig, seed: int, base: tuple[tuple[str, int], ...]
) -> PoolSplit | None:
    """The stable split of ``pool`` for one member (split seed ``seed``): the base datasets keep
    their labels of the paper's split of the base, the others get :func:`stable_dataset_labels`.
    None when it leaves no train or no validation sample (the caller falls back to the paper's split)."""
    check_pool(pool)
    base_labels, _ = _paper_labels([n for _, n in base], config, seed)
    offsets = np.cumsum([0] + [n for _, n in base])
    in_base = {key: (offsets[i], n) for i, (key, n) in enumerate(base)}
    labels = []
    for ds in pool:
        at = in_base.get(ds.content_key)
        if at is not None and at[1] == ds.n_samples:
            labels.append(base_labels[at[0] : at[0] + at[1]])
        else:
            labels.append(stable_dataset_labels(ds.content_key, ds.n_samples, config, seed))
    sample_split = np.concatenate(labels)
    if not (np.any(sample_split == "train") and np.any(sample_split == "validation")):
        return None
    return _split_from_labels(pool, sample_split)


#: kinematics of a preset with its headrest moved to ``(offset [m], tilt [rad])`` (None: the preset's own)
MovedHeadrest = Callable[[float | None, float | None], KinematicsFn]


def headrest_preset(preset: HeadNeckPreset, offset: float | None = None, tilt: float | None = None) -> HeadNeckPreset:
    """``preset`` with its headrest moved by ``offset`` [m] along its normal and inclined at ``tilt``
    [rad] (a dataset's ``headrest_offset`` / ``headrest_tilt``; None keeps the preset's own). The
    headrest turns about its origin, the head's back point at ``theta_contact`` moved by the offset."""
    if offset is not None:
        preset = replace(preset, headrest_offset=offset)
    if tilt is not None:
        preset = replace(preset, tilt=tilt)
    return preset


def moved_headrest(preset: HeadNeckPreset) -> MovedHeadrest:
    """Kinematics of ``preset`` with its headrest moved to a dataset's ``headrest_offset`` [m] and
    inclined at its ``headrest_tilt`` [rad] (see :func:`headrest_preset`)."""

    def moved(offset: float | None, tilt: float | None = None) -> KinematicsFn:
        return preset_kinematics(headrest_preset(preset, offset, tilt))

    return moved


def pool_features(
    pool: list[PoolDataset],
    kinematics: KinematicsFn,
    moved: MovedHeadrest | None = None,
    inputs: HistoryInputs | None = None,
) -> FloatArray:
    """The networks' inputs for every sample, each dataset's relative to its own headrest:
    ``kinematics`` for the task's headrest, ``moved(offset, tilt)`` for a dataset simulated with a
    scenario's ``headrest_offset`` and/or ``headrest_tilt``. With ``inputs`` of the ``history``
    feature set the history states follow: along each motion of the pool (its times ``t``), and
    histories drawn at random for the preliminary data's independent samples of a law without
    memory (:func:`.history.memoryless_history`, seeded by the data set's name)."""

    def kin(ds: PoolDataset) -> KinematicsFn:
        if ds.headrest_offset is None and ds.headrest_tilt is None:
            return kinematics
        if moved is None:
            field = "headrest_offset" if ds.headrest_offset is not None else "headrest_tilt"
            raise PoolDataError(f"{ds.name}.{field}", "needs the preset's kinematics (moved_headrest)")
        return moved(ds.headrest_offset, ds.headrest_tilt)

    # one kinematics call per headrest (the kinematics are per sample): datasets grouped by offset and tilt
    groups: dict[tuple[float | None, float | None], list[int]] = {}
    for i, ds in enumerate(pool):
        groups.setdefault((ds.headrest_offset, ds.headrest_tilt), []).append(i)
    out: list[FloatArray] = [np.empty(0)] * len(pool)
    for members in groups.values():
        fn = kin(pool[members[0]])
        k_all = fn(np.concatenate([pool[i].q for i in members]), np.concatenate([pool[i].qd for i in members]))
        bounds = np.cumsum([0] + [pool[i].n_samples for i in members])
        for j, i in enumerate(members):
            lo, hi = bounds[j], bounds[j + 1]
            k_i = RelativeKinematics(k_all.r_rel[lo:hi], k_all.v_rel[lo:hi], k_all.T_rel[lo:hi], k_all.omega_rel[lo:hi])
            ds = pool[i]
            try:
                if inputs is None:
                    out[i] = features(k_i)
                elif ds.origin == "preliminary":  # the auxiliary law has no memory: any history holds
                    out[i] = inputs(k_i, None, memoryless=_name_seed(ds.name))
                else:
                    out[i] = inputs(k_i, ds.t)
            except HistoryError as exc:
                raise PoolDataError(f"{ds.name}.{exc.field}", exc.reason) from None
    return np.concatenate(out)


def _name_seed(name: str) -> int:
    """A stable seed from a data set's name (the same draws in every process and run)."""
    return int.from_bytes(hashlib.sha256(name.encode()).digest()[:8], "little")


def sample_weights(pool: list[PoolDataset], config: SurrogateConfig, measured: bool | None = None) -> FloatArray:
    """Each sample's weight in the loss: its dataset's ``weight``, else its origin's
    (:meth:`.SurrogateConfig.weight_for`); with ``preliminary_in_contact: "drop"`` a preliminary sample in
    contact (wrench not zero) of a dataset without its own weight weighs 0 once there are measured (oracle
    or uploaded) data to train on: ``measured``, by default whether the pool holds any (a training decides
    per member, by its training split)."""
    n_oracle = sum(ds.origin == "oracle" for ds in pool)
    if measured is None:
        measured = any(ds.origin != "preliminary" for ds in pool)
    drop = config.preliminary_in_contact == "drop" and measured
    w = []
    for ds in pool:
        wk = np.full(ds.n_samples, ds.weight if ds.weight is not None else config.weight_for(ds.origin, n_oracle))
        if drop and ds.origin == "preliminary" and ds.weight is None:
            wk[preliminary_in_contact(ds)] = 0.0
        w.append(wk)
    return np.concatenate(w)


def preliminary_in_contact(ds: PoolDataset) -> NDArray[np.bool_]:
    """The samples of a preliminary dataset in contact: the auxiliary law's force or moment is not zero
    (it is exactly zero where the head is clear of the headrest)."""
    return np.asarray(np.any(ds.force != 0.0, axis=1) | np.any(ds.moment != 0.0, axis=1))


def bootstrap_counts(pool: list[PoolDataset], split: PoolSplit, seed: int) -> dict[str, int]:
    """``member_data: "bootstrap"``: how often a bootstrap resample over the measured (non-preliminary)
    simulations of ``split``'s training part draws each of them, by name (pool order), with
    ``numpy.random.default_rng([seed, 0xB0075])``: n draws with replacement from the n simulations, so the
    counts are whole numbers summing to n (module docstring, step 3)."""
    training = set(split.training_sets)
    names = [ds.name for ds in pool if ds.name in training and ds.origin != "preliminary"]
    rng = np.random.default_rng([int(seed), 0xB0075])
    counts = np.bincount(rng.integers(0, len(names), size=len(names)), minlength=len(names))
    return {name: int(c) for name, c in zip(names, counts, strict=True)}


def member_seed(seed: int, k: int) -> int:
    """Seed of ensemble member ``k``: member 0 has the model's seed (K = 1 is the single model of the
    paper's protocol), the others a seed derived from (seed, k)."""
    if k == 0:
        return int(seed)
    return int(np.random.SeedSequence([int(seed), k]).generate_state(1, np.uint64)[0] >> np.uint64(1))


def _member_splits(
    pool: list[PoolDataset], config: SurrogateConfig, seeds: list[int], warm_start: SurrogateModel | None
) -> tuple[SplitPlan, list[PoolSplit], str | None]:
    """Every member's split and the plan the model records (module docstring, step 1).

    A cold training (or a warm start from a model without a stable plan) splits as the paper
    does with the members' seeds and makes this pool the base of a new plan. A warm start
    continues the previous model's plan: member k keeps its split seed (a member the previous
    model lacks takes its own seed), the base datasets their labels, and every dataset added
    since its stable labels, so no sample changes between train, validation and test."""
    previous = SplitPlan.from_lineage(warm_start.lineage) if warm_start is not None and config.warm_start else None
    note = None
    if previous is not None and not previous.fits(config):
        note = "new plan: test_fraction or validation_fraction changed"
        previous = None
    if previous is not None:
        split_seeds = [previous.seeds[k] if k < len(previous.seeds) else s for k, s in enumerate(seeds)]
        stable = [stable_split(pool, config, s, previous.base) for s in split_seeds]
        if all(sp is not None for sp in stable):
            plan = SplitPlan(tuple(split_seeds), previous.base, config.test_fraction, config.validation_fraction)
            return plan, [sp for sp in stable if sp is not None], None
        note = "new plan: the previous plan leaves a member without train or validation samples in this pool"
    base = tuple((ds.content_key, ds.n_samples) for ds in pool)
    plan = SplitPlan(tuple(int(s) for s in seeds), base, config.test_fraction, config.validation_fraction)
    return plan, [split_pool(pool, config, s) for s in seeds], note


def train_surrogate(
    pool: list[PoolDataset],
    config: SurrogateConfig,
    seed: int,
    warm_start: SurrogateModel | None = None,
    cancel: Callable[[], bool] | None = None,
    *,
    preset: HeadNeckPreset = DEFAULT_PRESET,
    kinematics: KinematicsFn | None = None,
    member_seeds: list[int] | None = None,
    parallel: bool | None = None,
) -> TrainingResult:
    """Train an ensemble of ``config.ensemble_size`` force/moment MLP pairs on ``pool`` (module docstring).

    ``member_seeds`` overrides the members' seeds (default :func:`member_seed`); its length is K.
    ``parallel``: the force and moment nets on two threads (:mod:`.ensemble`; default when two CPUs
    are available); the weights are the same either way.
    """
    t_start = time.perf_counter()
    seeds = member_seeds if member_seeds is not None else [member_seed(seed, k) for k in range(config.ensemble_size)]
    plan, splits, split_note = _member_splits(pool, config, seeds, warm_start)
    kin = kinematics or preset_kinematics(preset)
    inputs = history_inputs(config.features, config.history, preset)
    x = pool_features(pool, kin, moved_headrest(preset) if kinematics is None else None, inputs)
    y = {"force": np.concatenate([ds.force for ds in pool]), "moment": np.concatenate([ds.moment for ds in pool])}
    # a member whose training split holds measured data trains without the auxiliary law's contact samples
    # (preliminary_in_contact); one whose measured data all went to its test set still has them
    is_measured = np.concatenate([np.full(ds.n_samples, ds.origin != "preliminary") for ds in pool])
    weights = {m: sample_weights(pool, config, measured=m) for m in (False, True)}
    dtype = torch.float64 if config.dtype == "float64" else torch.float32

    def tensor(a: FloatArray) -> torch.Tensor:
        return torch.as_tensor(np.ascontiguousarray(a), dtype=dtype)

    previous = warm_start.members if warm_start is not None and config.warm_start else []
    cold_reason = None
    if previous and warm_start is not None and warm_start.config.architecture != config.architecture:
        cold_reason = f"cold: architecture {warm_start.config.architecture} -> {config.architecture}"
        previous = []
    gated = config.architecture == "gated"
    gate_all = gate_value(gap_from_features(x, preset.profile), gate_params(config)) if gated else None
    norms: dict[str, list[Standardization]] = {n: [] for n in NETS}
    members: list[Member] = []
    data: list[MemberTensors] = []
    generators: list[torch.Generator] = []
    warm: list[dict[str, bool | str]] = []
    prior_contact: list[str] = []  # per member: what became of the preliminary samples in contact
    member_data: list[str | dict[str, dict[str, int]]] = []  # per member: "split" or its bootstrap draws
    for k, (s_k, split) in enumerate(zip(seeds, splits, strict=True)):
        is_train = split.masks["train"]
        measured_k = bool(np.any(is_measured & is_train))
        w = weights[measured_k]
        prior_contact.append("drop" if measured_k and config.preliminary_in_contact == "drop" else "keep")
        if config.member_data == "bootstrap":
            draws = bootstrap_counts(pool, split, s_k)
            w = w * np.repeat([float(draws.get(ds.name, 1)) for ds in pool], [ds.n_samples for ds in pool])
            member_data.append({"bootstrap": draws})
            if not np.any(w[split.masks["validation"]] > 0):
                raise PoolDataError(
                    "member_data", f"member {k}'s bootstrap draws leave every validation sample with weight 0"
                )
        else:
            member_data.append("split")
        if not np.any(w[is_train] > 0):
            raise PoolDataError(
                "weight", "every training sample has weight 0 (check preliminary_weight and the dataset weights)"
            )
        input_norm = Standardization.fit(x[is_train])
        out_norm = {
            n: Standardization.fit(y[n][is_train], constant_scale=0.0)
            if config.normalize_outputs
            else Standardization.identity(3)
            for n in NETS
        }
        generator = torch.Generator().manual_seed(int(s_k))
        nets = {
            n: MLP.from_config(
                getattr(config, n),
                dtype=dtype,
                n_in=len(config.input_names),
                blocks=config.output_blocks(n),
                block_inputs=config.block_inputs(n),
            )
            for n in NETS
        }
        warm_k: dict[str, bool | str] = {}
        for n in NETS:
            nets[n].reset_parameters(generator)
            if k < len(previous):
                before = getattr(previous[k], f"{n}_net")
                if nets[n].same_architecture(before):
                    nets[n].load_state_dict({name: p.to(dtype) for name, p in before.state_dict().items()})
                    warm_k[n] = True
                else:  # the campaign changed the architecture: this net starts afresh
                    old, now = _architecture_text(before), _architecture_text(nets[n])
                    warm_k[n] = f"cold: architecture {old} -> {now}"
            elif previous:
                warm_k[n] = "cold: the previous model has fewer members"
            elif cold_reason is not None:
                warm_k[n] = cold_reason
            norms[n].append(out_norm[n])
        warm.append(warm_k)
        z = tensor((x - input_norm.mean) / input_norm.divisor)
        yz = {n: tensor((y[n] - out_norm[n].mean) / out_norm[n].divisor) for n in NETS}
        w_all = tensor(w / w[is_train].mean())
        tr = torch.as_tensor(np.flatnonzero(is_train))
        va = torch.as_tensor(np.flatnonzero(split.masks["validation"]))
        g_all = None if gate_all is None else tensor(gate_all)
        data.append(
            MemberTensors(
                z_train=z[tr],
                y_train={n: yz[n][tr] for n in NETS},
                w_train=w_all[tr],
                z_val=z[va],
                y_val={n: yz[n][va] for n in NETS},
                w_val=w_all[va],
                g_train=None if g_all is None else g_all[tr],
                g_val=None if g_all is None else g_all[va],
            )
        )
        generators.append(generator)
        members.append(Member(nets["force"], nets["moment"], input_norm, out_norm["force"], out_norm["moment"]))

    n_threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        gated_outputs = None
        if gated:
            gated_outputs = GatedOutputs(
                gate_params(config),
                mean={n: tensor(np.stack([nm.mean for nm in norms[n]])) for n in NETS},
                scale={n: tensor(np.stack([nm.scale for nm in norms[n]])) for n in NETS},
                divisor={n: tensor(np.stack([nm.divisor for nm in norms[n]])) for n in NETS},
            )
        trainer = EnsembleTrainer(
            {n: [getattr(m, f"{n}_net") for m in members] for n in NETS},
            data,
            config,
            generators,
            gated_outputs,
            warm={n: [wk.get(n) is True for wk in warm] for n in NETS},
            parallel=parallel,
        )
        if any(flag is True for wk in warm for flag in wk.values()):
            # the previous model's weights are the first candidate of early stopping (epoch 0)
            trainer.validate(0)
        for epoch in range(1, config.max_epochs + 1):
            if cancel is not None and cancel():
                raise TrainingCancelled(f"training cancelled in epoch {epoch}")
            trainer.epoch()
            if not trainer.validate(epoch):
                break
        trainer.finish()
    finally:
        torch.set_num_threads(n_threads)
    for k, m in enumerate(members):  # held in float64 whatever the training's precision (exact for float32 values)
        for n in NETS:
            net = getattr(m, f"{n}_net").double()
            if warm[k].get(n) is True and trainer.best_epoch[n][k] == 0:
                # no epoch beat the carried weights: the previous model's, exactly (not rounded to the training's dtype)
                net.load_state_dict(getattr(previous[k], f"{n}_net").state_dict())

    model = SurrogateModel.from_members(
        members,
        config,
        preset,
        ndof=pool[0].ndof,
        lineage={
            "seed": int(seed),
            "member_seeds": [int(s_k) for s_k in seeds],
            "datasets": [ds.name for ds in pool],
            "test_sets": splits[0].test_sets,
            "member_test_sets": [sp.test_sets for sp in splits],
            "samples": int(x.shape[0]),
            "warm_start": (warm[0] or False) if len(warm) == 1 else [wk or False for wk in warm],
            "split": {**plan.to_dict(), **({"note": split_note} if split_note else {})},
            "preliminary_in_contact": prior_contact,
            "member_data": member_data,
            "training": "torch (vectorised over members)",
        },
    )
    metrics = _training_metrics(model, x, y, splits, trainer, time.perf_counter() - t_start)
    model.lineage["metrics"] = metrics.to_dict()
    history = {n: [row[0] for row in trainer.history[n] if not np.isnan(row[0])] for n in NETS}  # member 0's
    return TrainingResult(model=model, metrics=metrics, split=splits[0], history=history, splits=splits)


def _training_metrics(
    model: SurrogateModel,
    x: FloatArray,
    y: dict[str, FloatArray],
    splits: list[PoolSplit],
    trainer: EnsembleTrainer,
    wall_time_s: float,
) -> TrainingMetrics:
    """Each member's RMSE on its own splits (:func:`.metrics.vector_rmse`), their mean per split."""
    per_member: list[dict[str, dict[str, float | None]]] = []
    forces, moments = model.predict_members(x)  # through the gate with the gated architecture
    for k, split in enumerate(splits):
        pred = {"force": forces[k], "moment": moments[k]}
        per_member.append(
            {n: {s: vector_rmse(pred[n][split.masks[s]], y[n][split.masks[s]]) for s in SPLITS} for n in NETS}
        )
    rmse: dict[str, dict[str, float | None]] = {n: {} for n in NETS}
    for n in NETS:
        for s in SPLITS:
            values = [v for m in per_member if (v := m[n][s]) is not None]
            rmse[n][s] = float(np.mean(values)) if values else None
    return TrainingMetrics(
        rmse=rmse,
        epochs={n: max(trainer.epochs[n]) for n in NETS},
        best_epoch={n: trainer.best_epoch[n][0] for n in NETS},
        samples=splits[0].counts(),
        wall_time_s=wall_time_s,
        members=[
            {
                "rmse": m,
                "epochs": {n: trainer.epochs[n][k] for n in NETS},
                "best_epoch": {n: trainer.best_epoch[n][k] for n in NETS},
                "stop_reason": {n: trainer.stop_reason[n][k] for n in NETS},
                "still_improving": {n: trainer.still_improving(n, k) for n in NETS},
            }
            for k, m in enumerate(per_member)
        ],
        steps_per_epoch=trainer.S,
        batch_size=trainer.B,
        stopped_improving=sum(trainer.still_improving(n, k) for n in NETS for k in range(trainer.K)),
    )


def predict_ensemble(
    model: SurrogateModel,
    q: FloatArray,
    qd: FloatArray,
    kinematics: KinematicsFn | None = None,
    headrest_offset: float | None = None,
    headrest_tilt: float | None = None,
    t: FloatArray | None = None,
    *,
    steady: bool = False,
) -> Prediction:
    """Ensemble mean and standard deviation of force and moment (each (n, 3)) at states q, qd
    (with the model's headrest moved to ``headrest_offset`` [m] and inclined at ``headrest_tilt``
    [rad] unless ``kinematics`` is given). A model of the ``history`` feature set predicts along
    one motion: ``t`` (n,) are its times, strictly increasing; or, with ``steady``, at independent
    states, each with the history of a motion arriving there steadily."""
    q = np.asarray(q, float)
    qd = np.asarray(qd, float)
    q = q[:, None] if q.ndim == 1 else q
    qd = qd[:, None] if qd.ndim == 1 else qd
    if q.shape != qd.shape:
        raise PoolDataError("qd", f"has shape {qd.shape} but q has {q.shape}")
    if q.shape[1] != model.ndof:
        raise PoolDataError("q", f"has {q.shape[1]} degrees of freedom, the model was trained on {model.ndof}")
    kin = _model_kinematics(model, kinematics, headrest_offset, headrest_tilt)(q, qd)
    inputs = history_inputs(model.config.features, model.config.history, model.preset)
    if inputs is None:
        return model.predict_ensemble(features(kin))
    if t is None and not steady:
        raise PoolDataError("t", "the model's feature set 'history' predicts along a motion: give its times")
    try:
        return model.predict_ensemble(inputs(kin, t, steady=steady))
    except HistoryError as exc:
        raise PoolDataError(exc.field, exc.reason) from None


def _model_kinematics(
    model: SurrogateModel, kinematics: KinematicsFn | None, offset: float | None, tilt: float | None
) -> KinematicsFn:
    return kinematics or preset_kinematics(headrest_preset(model.preset, offset, tilt))


def history_along(
    model: SurrogateModel,
    q: FloatArray,
    qd: FloatArray,
    t: FloatArray,
    kinematics: KinematicsFn | None = None,
    headrest_offset: float | None = None,
    headrest_tilt: float | None = None,
) -> FloatArray | None:
    """The model's history states (n, 3) along the motion (q, qd at times t), as its prediction
    sees them (:func:`predict_ensemble`); None for a model of the state alone."""
    inputs = history_inputs(model.config.features, model.config.history, model.preset)
    if inputs is None:
        return None
    q2, qd2 = (np.asarray(a, float).reshape(len(t), -1) for a in (q, qd))
    kin = _model_kinematics(model, kinematics, headrest_offset, headrest_tilt)(q2, qd2)
    try:
        return inputs(kin, t)[:, N_FEATURES:]
    except HistoryError as exc:
        raise PoolDataError(exc.field, exc.reason) from None


def predict_arrays(
    model: SurrogateModel,
    q: FloatArray,
    qd: FloatArray,
    kinematics: KinematicsFn | None = None,
    t: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Predicted force (n, 3) and moment (n, 3), the ensemble mean, at states q, qd ((n,) or (n, ndof));
    ``t``: the motion's times (needed by a model of the ``history`` feature set)."""
    p = predict_ensemble(model, q, qd, kinematics, t=t)
    return p.force, p.moment


def predict(
    model: SurrogateModel, t: FloatArray, q: FloatArray, qd: FloatArray, kinematics: KinematicsFn | None = None
) -> ForceSeries:
    """Predicted contact force and moment (headrest frame) along a trajectory."""
    force, moment = predict_arrays(model, q, qd, kinematics, t)
    return ForceSeries(np.asarray(t, float), force, moment)


__all__ = [
    "PoolSplit",
    "SplitPlan",
    "TrainingCancelled",
    "TrainingMetrics",
    "TrainingResult",
    "bootstrap_counts",
    "headrest_preset",
    "history_along",
    "member_seed",
    "moved_headrest",
    "pose_kinematics",
    "predict",
    "predict_arrays",
    "predict_ensemble",
    "preliminary_in_contact",
    "preset_kinematics",
    "sample_weights",
    "split_pool",
    "stable_dataset_labels",
    "stable_split",
    "train_surrogate",
]
