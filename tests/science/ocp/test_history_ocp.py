"""The OCP with a contact surrogate with memory: DMOCC carries the history states as discrete
states at the interval midpoints, their recursion as equality constraints.

Checked as laws: at the optimum the carried states are the recursion of the optimal motion (the
same numbers the prediction along the motion computes, so the wrench the NLP used is the model's
prediction along the solution); the DEL equations hold; the trust region (the ensemble's std,
which then depends on the states too) bounds the solution where it applies; and the model's
paper twin on the same data keeps its NLP without history states (the paper's, unchanged)."""

from __future__ import annotations

import numpy as np
import pytest

from alcove.science.geometry import DEFAULT_PRESET as P
from alcove.science.geometry import relative_kinematics
from alcove.science.ocp.solve import get_transcription, solve_task
from alcove.science.ocp.task_spec import task_preset
from alcove.science.oracles.aux_penalty import AuxPenaltyParams, aux_penalty_wrench
from alcove.science.press_family import PressFamily, family_motions
from alcove.science.surrogate.casadi_contact import surrogate_contact, surrogate_contact_std, surrogate_history
from alcove.science.surrogate.config import SurrogateConfig
from alcove.science.surrogate.dataset import PoolDataset
from alcove.science.surrogate.history import HistoryConfig, history_states
from alcove.science.surrogate.training import predict_ensemble, train_surrogate
from alcove.science.surrogate.trust import force_variance_function, midpoints

pytestmark = pytest.mark.slow


def _pool() -> list[PoolDataset]:
    """Press-family motions with the auxiliary law's normal force and a friction force that
    remembers the slip direction (fz = -0.4 fx tanh(s / 5 mm/s), s the filtered slip velocity)."""
    out = []
    for i, m in enumerate(family_motions(PressFamily(), 12, list(range(12)), (P.theta_min, P.theta_max))):
        tr = m.trajectory(0.0025)
        kin = relative_kinematics(P, tr.q[:, 0], tr.qd[:, 0])
        force, moment = aux_penalty_wrench(P, AuxPenaltyParams(), kin)
        force[:, 2] = -0.4 * force[:, 0] * np.tanh(history_states(P, kin, tr.t, HistoryConfig())[:, 2] / 5e-3)
        out.append(PoolDataset(f"press-{i:02d}", tr.t, tr.q, tr.qd, force, moment))
    return out


@pytest.fixture(scope="module")
def history_model():
    config = {"features": "history", "ensemble_size": 2, "max_epochs": 200, "batch_size": 256}
    return train_surrogate(_pool(), SurrogateConfig.parse(config), 5, preset=P).model


def test_the_carried_states_are_the_recursion_of_the_optimal_motion(history_model):
    task = task_preset("head-headrest-2phase").with_intervals(30)
    fn, params = surrogate_contact(history_model, P)
    history = surrogate_history(history_model, P)
    sol = solve_task(task, fn, contact_params=params, history=history)
    assert sol.converged, sol.status
    assert sol.constraint_violation < 1e-6
    tr = get_transcription(task, fn, history=history)
    N = task.discrete_problem().intervals
    z_nlp = np.asarray(sol.x)[tr.n_q + tr.n_u :].reshape(N, 3)
    # the recursion holds at the optimum: the states are those of the motion's midpoints
    tm, qm, v = midpoints(sol.t, sol.q)
    z_motion = history_states(P, relative_kinematics(P, qm[:, 0], v[:, 0]), tm, history_model.config.history)
    np.testing.assert_allclose(z_nlp, z_motion, rtol=0, atol=1e-7 * max(1.0, np.abs(z_motion).max()))
    assert z_motion[:, 0].max() > 1e-3, "the head presses into the headrest: the largest indentation grows"
    # the OCP's recursion (its CasADi step and steady states) is training's on the same trajectory
    z_ocp = tr.history_states(sol.q)
    assert np.max(np.abs(z_ocp - z_motion) / np.maximum(1.0, np.abs(z_motion))) <= 1e-10
    # the wrench the NLP used at each midpoint is the model's prediction along the motion
    used = np.array([np.asarray(fn(qm[k], v[k], z_nlp[k], params)).ravel() for k in range(N)])
    pred = predict_ensemble(history_model, qm, v, t=tm)
    scale = max(1.0, np.abs(pred.force).max())
    np.testing.assert_allclose(used[:, :3], pred.force, rtol=0, atol=1e-6 * scale)


def test_a_trust_region_bounds_the_ensemble_std_with_the_states(history_model):
    task = task_preset("head-headrest-2phase").with_intervals(24)
    fn, params = surrogate_contact(history_model, P)
    std_fn, _ = surrogate_contact_std(history_model, P)
    history = surrogate_history(history_model, P)
    free = solve_task(task, fn, contact_params=params, history=history)
    tm, qm, v = midpoints(free.t, free.q)
    spread = predict_ensemble(history_model, qm, v, t=tm).force_std
    worst = float(np.sqrt((spread**2).sum(axis=1)).max())
    bound = 0.5 * worst
    sol = solve_task(task, fn, contact_params=params, history=history, path=(force_variance_function(std_fn), bound**2))
    assert sol.converged, sol.status
    tm, qm, v = midpoints(sol.t, sol.q)
    spread = predict_ensemble(history_model, qm, v, t=tm).force_std
    assert float(np.sqrt((spread**2).sum(axis=1)).max()) <= bound * (1 + 1e-5)


def test_a_paper_model_keeps_the_nlp_without_history_states():
    pool = _pool()[:4]
    model = train_surrogate(pool, SurrogateConfig.parse({"ensemble_size": 1, "max_epochs": 5}), 1, preset=P).model
    task = task_preset("head-headrest-2phase").with_intervals(20)
    fn, _ = surrogate_contact(model, P)
    assert surrogate_history(model, P) is None
    tr = get_transcription(task, fn)
    assert tr.n_z == 0 and tr.history is None and tr.derivatives == "structured"
    assert tr.lbx.size == tr.n_q + tr.n_u
    history_config = SurrogateConfig.parse({"features": "history", "ensemble_size": 1, "max_epochs": 5})
    history_fn, history_params = surrogate_contact(train_surrogate(pool, history_config, 1, preset=P).model, P)
    with pytest.raises(ValueError, match="history: the contact function takes 3 history states"):
        solve_task(task, history_fn, contact_params=history_params)  # without the states' step and steady
