"""Preliminary data: Latin hypercube over the task's ranges, aux-penalty forces, usable first model."""

import numpy as np
import pytest

from alcove.science.geometry import DEFAULT_PRESET as P
from alcove.science.geometry import relative_kinematics
from alcove.science.oracles.aux_penalty import AuxPenaltyParams, aux_penalty_wrench
from alcove.science.surrogate.config import SurrogateConfig
from alcove.science.surrogate.dataset import PoolDataError
from alcove.science.surrogate.preliminary import DEFAULT_SAMPLES, preliminary_pool
from alcove.science.surrogate.training import predict_arrays, train_surrogate


def stacked(pool):
    return (np.concatenate([getattr(ds, k) for ds in pool]) for k in ("q", "qd", "force", "moment"))


def test_latin_hypercube_over_the_ranges():
    K, vmax = 200, 1.5
    pool = preliminary_pool(P, samples=K, velocity_bound=vmax, chunks=8)
    assert len(pool) == 8 and all(ds.origin == "preliminary" for ds in pool)
    assert [ds.name for ds in pool][:2] == ["preliminary-00", "preliminary-01"]
    q, qd, force, moment = stacked(pool)
    assert q.shape == (K, 1)
    # one sample in each of the K strata of each variable (the Latin hypercube property)
    strata_q = np.floor((q[:, 0] - P.theta_min) / (P.theta_max - P.theta_min) * K).astype(int)
    strata_v = np.floor((qd[:, 0] + vmax) / (2 * vmax) * K).astype(int)
    assert sorted(strata_q) == list(range(K)) and sorted(strata_v) == list(range(K))
    # forces are the auxiliary penalty model's, recomputed here
    f, m = aux_penalty_wrench(P, AuxPenaltyParams(), relative_kinematics(P, q[:, 0], qd[:, 0]))
    np.testing.assert_array_equal(force, f)
    np.testing.assert_array_equal(moment, m)
    in_contact = force[:, 0] > 0
    assert 0.1 < in_contact.mean() < 0.5 and np.all(q[in_contact, 0] > P.theta_contact)
    one_sided = np.concatenate([ds.qd for ds in preliminary_pool(P, samples=K, velocity_bound=(0.0, 0.5))])
    assert one_sided.min() >= 0.0 and one_sided.max() <= 0.5
    other = preliminary_pool(P, samples=K, seed=1)
    assert not np.array_equal(stacked(other).__next__(), q)


def test_default_samples_give_a_usable_first_model():
    result = train_surrogate(preliminary_pool(P), SurrogateConfig(), seed=0)
    # judged on fresh samples from another hypercube
    q, qd, force, moment = stacked(preliminary_pool(P, samples=2000, seed=99))
    f_pred, m_pred = predict_arrays(result.model, q, qd)
    assert np.sqrt(np.mean((f_pred - force) ** 2)) < 0.03 * np.abs(force).max()
    assert np.sqrt(np.mean((m_pred - moment) ** 2)) < 0.03 * np.abs(moment).max()
    # contact onset: no force well clear of the cushion, a push away from it when pressed in
    f_clear, _ = predict_arrays(result.model, [P.theta0], [0.0])
    f_pressed, _ = predict_arrays(result.model, [P.theta_max - 0.02], [0.0])
    assert abs(f_clear[0, 0]) < 0.02 * np.abs(force).max() and f_pressed[0, 0] > 0.3 * np.abs(force).max()
    assert sum(ds.n_samples for ds in preliminary_pool(P)) == DEFAULT_SAMPLES


@pytest.mark.parametrize(
    "kw, match",
    [
        ({"samples": 1}, "^samples: must be an integer >= 2"),
        ({"velocity_bound": 0.0}, "^velocity_bound: must be a positive number"),
        ({"velocity_bound": (1.0, -1.0)}, "^velocity_bound: must be finite with lower < upper"),
        ({"q_bounds": (0.4, 0.1)}, "^q_bounds: must be finite with lower < upper"),
        ({"samples": 10, "chunks": 6}, r"^chunks: must lie in 1..5"),
    ],
)
def test_bad_arguments(kw, match):
    with pytest.raises(PoolDataError, match=match):
        preliminary_pool(P, **kw)
