"""The surrogate on a chain model: preliminary data over the joint box, training, the OCP's
contact function and the trust diagnostics, all from the contact body's pose.

A two-joint chain held straight (second joint at 0) whose head sits where the 1-DOF preset's
does is that preset: fed by its pose, the surrogate gives the 1-DOF path's numbers."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from alcove.science.geometry import DEFAULT_PRESET, kinematics_from_pose, profile_gap, signed_gap
from alcove.science.multibody import Headrest, Link, PlanarChain
from alcove.science.ocp.task_spec import task_preset
from alcove.science.oracles.aux_penalty import AuxPenaltyParams, aux_penalty_wrench
from alcove.science.surrogate.casadi_contact import casadi_contact_function, surrogate_contact
from alcove.science.surrogate.config import SurrogateConfig
from alcove.science.surrogate.dataset import PoolDataError, PoolDataset
from alcove.science.surrogate.preliminary import chain_box, chain_preliminary_pool
from alcove.science.surrogate.training import pose_kinematics, predict_ensemble, train_surrogate
from alcove.science.surrogate.trust import trust_curves

P = DEFAULT_PRESET


def straight_chain() -> PlanarChain:
    o = P.headrest_origin
    return PlanarChain(
        links=(Link(1.0, 0.03, 0.001, 0.06), Link(P.mass, 0.06, P.inertia_com, 0.0)),
        q_min=(P.theta_min, -0.3),
        q_max=(P.theta_max, 0.3),
        torque_limit=(30.0, 30.0),
        headrest=Headrest((float(o[0]), float(o[1])), P.tilt),
        profile=P.profile,
    )


def test_chain_preliminary_data_lie_in_the_box_within_reach_with_the_aux_wrench_of_the_heads_pose():
    model = task_preset("head-headrest-2dof").model
    lo, hi = chain_box(model.q_initial, model.joint_min, model.joint_max)
    np.testing.assert_allclose(lo, [0.032, -0.2])  # q0 = (0.232, 0) +- 0.2 rad
    np.testing.assert_allclose(hi, [0.432, 0.2])
    pose_fn, preset = model.pose_function(), model.oracle_preset()
    pool = chain_preliminary_pool(pose_fn, preset, (lo, hi), samples=600, seed=4, chunks=6)
    q, qd = np.concatenate([d.q for d in pool]), np.concatenate([d.qd for d in pool])
    assert q.shape == (600, 2) and np.all((q >= lo) & (q <= hi)) and np.all(np.abs(qd) <= 2.0)
    pose = pose_fn(q, qd)
    assert profile_gap(preset.profile, pose).min() >= -0.010  # at most 10 mm into the cushion
    force, moment = aux_penalty_wrench(preset, AuxPenaltyParams(), kinematics_from_pose(pose))
    np.testing.assert_array_equal(np.concatenate([d.force for d in pool]), force)
    np.testing.assert_array_equal(np.concatenate([d.moment for d in pool]), moment)
    assert 0.05 < np.mean(force[:, 0] > 0) < 0.6  # the box reaches the cushion and beyond
    with pytest.raises(PoolDataError, match=r"^samples: only \d+ of 400 drawn samples indent the cushion by at most"):
        chain_preliminary_pool(pose_fn, preset, (lo, hi), samples=100, seed=4, chunks=2, max_indentation=-0.05)


@pytest.fixture(scope="module")
def chain_model():
    """A small ensemble trained on the straight chain's aux data (features from its head's pose)."""
    chain = straight_chain()
    pose = chain.head_pose
    pool = chain_preliminary_pool(pose, P, (np.array([0.15, -0.1]), np.array([0.4, 0.1])), samples=800, chunks=8)
    config = SurrogateConfig.parse({"ensemble_size": 2, "max_epochs": 5})
    return chain, train_surrogate(pool, config, seed=1, preset=P, kinematics=pose_kinematics(pose)).model


def test_the_ocp_contact_on_a_chain_is_the_numpy_prediction_from_the_heads_pose(chain_model):
    chain, model = chain_model
    assert model.ndof == 2
    rng = np.random.default_rng(0)
    q = np.stack([rng.uniform(0.2, 0.4, 20), rng.uniform(-0.1, 0.1, 20)], -1)
    qd = rng.uniform(-1, 1, (20, 2))
    pred = predict_ensemble(model, q, qd, kinematics=pose_kinematics(chain.head_pose))
    expected = np.hstack([pred.force, pred.moment])
    fn, p = surrogate_contact(model, P, chain)
    parametric = np.asarray(fn.map(20)(q.T, qd.T, ca.repmat(ca.DM(p), 1, 20))).T
    direct = np.asarray(casadi_contact_function(model, P, chain.relative_kinematics_function).map(20)(q.T, qd.T)).T
    scale = np.abs(expected).max() + 1.0
    np.testing.assert_allclose(parametric, expected, rtol=0, atol=1e-9 * scale)  # float64 nets, round-off only
    np.testing.assert_allclose(direct, expected, rtol=0, atol=1e-9 * scale)


def test_a_saved_chain_surrogate_is_the_contact_of_alcove_ocp_solve(chain_model, tmp_path):
    from alcove.science.ocp.contact import ContactModelError, contact_from_spec
    from alcove.science.surrogate.artifact import save_artifact

    chain, model = chain_model
    save_artifact(model, tmp_path / "m")
    fn = contact_from_spec(f"model:{tmp_path / 'm'}", chain)
    q, qd = np.array([[0.33, 0.02]]), np.array([[0.4, -0.1]])
    pred = predict_ensemble(model, q, qd, kinematics=pose_kinematics(chain.head_pose))
    np.testing.assert_allclose(np.asarray(fn(q.T, qd.T)).ravel(), np.hstack([pred.force, pred.moment])[0], atol=1e-9)
    three = task_preset("head-headrest-2phase").model_dump(mode="json")
    three["model"] = {"preset": "trunk-neck-head-3dof"}
    from alcove.science.ocp.task_spec import parse_task

    with pytest.raises(
        ContactModelError, match=r"^contact: the model was trained on 2 joint\(s\), the task's chain has 3"
    ):
        contact_from_spec(f"model:{tmp_path / 'm'}", parse_task(three).chain())


def test_trust_curves_of_a_straight_chain_are_the_1dof_presets(chain_model):
    chain, model = chain_model
    t = np.linspace(0.0, 1.0, 41)
    theta = 0.232 + 0.15 * np.sin(np.pi * t)
    q2 = np.stack([theta, np.zeros_like(theta)], -1)
    curves = trust_curves(model, P, t, q2, kinematics=pose_kinematics(chain.head_pose))
    mid = 0.5 * (theta[1:] + theta[:-1])
    np.testing.assert_allclose(curves.gap, signed_gap(P, mid), rtol=0, atol=1e-12)
    # the features of the 1-DOF path give the same prediction (the model takes 2 joint columns,
    # so the 1-DOF path's features are fed in directly)
    v = np.diff(theta) / np.diff(t)
    from alcove.science.geometry import relative_kinematics
    from alcove.science.surrogate.features import features

    ref = model.predict_ensemble(features(relative_kinematics(P, mid, v)))
    np.testing.assert_allclose(curves.force, ref.force, rtol=0, atol=1e-9 * (np.abs(ref.force).max() + 1.0))


def test_a_pool_of_two_joints_needs_the_chains_kinematics():
    z2, z3 = np.zeros((3, 2)), np.zeros((3, 3))
    pool = [PoolDataset(f"x{i}", np.arange(3.0), z2, z2, z3, z3) for i in range(4)]
    with pytest.raises(PoolDataError, match=r"^q: the head-neck preset has 1 degree of freedom, got 2"):
        train_surrogate(pool, SurrogateConfig.parse({"ensemble_size": 1}), seed=0)


@pytest.mark.parametrize("name", ["head-neck-2dof", "trunk-neck-head-3dof"])
def test_a_chains_validation_suite_presses_its_head_as_deep_as_the_1dof_suite(name):
    from alcove.science.ocp.task_spec import parse_task
    from alcove.science.validation_suite import (
        SuiteSpec,
        chain_press_trajectory,
        chain_suite_model,
        motion_parameters,
        press_trajectory,
        suite_model_from_dict,
    )

    data = task_preset("head-headrest-2phase").model_dump(mode="json")
    data["model"] = {"preset": name}
    m = parse_task(data).model
    pose, head = m.pose_function(), m.oracle_preset()
    suite = chain_suite_model(m.model_dump(mode="json"), pose, head, m.q_initial, m.joint_min, m.joint_max)
    assert suite_model_from_dict(suite.to_dict()) == suite
    q_c = np.array([suite.q_contact])
    assert abs(profile_gap(head.profile, pose(q_c, np.zeros_like(q_c)))[0]) < 1e-9  # the line's first contact
    spec = SuiteSpec()
    for motion in motion_parameters(spec, suite):
        traj = chain_press_trajectory(motion, spec.dt, suite, pose)
        assert np.all((traj.q >= m.joint_min) & (traj.q <= m.joint_max))
        np.testing.assert_allclose(traj.pose, pose(traj.q, traj.qd), atol=1e-15)
        depth = -profile_gap(head.profile, traj.pose).min()
        ref = -signed_gap(P, press_trajectory(motion, spec.dt).q[:, 0]).min()
        assert ref > 0.002 and depth == pytest.approx(ref, rel=0.1)  # same rate at first contact: within 10 %
