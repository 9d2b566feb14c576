"""History states: the recursions against exact solutions, their order of convergence and their
laws (monotone, no drift, causal), numeric = symbolic, and a surrogate that learns a path-dependent
friction law the paper's state features cannot represent."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from alcove.science.geometry import DEFAULT_PRESET as P
from alcove.science.geometry import RelativeKinematics, relative_kinematics
from alcove.science.oracles.aux_penalty import AuxPenaltyParams, aux_penalty_wrench
from alcove.science.press_family import PressFamily, family_motions
from alcove.science.surrogate.artifact import ArtifactError, artifact_dict, model_from_dict
from alcove.science.surrogate.config import SurrogateConfig, SurrogateConfigError
from alcove.science.surrogate.dataset import PoolDataError, PoolDataset
from alcove.science.surrogate.features import N_FEATURES
from alcove.science.surrogate.history import (
    HISTORY_NAMES,
    HistoryConfig,
    HistoryError,
    contact_point_motion,
    contact_point_motion_symbolic,
    history_states,
    history_step,
    history_step_symbolic,
    ramp,
    steady_history,
)
from alcove.science.surrogate.training import predict_ensemble, train_surrogate

CFG = HistoryConfig()


def _translation(x: np.ndarray, z: np.ndarray, vx: np.ndarray, vz: np.ndarray) -> RelativeKinematics:
    """A head that translates without turning: its contact point moves like its origin."""
    n = len(x)
    zeros = np.zeros(n)
    return RelativeKinematics(
        r_rel=np.column_stack([x, zeros, z]),
        v_rel=np.column_stack([vx, zeros, vz]),
        T_rel=np.repeat(np.eye(3)[None], n, axis=0),
        omega_rel=np.zeros((n, 3)),
    )


def _back_x() -> float:
    return P.profile.back_point()[0]


def test_ramp_is_c1_and_lags_by_half_its_width():
    w = 1e-4
    x = np.array([-1.0, 0.0, 0.5 * w, w, 3 * w])
    np.testing.assert_allclose(ramp(x, w), [0.0, 0.0, 0.125 * w, 0.5 * w, 2.5 * w], rtol=0, atol=1e-18)
    # value and slope continuous at both joints (central differences from each side)
    h = 1e-12
    for joint in (0.0, w):
        assert abs(ramp(np.array([joint + h]), w)[0] - ramp(np.array([joint - h]), w)[0]) < 1e-11
        slope_left = (ramp(np.array([joint - h]), w) - ramp(np.array([joint - 2 * h]), w))[0] / h
        slope_right = (ramp(np.array([joint + 2 * h]), w) - ramp(np.array([joint + h]), w))[0] / h
        assert abs(slope_left - slope_right) < 1e-3


def test_max_indentation_follows_the_deepest_point_without_drift():
    """Press to 3 mm, hold, retreat to 1 mm, press again to 4 mm: the state is the running maximum
    (lagging a deepening press by at most half the ramp, catching up while the head holds), never
    above it, and constant while the head is shallower than its deepest point."""
    t = np.linspace(0.0, 1.0, 1001)
    depth = np.interp(t, [0.0, 0.2, 0.4, 0.6, 0.8, 1.0], [0.0, 3e-3, 3e-3, 1e-3, 4e-3, 4e-3])
    x = -depth - _back_x()  # the contact point (origin + back point) is at x = -depth in H
    kin = _translation(x, np.zeros_like(t), np.gradient(x, t), np.zeros_like(t))
    p, _ = contact_point_motion(P, kin)
    np.testing.assert_allclose(p, depth, atol=1e-15)
    z = history_states(P, kin, t, CFG)[:, 0]
    assert np.all(np.diff(z) >= 0), "the largest indentation never decreases"
    running_max = np.maximum.accumulate(depth)
    lag = running_max - z
    assert lag.min() >= 0.0 and lag.max() <= CFG.indentation_ramp / 2 + 1e-12
    assert lag[t == 0.4][0] < 0.01 * CFG.indentation_ramp, "caught up by the end of the hold"
    shallower = (t > 0.4) & (depth < z[t == 0.4][0])  # retreating and re-pressing up to the old depth
    assert shallower.sum() > 200 and np.ptp(z[shallower]) == 0.0, "no drift while the head is shallower"
    assert lag[-1] < 0.01 * CFG.indentation_ramp


def test_slip_filter_converges_to_the_low_pass_solution_with_order_one():
    """tau z' = v - z with v = sin(w t), z(0) = v(0) = 0: exact solution known; implicit Euler's
    error halves with the step."""
    tau, w = CFG.slip_time_constant, 20.0

    def exact(t: np.ndarray) -> np.ndarray:
        a = 1.0 / (1.0 + (w * tau) ** 2)
        return a * (np.sin(w * t) - w * tau * np.cos(w * t) + w * tau * np.exp(-t / tau))

    errors = []
    for n in (201, 401, 801, 1601):
        t = np.linspace(0.0, 0.5, n)
        v = np.sin(w * t)
        kin = _translation(np.full(n, 0.01), np.zeros(n), np.zeros(n), v)  # clear of the headrest, sliding along z
        z = history_states(P, kin, t, CFG)
        np.testing.assert_array_equal(z[:, 1], 0.0)  # no motion along y
        errors.append(np.max(np.abs(z[:, 2] - exact(t))))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    np.testing.assert_allclose(orders, 1.0, atol=0.1)
    assert errors[-1] < 2e-3


def test_the_recursion_is_causal_and_starts_from_the_steady_states():
    motion = family_motions(PressFamily(), 1, 7, (P.theta_min, P.theta_max))[0].trajectory(0.0025)
    kin = relative_kinematics(P, motion.q[:, 0], motion.qd[:, 0])
    z = history_states(P, kin, motion.t, CFG)
    np.testing.assert_array_equal(z[0], steady_history(P, kin, CFG)[0])
    k = len(motion.t) // 2
    head = RelativeKinematics(kin.r_rel[:k], kin.v_rel[:k], kin.T_rel[:k], kin.omega_rel[:k])
    np.testing.assert_array_equal(history_states(P, head, motion.t[:k], CFG), z[:k])


def test_symbolic_step_equals_the_numeric_step():
    rng = np.random.default_rng(0)
    zs, p, v = ca.SX.sym("z", 3), ca.SX.sym("p"), ca.SX.sym("v", 2)
    step = ca.Function("step", [zs, p, v], [history_step_symbolic(zs, p, v, 0.0025, CFG)])
    for gap in (-1e-3, 0.0, 0.3 * CFG.indentation_ramp, 0.9 * CFG.indentation_ramp, 2e-3):  # every ramp branch
        z0 = np.array([2e-3, *rng.normal(size=2)])
        vv = rng.normal(size=2)
        num = history_step(z0[None], np.array([z0[0] + gap]), vv[None], np.array([0.0025]), CFG)[0]
        sym = np.asarray(step(z0, z0[0] + gap, vv)).ravel()
        np.testing.assert_allclose(sym, num, rtol=1e-14, atol=1e-18)
    motion = family_motions(PressFamily(), 1, 3, (P.theta_min, P.theta_max))[0].trajectory(0.005)
    kin = relative_kinematics(P, motion.q[:, 0], motion.qd[:, 0])
    p_num, v_num = contact_point_motion(P, kin)
    r, vr, T, om = ca.SX.sym("r", 3), ca.SX.sym("v", 3), ca.SX.sym("T", 3, 3), ca.SX.sym("w", 3)
    f = ca.Function("cp", [r, vr, T, om], list(contact_point_motion_symbolic(P, r, vr, T, om)))
    for i in range(0, len(motion.t), 25):
        ps, vs = f(kin.r_rel[i], kin.v_rel[i], kin.T_rel[i], kin.omega_rel[i])
        assert float(ps) == pytest.approx(p_num[i], abs=1e-15)
        np.testing.assert_allclose(np.asarray(vs).ravel(), v_num[i], atol=1e-15)


def test_times_must_increase_and_match_the_samples():
    kin = _translation(np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3))
    with pytest.raises(HistoryError) as exc:
        history_states(P, kin, np.array([0.0, 0.1, 0.1]), CFG)
    assert exc.value.field == "t" and "increase strictly" in exc.value.reason
    with pytest.raises(HistoryError) as exc:
        history_states(P, kin, np.array([0.0, 0.1]), CFG)
    assert exc.value.field == "t"


def test_config_fields_are_checked_by_name():
    assert SurrogateConfig.parse({}).features == "paper"
    assert SurrogateConfig.parse({}).input_names == SurrogateConfig.parse({}).input_names[:N_FEATURES]
    with pytest.raises(SurrogateConfigError) as exc:
        SurrogateConfig.parse({"features": "memory"})
    assert exc.value.field == "features"
    with pytest.raises(SurrogateConfigError) as exc:
        SurrogateConfig.parse({"features": "history", "history": {"slip_time_constant": 0}})
    assert exc.value.field == "history.slip_time_constant"


# ------------------------------------------------------------------ a law with memory, learned


def _friction_pool(seeds: list[int], prefix: str) -> list[PoolDataset]:
    """Press-family motions with a known law with memory: the auxiliary law's normal force and a
    friction force fz = -0.4 fx tanh(s / 5 mm/s), s the filtered slip velocity along z: the same
    state gives fz of either sign depending on where the head came from."""
    out = []
    motions = family_motions(PressFamily(), len(seeds), seeds, (P.theta_min, P.theta_max))
    for i, m in enumerate(motions):
        tr = m.trajectory(0.0025)
        kin = relative_kinematics(P, tr.q[:, 0], tr.qd[:, 0])
        force, moment = aux_penalty_wrench(P, AuxPenaltyParams(), kin)
        slip = history_states(P, kin, tr.t, CFG)[:, 2]
        force[:, 2] = -0.4 * force[:, 0] * np.tanh(slip / 5e-3)
        out.append(PoolDataset(f"{prefix}-{i:02d}", tr.t, tr.q, tr.qd, force, moment))
    return out


@pytest.fixture(scope="module")
def friction_models() -> tuple[dict[str, object], list[PoolDataset]]:
    pool, held = _friction_pool(list(range(16)), "train"), _friction_pool(list(range(100, 106)), "held")
    base = {"ensemble_size": 1, "max_epochs": 400, "batch_size": 256, "test_fraction": 0.0}
    models = {
        fs: train_surrogate(pool, SurrogateConfig.parse({**base, "features": fs}), 3, preset=P).model
        for fs in ("paper", "history")
    }
    return models, held


def _fz_rmse(model, held: list[PoolDataset]) -> float:
    err = [predict_ensemble(model, d.q, d.qd, t=d.t).force[:, 2] - d.force[:, 2] for d in held]
    return float(np.sqrt(np.mean(np.concatenate(err) ** 2)))


def test_history_states_let_the_surrogate_learn_friction_with_memory(friction_models):
    """On held-out motions the history model predicts the path-dependent fz at least 3 times
    better than the paper's state features can (they see one state, two signs of fz)."""
    models, held = friction_models
    paper, history = _fz_rmse(models["paper"], held), _fz_rmse(models["history"], held)
    fz_scale = float(np.sqrt(np.mean(np.concatenate([d.force[:, 2] for d in held]) ** 2)))
    assert history < paper / 3, (paper, history, fz_scale)
    assert history < 0.15 * fz_scale


def test_a_history_model_predicts_along_motions_and_round_trips(friction_models):
    models, held = friction_models
    model = models["history"]
    d = held[0]
    with pytest.raises(PoolDataError) as exc:
        predict_ensemble(model, d.q, d.qd)
    assert exc.value.field == "t"
    doc = artifact_dict(model)
    assert doc["feature_names"][N_FEATURES:] == list(HISTORY_NAMES)
    again = model_from_dict(doc)
    np.testing.assert_array_equal(
        predict_ensemble(again, d.q, d.qd, t=d.t).force, predict_ensemble(model, d.q, d.qd, t=d.t).force
    )
    with pytest.raises(ArtifactError) as aexc:
        model_from_dict({**doc, "feature_names": doc["feature_names"][:N_FEATURES]})
    assert aexc.value.field == "feature_names"
    # the paper's model keeps its 19 inputs and needs no times
    paper = models["paper"]
    assert artifact_dict(paper)["feature_names"] == list(SurrogateConfig().input_names)
    assert predict_ensemble(paper, d.q, d.qd).force.shape == (len(d.t), 3)


def test_the_casadi_export_carries_the_state_update_and_the_surrogate(friction_models, tmp_path):
    """Loaded without alcove: iterating ``history_step.casadi`` from the steady first states gives
    the history states of the motion, and ``force.casadi(q, qd, z)`` the model's prediction."""
    from alcove.science.surrogate.artifact import save_artifact

    models, held = friction_models
    model = models["history"]
    root = save_artifact(model, tmp_path / "model", exports=True)
    assert {"history_step.casadi", "force.casadi", "moment.casadi", "force.onnx"} <= {p.name for p in root.iterdir()}
    step = ca.Function.load(str(root / "history_step.casadi"))
    force = ca.Function.load(str(root / "force.casadi"))
    d = held[1]
    kin = relative_kinematics(P, d.q[:, 0], d.qd[:, 0])
    want = history_states(P, kin, d.t, model.config.history)
    z = steady_history(P, kin, model.config.history)[0]
    got = [z]
    for k in range(1, len(d.t)):
        z = np.asarray(step(z, d.q[k, 0], d.qd[k, 0], d.t[k] - d.t[k - 1])).ravel()
        got.append(z)
    np.testing.assert_allclose(np.array(got), want, rtol=1e-12, atol=1e-15)
    pred = predict_ensemble(model, d.q, d.qd, t=d.t).force
    for k in range(0, len(d.t), 40):
        np.testing.assert_allclose(
            np.asarray(force(d.q[k, 0], d.qd[k, 0], want[k])).ravel(), pred[k], rtol=1e-9, atol=1e-9
        )


def test_the_auxiliary_laws_samples_teach_that_it_has_no_memory():
    """Trained on the preliminary data alone (a law without memory, each sample given a random
    history), a history model predicts the same wrench at a state whatever the history fed to it:
    at states in contact, a deepest indentation 2 mm deeper and a slip velocity of the other sign
    change the force by under 10 % of its size (the law's own change is 0)."""
    from alcove.science.surrogate.features import features
    from alcove.science.surrogate.preliminary import preliminary_pool

    pool = preliminary_pool(P, samples=1500, seed=1)
    cfg = SurrogateConfig.parse({"features": "history", "ensemble_size": 1, "max_epochs": 150, "batch_size": 128})
    model = train_surrogate(pool, cfg, 4, preset=P).model
    q = np.linspace(0.36, P.theta_max, 30)
    qd = np.linspace(-0.5, 0.5, 30)
    kin = relative_kinematics(P, q, qd)
    z = steady_history(P, kin, CFG)
    assert np.all(z[:, 0] > 0), "the states press into the headrest"
    other = np.column_stack([z[:, 0] + 2e-3, -z[:, 1:] - 0.05])
    x = features(kin)
    steady = model.predict_ensemble(np.hstack([x, z])).force
    moved = model.predict_ensemble(np.hstack([x, other])).force
    size = np.linalg.norm(steady, axis=1).mean()
    assert size > 20.0
    assert np.linalg.norm(moved - steady, axis=1).mean() < 0.1 * size


def test_the_paper_feature_set_is_the_papers_model_unchanged(smooth_pool):
    """The default takes the 19 features alone, with no history anywhere: its inputs are
    features(kinematics) exactly, in training and in prediction (times given or not), and saying
    'paper' explicitly trains the same weights bit for bit."""
    from alcove.science.surrogate.features import FEATURE_NAMES, features
    from alcove.science.surrogate.training import pool_features, preset_kinematics

    default = SurrogateConfig.parse({"max_epochs": 3, "ensemble_size": 2})
    assert default.features == "paper" and default.input_names == FEATURE_NAMES
    kin = preset_kinematics(P)
    x = pool_features(smooth_pool, kin)
    want = np.concatenate([features(kin(ds.q, ds.qd)) for ds in smooth_pool])
    np.testing.assert_array_equal(x, want)
    a = train_surrogate(smooth_pool, default, 5, preset=P).model
    b = train_surrogate(
        smooth_pool, SurrogateConfig.parse({**default.model_dump(), "features": "paper"}), 5, preset=P
    ).model
    ds = smooth_pool[0]
    for m in (a, b):
        direct = m.predict_ensemble(features(kin(ds.q, ds.qd)))
        np.testing.assert_array_equal(predict_ensemble(m, ds.q, ds.qd).force, direct.force)
        np.testing.assert_array_equal(predict_ensemble(m, ds.q, ds.qd, t=ds.t).force, direct.force)
    for ma, mb in zip(a.members, b.members, strict=True):
        for pa, pb in zip(ma.force_net.parameters(), mb.force_net.parameters(), strict=True):
            assert bool((pa == pb).all())
