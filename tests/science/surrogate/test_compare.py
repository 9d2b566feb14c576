"""paper, gated and history on one pool, scored on held-out motions: the figures are those of their definitions."""

import numpy as np
import pytest
from conftest import make_contact_pool

from alcove.science.geometry import DEFAULT_PRESET as P
from alcove.science.geometry import signed_gap
from alcove.science.surrogate.compare import compare_variants, score_on_suite
from alcove.science.surrogate.config import SurrogateConfig
from alcove.science.surrogate.training import predict_ensemble


def test_the_variants_on_the_same_pool_and_suite(contact_pool):
    suite = make_contact_pool(3, seed=7)  # other motions than the pool's (seed 0)
    cfg = SurrogateConfig(max_epochs=20, batch_size=256, ensemble_size=2)
    scores, models = compare_variants(contact_pool, suite, cfg, seed=3, preset=P)
    assert [(s.variant, s.architecture, s.features) for s in scores] == [
        ("paper", "paper", "paper"),
        ("gated", "gated", "paper"),
        ("history", "paper", "history"),
    ]
    assert models["paper"].config.model_copy(update={"architecture": "gated"}) == models["gated"].config
    assert models["paper"].config.model_copy(update={"features": "history"}) == models["history"].config
    q = np.concatenate([ds.q[:, 0] for ds in suite])
    true = np.vstack([np.hstack([ds.force, ds.moment]) for ds in suite])
    open_ = signed_gap(P, q) >= 0.002
    assert 0 < open_.sum() < q.size
    for s in scores:
        # a history model predicts along each motion (its times); the others at the states
        p = [predict_ensemble(models[s.variant], ds.q, ds.qd, t=ds.t) for ds in suite]
        force = np.vstack([pi.force for pi in p])
        moment = np.vstack([pi.moment for pi in p])
        err = force - true[:, :3]
        assert s.force_rmse == pytest.approx(np.sqrt(np.mean(np.sum(err**2, 1))), rel=1e-12)
        assert s.fz_rmse == pytest.approx(np.sqrt(np.mean(err[:, 2] ** 2)), rel=1e-12)
        assert s.my_rmse == pytest.approx(np.sqrt(np.mean((moment[:, 1] - true[:, 4]) ** 2)), rel=1e-12)
        assert s.ghost_force_max == pytest.approx(np.linalg.norm(force[open_], axis=1).max(), rel=1e-12)
        assert s.oracle_force_open_max == 0.0  # the contact law is zero with the gap open
        assert s.n_open_samples == open_.sum() and s.n_samples == q.size
    gated = scores[1]
    assert gated.ghost_force_max == 0.0 and gated.ghost_moment_max == 0.0 and gated.grid_ghost_force_max == 0.0


def test_an_empty_suite_is_refused(trained_smooth):
    with pytest.raises(ValueError, match=r"^variants: 'memory' not one of paper, gated, history"):
        compare_variants([], [], SurrogateConfig(), 0, P, ["memory"])
    with pytest.raises(ValueError, match=r"^suite: "):
        score_on_suite(trained_smooth.model, [], P)
