"""Deep ensembles: vectorised training equals training each member alone; mean and std are the members'."""

import numpy as np
import pytest
import torch

from alcove.science.surrogate.config import SurrogateConfig
from alcove.science.surrogate.ensemble import batch_sizes
from alcove.science.surrogate.training import member_seed, predict_ensemble, split_pool, train_surrogate

# 20 simulations of 100 samples: every member's 70/30 split by simulation holds 14 simulations,
# so all members have 1120 training rows and the same batches as when trained alone. Patience 2 and
# lr 0.1 make every net of every member stop early, at different epochs (12 to 40 with the default
# force net, whose normal force has layers of its own: its blocks train batched as well).
# float64: the vectorised and the single trainings are compared to float64 rounding
# the paper's early stopping (patience in epochs alone), so that members stop apart within 80 epochs
CONFIG = SurrogateConfig(
    max_epochs=80, batch_size=256, patience=2, patience_steps=0, learning_rate=0.1, ensemble_size=3, dtype="float64"
)
SEEDS = [11, 12, 13]


@pytest.fixture(scope="module")
def ensemble_and_alone(smooth_pool):
    ensemble = train_surrogate(smooth_pool, CONFIG, seed=0, member_seeds=SEEDS)
    alone = [train_surrogate(smooth_pool, CONFIG.model_copy(update={"ensemble_size": 1}), seed=s) for s in SEEDS]
    return ensemble, alone


def test_members_differ_by_seed_and_split(smooth_pool, ensemble_and_alone):
    ensemble, _ = ensemble_and_alone
    assert ensemble.model.ensemble_size == 3
    tests = [sp.test_sets for sp in ensemble.splits]
    assert tests[0] != tests[1] and tests[1] != tests[2]
    assert tests == [split_pool(smooth_pool, CONFIG, s).test_sets for s in SEEDS]
    # member 0 of a default ensemble has the model's own seed: K = 1 is the single model of before
    assert member_seed(7, 0) == 7 and len({member_seed(7, k) for k in range(5)}) == 5


def test_vectorised_training_gives_each_members_weights_trained_alone(ensemble_and_alone):
    ensemble, alone = ensemble_and_alone
    for member, single in zip(ensemble.model.members, alone, strict=True):
        for net in ("force_net", "moment_net"):
            got = getattr(member, net).state_dict()
            want = getattr(single.model, net).state_dict()
            # threshold: batched and single matrix products round differently, and how differs with the
            # CPU's kernels (AVX2 or AVX-512); ~30 epochs at lr 0.1 grow that to 4.9e-11 absolute, 6.3e-9
            # relative on an AVX-512 Xeon. The bound still catches a member trained with its learning rate
            # off by 1e-6 relative (1.6e-5 apart) or with another member's seed (2.9 apart).
            for name in got:
                torch.testing.assert_close(got[name], want[name], rtol=1e-6, atol=1e-8)
        np.testing.assert_array_equal(member.input_norm.mean, single.model.input_norm.mean)
    for k, single in enumerate(alone):
        assert ensemble.metrics.members[k]["best_epoch"] == single.metrics.best_epoch
        assert ensemble.metrics.members[k]["epochs"] == single.metrics.epochs
    stops = {(k, net): m["epochs"][net] for k, m in enumerate(ensemble.metrics.members) for net in m["epochs"]}
    assert max(stops.values()) < CONFIG.max_epochs and len(set(stops.values())) > 2  # stopped early, apart


def test_ensemble_mean_and_std_are_those_of_the_independent_members(ensemble_and_alone):
    ensemble, alone = ensemble_and_alone
    t = np.linspace(0, 1, 40)
    q, qd = 0.22 + 0.1 * np.sin(5 * t), 0.5 * np.cos(5 * t)
    p = predict_ensemble(ensemble.model, q, qd)
    singles = [predict_ensemble(r.model, q, qd) for r in alone]
    f = np.stack([s.force for s in singles])
    m = np.stack([s.moment for s in singles])
    np.testing.assert_allclose(p.force, f.mean(0), rtol=1e-8, atol=1e-9)  # threshold: as above
    np.testing.assert_allclose(p.moment, m.mean(0), rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(p.force_std, f.std(0), rtol=1e-6, atol=1e-9)
    assert np.all(p.force_std[:, 0] > 0)  # the members disagree somewhere off their data
    assert np.all(p.force_std[:, 1] == 0) and np.all(p.moment_std[:, [0, 2]] == 0)  # structural zeros
    assert np.all(singles[0].force_std == 0)  # K = 1 has no spread


def test_warm_start_is_per_member(smooth_pool, ensemble_and_alone):
    ensemble, _ = ensemble_and_alone
    tiny = CONFIG.model_copy(update={"max_epochs": 1, "learning_rate": 1e-12, "ensemble_size": 4})
    warm = train_surrogate(smooth_pool, tiny, seed=0, member_seeds=[*SEEDS, 99], warm_start=ensemble.model)
    status = warm.model.lineage["warm_start"]
    assert status[:3] == [{"force": True, "moment": True}] * 3
    assert status[3]["force"].startswith("cold")
    for k in range(3):  # lr 1e-12: each member is still the previous member k (Adam moves <= lr per step, 5 steps)
        torch.testing.assert_close(
            warm.model.members[k].force_net.state_dict()["layers.0.weight"],
            ensemble.model.members[k].force_net.state_dict()["layers.0.weight"],
            rtol=0,
            atol=5e-12 * 1.01,
        )


def test_batches_cover_every_row_once_per_epoch():
    assert list(batch_sizes(2500, 3, 1024)) == [1024, 1024, 452]  # the largest set: the paper's batches
    sizes = batch_sizes(1900, 3, 1024)  # a smaller set: the same number of nearly equal batches
    assert sizes.sum() == 1900 and len(sizes) == 3 and sizes.max() - sizes.min() <= 1


def test_history_and_metrics_are_strict_json_when_members_stop_apart(ensemble_and_alone):
    import json

    ensemble, alone = ensemble_and_alone
    json.dumps({"history": ensemble.history, "metrics": ensemble.metrics.to_dict()}, allow_nan=False)
    for net in ("force", "moment"):  # member 0's validation losses, as when trained alone (float rounding)
        assert ensemble.history[net] == pytest.approx(alone[0].history[net], rel=1e-9)


def test_the_two_nets_on_two_threads_give_the_same_weights(smooth_pool):
    """The force and moment nets train concurrently (one thread each) or one after the other: bit for bit
    the same weights, epochs and history (each net's arithmetic does not depend on the thread)."""
    config = CONFIG.model_copy(update={"max_epochs": 6})
    runs = [train_surrogate(smooth_pool, config, seed=3, parallel=p) for p in (True, False)]
    for a, b in zip(runs[0].model.members, runs[1].model.members, strict=True):
        for net in ("force_net", "moment_net"):
            want = getattr(b, net).state_dict()
            for name, x in getattr(a, net).state_dict().items():
                assert torch.equal(x, want[name]), name
    assert runs[0].history == runs[1].history and runs[0].metrics.epochs == runs[1].metrics.epochs


def test_float32_training_gives_a_float64_model_with_float32_weights(smooth_pool):
    """``dtype: float32`` is the training's arithmetic: the model is held in float64, every weight is a float32
    value (exact in float64), and its prediction is the float64 evaluation of those weights. It learns the
    smooth law as the float64 training does (threshold: test force RMSE <= 8 % of the force's RMS, 32 N; the
    float64 training of seeds 0-2 reaches 1.3-5.1 %, the float32 one 2.1-3.8 %)."""
    config = SurrogateConfig(max_epochs=40, batch_size=256, ensemble_size=1)
    r32 = train_surrogate(smooth_pool, config.model_copy(update={"dtype": "float32"}), seed=0)
    for net in (r32.model.force_net, r32.model.moment_net):
        for p in net.parameters():
            assert p.dtype == torch.float64
            assert torch.equal(p, p.float().double())
    q, qd = np.linspace(0.1, 0.4, 30), np.linspace(-1.0, 1.0, 30)
    assert predict_ensemble(r32.model, q, qd).force.dtype == np.float64
    force = np.concatenate([ds.force for ds in smooth_pool])
    rms = float(np.sqrt(np.mean(np.sum(force**2, axis=1))))
    rmse = r32.metrics.rmse["force"]["test"]
    assert rmse is not None and rmse <= 0.08 * rms, (rmse, rms)
