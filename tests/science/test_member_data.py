"""``member_data``: the ensemble's members trained on today's splits, or on bootstrap resamples over trajectories.

The pools are built here: trajectories q(t) = c + a sin(2 pi f t + phase) of 100 samples, with a smooth
law of (q, qd) and, for the statistical test, an offset per trajectory that the state cannot explain (a
hidden history term: the same state gives other forces in another trajectory).
"""

from __future__ import annotations

import hashlib
from typing import ClassVar

import numpy as np
import pytest

from alcove.science.surrogate import training
from alcove.science.surrogate.config import SurrogateConfig, SurrogateConfigError
from alcove.science.surrogate.dataset import PoolDataset
from alcove.science.surrogate.metrics import calibration
from alcove.science.surrogate.training import bootstrap_counts, member_seed, predict_ensemble, train_surrogate

N_SAMPLES = 100


def trajectories(
    n: int, seed: int, prefix: str = "sim", offset_std: float = 0.0, origin: str = "oracle"
) -> list[PoolDataset]:
    """``n`` trajectories of a smooth law; each adds its own offsets ~ N(0, offset_std) to fx, fz
    (and a tenth of it to my) on every sample."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, N_SAMPLES)
    pool = []
    for i in range(n):
        a, c, f, ph = rng.uniform(0.05, 0.2), rng.uniform(0.1, 0.35), rng.uniform(0.5, 1.5), rng.uniform(0, 2 * np.pi)
        b = rng.normal(0.0, offset_std, 3) * [1.0, 1.0, 0.1]
        q = c + a * np.sin(2 * np.pi * f * t + ph)
        qd = 2 * np.pi * f * a * np.cos(2 * np.pi * f * t + ph)
        z = np.zeros_like(q)
        force = np.stack([20 * np.sin(4 * q) + 2 * q * qd + b[0], z, 5 * np.cos(3 * q) - qd + b[1]], -1)
        moment = np.stack([z, 2 * q + b[2], z], -1)
        pool.append(PoolDataset(f"{prefix}-{i:03d}", t, q, qd, force, moment, origin))
    return pool


def digest(model) -> str:
    h = hashlib.sha256()
    for m in model.members:
        for net in (m.force_net, m.moment_net):
            for p in net.state_dict().values():
                h.update(p.numpy().tobytes())
    return h.hexdigest()


SHORT = SurrogateConfig(max_epochs=4, batch_size=128, ensemble_size=3)


def test_the_default_is_split_and_a_bad_value_names_the_field():
    assert SurrogateConfig().member_data == "split"
    assert SurrogateConfig.parse({"member_data": "bootstrap"}).member_data == "bootstrap"
    with pytest.raises(SurrogateConfigError, match=r"^member_data: Input should be 'split' or 'bootstrap'") as err:
        SurrogateConfig.parse({"member_data": "bagging"})
    assert err.value.field == "member_data"


def test_split_trains_the_ensemble_of_a_config_without_the_field(monkeypatch):
    """``"split"`` is today's training, bit for bit: the same weights as a config that does not name the
    field, and as the bootstrap path with every draw count forced to 1 (so the split path is the bootstrap
    path without its weights, and the weights are all the bootstrap changes)."""
    pool = trajectories(8, seed=1)
    without = train_surrogate(pool, SurrogateConfig.parse(SHORT.model_dump(exclude={"member_data"})), seed=5)
    split = train_surrogate(pool, SHORT.model_copy(update={"member_data": "split"}), seed=5)
    assert digest(split.model) == digest(without.model)
    assert split.model.lineage["member_data"] == ["split"] * 3
    bootstrap = SHORT.model_copy(update={"member_data": "bootstrap"})
    assert digest(train_surrogate(pool, bootstrap, seed=5).model) != digest(split.model)
    monkeypatch.setattr(training, "bootstrap_counts", lambda pool, split, seed: dict.fromkeys(split.training_sets, 1))
    assert digest(train_surrogate(pool, bootstrap, seed=5).model) == digest(split.model)


class _Recorder(training.EnsembleTrainer):
    """The trainer, keeping the members' tensors it was given (their weights)."""

    seen: ClassVar[list] = []

    def __init__(self, nets, data, *args, **kwargs):
        _Recorder.seen.append(data)
        super().__init__(nets, data, *args, **kwargs)


def _dataset_weights(pool, split, rows_mask, w):
    """Per dataset of the pool, its rows' weights (from the member's rows ``w`` under ``rows_mask``)."""
    owner = np.repeat(np.arange(len(pool)), [ds.n_samples for ds in pool])[rows_mask]
    return {pool[i].name: w[owner == i] for i in np.unique(owner)}


def test_bootstrap_weights_are_whole_draw_counts_that_differ_between_members(monkeypatch):
    """12 trajectories and 2 preliminary chunks: each member weighs each of its measured training
    trajectories by how often it was drawn (whole numbers summing to their number), the preliminary
    chunks as before; the members' draws differ, and the same seed draws the same again."""
    prelim = trajectories(2, seed=3, prefix="preliminary", origin="preliminary")
    pool = prelim + trajectories(12, seed=2)
    config = SurrogateConfig(
        max_epochs=2,
        batch_size=128,
        ensemble_size=4,
        member_data="bootstrap",
        preliminary_weight=0.5,
        preliminary_in_contact="keep",
    )
    monkeypatch.setattr(training, "EnsembleTrainer", _Recorder)
    _Recorder.seen = []
    result = train_surrogate(pool, config, seed=9)
    again = train_surrogate(pool, config, seed=9)
    other = train_surrogate(pool, config, seed=10)
    draws = [d["bootstrap"] for d in result.model.lineage["member_data"]]
    assert draws == [d["bootstrap"] for d in again.model.lineage["member_data"]]  # reproducible from the seed
    assert draws != [d["bootstrap"] for d in other.model.lineage["member_data"]]
    assert digest(result.model) == digest(again.model)
    assert len({tuple(d.items()) for d in draws}) == 4  # every member its own resample
    for k, (split, counts) in enumerate(zip(result.splits, draws, strict=True)):
        measured = [n for n in split.training_sets if not n.startswith("preliminary")]
        assert list(counts) == measured and sum(counts.values()) == len(measured) >= 12 - 4  # 4 of 14 to test
        assert all(isinstance(c, int) and c >= 0 for c in counts.values()) and 0 in counts.values()
        assert counts == bootstrap_counts(pool, split, member_seed(9, k))
        # what the member trains on: each training trajectory's train and validation rows weigh its draw count
        data = _Recorder.seen[0][k]
        for part, w in (("train", data.w_train.numpy()), ("validation", data.w_val.numpy())):
            per_dataset = _dataset_weights(pool, split, split.masks[part], w)
            unit = next(v[0] / counts[n] for n, v in per_dataset.items() if counts.get(n))
            for name, v in per_dataset.items():
                want = counts.get(name, 0.5)  # the preliminary chunks keep their weight
                np.testing.assert_allclose(v, want * unit, rtol=1e-6)


def test_bootstrap_spread_reflects_what_the_data_do_not_pin_down():
    """Each trajectory carries its own offset (std 4 N on fx and fz) that no state feature explains. The
    best a model can do on an unseen trajectory is the law plus the mean offset, with an error of about
    4 N, and an honest ensemble spreads about that much. A split member fits the mean offset of 8 of the
    12 trajectories, drawn without replacement from the same 12 as the other members: the members'
    offsets scatter by 4 N x sqrt(1/8 x 4/11) = 0.85 N. A bootstrap member's resample of its 8 adds
    4 N / sqrt(8) = 1.4 N of scatter (1.65 N in all): the spread on held-out trajectories about doubles,
    and more of their oracle values fall inside mean +- 2 std. Thresholds (three pools, K = 8, 60 epochs;
    measured: std ratios 1.6 to 2.3, calibration gains 0.14 to 0.24): the spread grows by more than a
    third on every pool, the calibration is better on every pool and by more than 0.05 on average."""
    config = SurrogateConfig(ensemble_size=8, max_epochs=60, batch_size=256)
    gains, ratios = [], []
    for p in range(3):
        pool = trajectories(12, seed=10 + p, offset_std=4.0)
        held = trajectories(8, seed=100 + p, prefix="held", offset_std=4.0)
        q, qd = np.concatenate([d.q for d in held]), np.concatenate([d.qd for d in held])
        true = np.concatenate([np.hstack([d.force, d.moment]) for d in held])
        spread, cal = {}, {}
        for mode in ("split", "bootstrap"):
            model = train_surrogate(pool, config.model_copy(update={"member_data": mode}), seed=0).model
            pred = predict_ensemble(model, q, qd)
            spread[mode] = float(np.mean(pred.force_std[:, [0, 2]]))
            std = np.hstack([pred.force_std, pred.moment_std])
            cal[mode] = calibration(np.hstack([pred.force, pred.moment]), true, std)
        ratios.append(spread["bootstrap"] / spread["split"])
        gains.append(cal["bootstrap"] - cal["split"])
    assert min(ratios) > 4 / 3, ratios
    assert min(gains) > 0 and np.mean(gains) > 0.05, gains
