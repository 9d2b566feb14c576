"""Training protocol: splits, a known smooth law, determinism, weights, warm start, errors."""

from dataclasses import replace

import numpy as np
import pytest
import torch
from conftest import make_smooth_pool, smooth_wrench

from alcove.science.surrogate.config import NetworkConfig, SurrogateConfig
from alcove.science.surrogate.dataset import PoolDataError, PoolDataset
from alcove.science.surrogate.training import (
    TrainingCancelled,
    predict,
    preliminary_in_contact,
    sample_weights,
    split_pool,
    train_surrogate,
)

SHORT = SurrogateConfig(max_epochs=4, batch_size=256, ensemble_size=1)


def test_split_keeps_whole_simulations_together(smooth_pool):
    split = split_pool(smooth_pool, SurrogateConfig(), seed=7)
    labels = np.split(split.sample_split, np.cumsum([ds.n_samples for ds in smooth_pool])[:-1])
    for ds, lab in zip(smooth_pool, labels, strict=False):
        in_test = lab == "test"
        assert in_test.all() or not in_test.any()
        assert (ds.name in split.test_sets) == in_test.all()
    assert len(split.test_sets) == 6  # 30 % of 20 simulations
    assert sorted(split.training_sets + split.test_sets) == sorted(ds.name for ds in smooth_pool)
    counts = split.counts()
    assert counts["validation"] == round(0.2 * (counts["train"] + counts["validation"]))  # pointwise 80/20
    # points of one training simulation land on both sides of the train/validation split
    train_sim = labels[[ds.name for ds in smooth_pool].index(split.training_sets[0])]
    assert {"train", "validation"} <= set(train_sim)
    assert split_pool(smooth_pool, SurrogateConfig(), seed=8).test_sets != split.test_sets


def test_split_of_a_single_simulation_has_no_test_set(smooth_pool):
    split = split_pool(smooth_pool[:1], SurrogateConfig(), seed=0)
    assert split.test_sets == [] and split.counts()["test"] == 0


def test_learns_a_known_smooth_law(smooth_pool, trained_smooth):
    result = trained_smooth
    f_std = np.concatenate([ds.force for ds in smooth_pool]).std(0).max()
    m_std = np.concatenate([ds.moment for ds in smooth_pool]).std(0).max()
    rmse = result.metrics.rmse
    assert rmse["force"]["test"] < 0.02 * f_std
    assert rmse["moment"]["test"] < 0.05 * m_std
    assert result.metrics.epochs["force"] > result.metrics.best_epoch["force"]  # stopped early, best kept
    assert result.metrics.epochs["force"] - result.metrics.best_epoch["force"] == 6  # patience
    assert result.metrics.members[0]["stop_reason"] == {"force": "patience", "moment": "patience"}
    # new trajectory, unseen: predict() agrees with the law
    t = np.linspace(0, 1, 50)
    q, qd = 0.25 + 0.1 * np.sin(3 * t), 0.3 * np.cos(3 * t)
    pred = predict(result.model, t, q, qd)
    force, _ = smooth_wrench(q, qd)
    assert np.sqrt(np.mean((pred.force - force) ** 2)) < 0.05 * f_std
    assert np.all(pred.force[:, 1] == 0) and np.all(pred.moment[:, [0, 2]] == 0)  # zero-variance outputs


def test_zero_variance_features_give_finite_models(smooth_pool):
    result = train_surrogate(smooth_pool[:4], SHORT, seed=0)
    norm = result.model.input_norm
    assert np.all(np.isfinite(norm.mean)) and np.all(norm.scale > 0)
    planar_constant = [1, 4, 7, 9, 10, 11, 12, 14]  # r_y, v_y, T_10, T_01, T_11, T_21, omega_x, omega_z
    assert np.all(norm.scale[planar_constant] == 1.0)
    for net in (result.model.force_net, result.model.moment_net):
        assert all(torch.isfinite(p).all() for p in net.parameters())


def test_same_pool_and_seed_give_bit_identical_weights(smooth_pool):
    a = train_surrogate(smooth_pool, SHORT, seed=3).model
    b = train_surrogate(smooth_pool, SHORT, seed=3).model
    c = train_surrogate(smooth_pool, SHORT, seed=4).model
    for name in ("force_net", "moment_net"):
        sa, sb, sc = (getattr(m, name).state_dict() for m in (a, b, c))
        assert all(torch.equal(sa[k], sb[k]) for k in sa)
        assert not all(torch.equal(sa[k], sc[k]) for k in sa)
    assert torch.get_num_threads() >= 1


def test_preliminary_down_weighting():
    prelim = [
        PoolDataset(
            ds.name.replace("sim", "preliminary"), ds.t, ds.q, ds.qd, 0 * ds.force, 0 * ds.moment, "preliminary"
        )
        for ds in make_smooth_pool(10, seed=1)
    ]
    oracle = make_smooth_pool(10, seed=2)
    pool = prelim + oracle
    cfg = SurrogateConfig(preliminary_weight=0.5, preliminary_halving=5)
    w = sample_weights(pool, cfg)
    assert np.all(w[: 10 * 100] == 0.5 * 0.5 ** (10 / 5)) and np.all(w[10 * 100 :] == 1)
    # contradictory data: preliminary says zero force; with weight 0 the model follows the oracle
    res = train_surrogate(
        pool, SurrogateConfig(preliminary_weight=0.0, test_fraction=0.0, batch_size=256, max_epochs=60), seed=0
    )
    t = np.linspace(0, 1, 20)
    q, qd = 0.25 + 0.05 * np.sin(4 * t), 0.2 * np.cos(4 * t)
    force, _ = smooth_wrench(q, qd)
    pred = predict(res.model, t, q, qd)
    assert np.sqrt(np.mean((pred.force - force) ** 2)) < 0.1 * np.abs(force).max()
    explicit = [
        PoolDataset(ds.name, ds.t, ds.q, ds.qd, ds.force, ds.moment, ds.origin, weight=2.0) for ds in prelim[:1]
    ]
    assert np.all(sample_weights(explicit, cfg) == 2.0)  # a dataset's own weight wins


def test_preliminary_samples_in_contact_weigh_zero_once_measured_data_exist():
    """The auxiliary law's samples in contact (wrench not zero) bootstrap the first model only: with the
    default ``preliminary_in_contact: "drop"`` they weigh 0 as soon as the pool holds oracle or uploaded
    data, while its samples out of contact (wrench exactly zero) keep the preliminary weight (and its
    halving); ``"keep"`` weighs them all alike; a dataset's own weight wins."""
    prelim = []
    for ds in make_smooth_pool(4, n_samples=10, seed=1, origin="preliminary", prefix="preliminary"):
        force, moment = ds.force.copy(), ds.moment.copy()
        force[::2], moment[::2] = 0.0, 0.0  # every other sample clear of the headrest
        moment[1::4] = 0.0  # in contact with a zero moment: still in contact (its force is not zero)
        prelim.append(replace(ds, force=force, moment=moment))
    contact = np.tile(np.arange(10) % 2 == 1, 4)
    oracle = make_smooth_pool(2, n_samples=10, seed=2)
    upload = [replace(ds, origin="upload") for ds in oracle]
    cfg = SurrogateConfig(preliminary_weight=0.5, preliminary_halving=1)
    assert cfg.preliminary_in_contact == "drop"
    assert np.all(sample_weights(prelim, cfg) == 0.5)  # no measured data yet: the prior is all there is
    w = sample_weights(prelim + oracle, cfg)
    np.testing.assert_array_equal(w[:40], np.where(contact, 0.0, 0.5 * 0.5**2))
    assert np.all(w[40:] == 1.0)
    np.testing.assert_array_equal(sample_weights(prelim + upload, cfg)[:40], np.where(contact, 0.0, 0.5))
    # a member whose measured data all went to its test set trains on the whole prior
    assert np.all(sample_weights(prelim + oracle, cfg, measured=False)[:40] == 0.5 * 0.5**2)
    keep = cfg.model_copy(update={"preliminary_in_contact": "keep"})
    assert np.all(sample_weights(prelim + oracle, keep)[:40] == 0.5 * 0.5**2)
    own = [replace(ds, weight=2.0) for ds in prelim]
    assert np.all(sample_weights(own + oracle, cfg)[:40] == 2.0)
    np.testing.assert_array_equal(preliminary_in_contact(prelim[0]), contact[:10])
    # in a training: the one oracle simulation of this pool is the test set of some members (70/30 by
    # simulation), and they keep the prior's contact samples; the others train without them
    small = prelim[:2] + oracle[:1]
    result = train_surrogate(small, SurrogateConfig(ensemble_size=6, max_epochs=2), seed=0)
    tested = ["sim-000" in sp.test_sets for sp in result.splits]
    assert any(tested) and not all(tested)
    assert result.model.lineage["preliminary_in_contact"] == ["keep" if t else "drop" for t in tested]


def test_warm_start_starts_from_the_previous_weights(smooth_pool, trained_smooth):
    first = trained_smooth
    tiny = SurrogateConfig(max_epochs=1, learning_rate=1e-12, ensemble_size=1)
    warm = train_surrogate(smooth_pool, tiny, seed=1, warm_start=first.model)
    cold = train_surrogate(smooth_pool, tiny, seed=1)
    assert warm.model.lineage["warm_start"] == {"force": True, "moment": True}
    assert cold.model.lineage["warm_start"] is False
    assert warm.metrics.rmse["force"]["train"] < 0.1 * cold.metrics.rmse["force"]["train"]
    # an architecture changed during the campaign: that net starts afresh, the other is carried over
    changed = train_surrogate(
        smooth_pool, tiny.model_copy(update={"force": NetworkConfig(hidden=(8,))}), seed=1, warm_start=first.model
    )
    assert changed.model.lineage["warm_start"]["moment"] is True
    # the default force net: fx in a block of its own, (fy, fz) in the other
    assert changed.model.lineage["warm_start"]["force"] == (
        "cold: architecture (6, 6, 4)/softplus/blocks [0] [1, 2] -> (8,)/softplus/blocks [0] [1, 2]"
    )
    assert changed.metrics.rmse["moment"]["train"] == pytest.approx(warm.metrics.rmse["moment"]["train"], rel=1e-6)


def test_warm_start_keeps_the_previous_weights_when_no_epoch_improves_on_them(smooth_pool, trained_smooth):
    """Early stopping's candidates include the starting weights (epoch 0) of a warm start: with a
    step size that makes every epoch worse (lr 0.5 on standardised data), the result is the previous
    model, bit for bit, after ``warm_patience`` epochs; a cold start from the same config moves."""
    first = trained_smooth.model
    wild = SurrogateConfig(
        ensemble_size=1,
        learning_rate=0.5,
        warm_learning_rate=0.5,
        warm_patience=3,
        warm_min_improvement=0.0,
        warm_max_epochs=50,
        max_epochs=50,
        patience_steps=0,
    )
    warm = train_surrogate(smooth_pool, wild, seed=0, warm_start=first)
    assert warm.metrics.best_epoch == {"force": 0, "moment": 0}
    assert warm.metrics.epochs == {"force": 3, "moment": 3}  # threshold: stopped after warm_patience epochs
    for net in ("force_net", "moment_net"):
        for name, value in getattr(warm.model, net).state_dict().items():
            assert torch.equal(value, getattr(first, net).state_dict()[name]), (net, name)
    assert len(warm.history["force"]) == 4  # epochs 0 .. 3
    cold = train_surrogate(smooth_pool, wild, seed=0)
    assert cold.metrics.best_epoch["force"] >= 1


def test_metrics_and_cancel(smooth_pool):
    res = train_surrogate(smooth_pool, SHORT, seed=0)
    m = res.metrics.to_dict()
    assert set(m["rmse"]) == {"force", "moment"} and set(m["rmse"]["force"]) == {"train", "validation", "test"}
    assert m["epochs"] == {"force": 4, "moment": 4} and m["wall_time_s"] > 0
    assert sum(m["samples"].values()) == 2000
    with pytest.raises(TrainingCancelled):
        train_surrogate(smooth_pool, SHORT, seed=0, cancel=lambda: True)


def test_bad_pools_give_clear_errors(smooth_pool):
    with pytest.raises(PoolDataError, match=r"^pool: is empty"):
        train_surrogate([], SurrogateConfig(), seed=0)
    with pytest.raises(PoolDataError, match=r"^sim-000: duplicate"):
        train_surrogate([smooth_pool[0], smooth_pool[0]], SurrogateConfig(), seed=0)
    one = smooth_pool[0]
    with pytest.raises(PoolDataError, match=r"^pool: the training part has 1 sample"):
        train_surrogate(
            [PoolDataset("a", one.t[:1], one.q[:1], one.qd[:1], one.force[:1], one.moment[:1])],
            SurrogateConfig(),
            seed=0,
        )
    zero = [PoolDataset(ds.name, ds.t, ds.q, ds.qd, ds.force, ds.moment, "preliminary") for ds in smooth_pool[:3]]
    with pytest.raises(PoolDataError, match=r"^weight: every training sample has weight 0"):
        train_surrogate(zero, SurrogateConfig(preliminary_weight=0), seed=0)
    two_dof = PoolDataset("b", one.t, np.c_[one.q, one.q], np.c_[one.qd, one.qd], one.force, one.moment)
    with pytest.raises(PoolDataError, match=r"^b.q: has 2 degrees of freedom"):
        train_surrogate([one, two_dof], SurrogateConfig(), seed=0)
    with pytest.raises(PoolDataError, match=r"^q: the head-neck preset has 1 degree"):
        train_surrogate([two_dof], SurrogateConfig(), seed=0)


def _weights_digest(model) -> str:
    import hashlib

    h = hashlib.sha256()
    for m in model.members:
        for net in (m.force_net, m.moment_net):
            for p in net.state_dict().values():
                h.update(p.numpy().tobytes())
    return h.hexdigest()


_DIGEST_SCRIPT = """
import sys
sys.path.insert(0, sys.argv[1])
from conftest import make_smooth_pool
from test_surrogate_training import _weights_digest
from alcove.science.surrogate.config import SurrogateConfig
from alcove.science.surrogate.training import train_surrogate
config = SurrogateConfig(max_epochs=3, batch_size=64, ensemble_size=3)
print(_weights_digest(train_surrogate(make_smooth_pool(6), config, seed=5).model))
"""


def test_bit_identical_weights_in_another_process():
    import subprocess
    import sys
    from pathlib import Path

    other = subprocess.run(
        [sys.executable, "-c", _DIGEST_SCRIPT, str(Path(__file__).parent)], capture_output=True, text=True, check=True
    ).stdout.strip()
    here = _weights_digest(
        train_surrogate(
            make_smooth_pool(6), SurrogateConfig(max_epochs=3, batch_size=64, ensemble_size=3), seed=5
        ).model
    )
    assert other == here
