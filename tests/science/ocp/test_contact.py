"""Contact models for the OCP: the smooth auxiliary penalty model and the slot contract."""

import casadi as ca
import numpy as np
import pytest

from alcove.science.geometry import DEFAULT_PRESET, relative_kinematics
from alcove.science.multibody import PlanarChain
from alcove.science.ocp.contact import (
    AuxSmoothing,
    ContactModelError,
    aux_contact,
    check_contact_function,
    contact_from_spec,
    no_contact,
)
from alcove.science.oracles.aux_penalty import AuxPenaltyParams, aux_penalty_wrench, contact_point


def wrench(fn, theta, theta_dot):
    return np.array([np.asarray(fn(t, td)).ravel() for t, td in zip(theta, theta_dot, strict=False)])


def literal(theta, theta_dot, params=AuxPenaltyParams()):
    F, M = aux_penalty_wrench(DEFAULT_PRESET, params, relative_kinematics(DEFAULT_PRESET, theta, theta_dot))
    return np.hstack([F, M])


def test_smooth_aux_converges_to_the_paper_model_as_the_widths_vanish():
    theta = np.array([0.33, 0.35, 0.38, 0.40, 0.36])
    theta_dot = np.array([0.0, 0.5, -0.3, 1.0, -2.0])
    ref = literal(theta, theta_dot)
    assert np.all(ref[:, 0] > 1.0)  # all in contact with a clearly positive force
    errors = []
    for width in (2e-3, 1e-3, 2e-4, 5e-5):  # m (penetration); the force ramp gets 1000x in N
        fn = aux_contact(DEFAULT_PRESET, smoothing=AuxSmoothing(penetration_width=width, force_width=1e3 * width))
        errors.append(np.abs(wrench(fn, theta, theta_dot) - ref).max())
    assert errors[-1] < 1e-3 * np.abs(ref).max()
    assert np.all(np.diff(errors) < 0), errors


def test_smooth_aux_is_zero_away_from_the_headrest_and_pushes_the_head_out():
    fn = aux_contact(DEFAULT_PRESET)
    far = wrench(fn, [0.05, 0.2, 0.25], [1.0, -1.0, 0.0])
    np.testing.assert_allclose(far, 0.0, atol=1e-12)
    near = wrench(fn, np.linspace(0.33, 0.43, 6), np.zeros(6))
    assert np.all(near[:, 0] > 0) and np.all(np.diff(near[:, 0]) > 0)  # fx > 0, growing with penetration
    np.testing.assert_array_equal(near[:, [1, 2, 3, 5]], 0.0)  # force along the normal, moment about y


def test_moment_is_r_sp_cross_force():
    fn = aux_contact(DEFAULT_PRESET)
    theta = np.array([0.37])
    w = wrench(fn, theta, [0.0])[0]
    arm = relative_kinematics(DEFAULT_PRESET, theta, [0.0]).T_rel[0] @ contact_point(DEFAULT_PRESET, AuxPenaltyParams())
    np.testing.assert_allclose(w[3:], np.cross(arm, w[:3]), rtol=1e-12)


def test_contact_carries_the_head_at_a_resting_angle():
    """Static equilibrium on the headrest: J^T w + g = 0 at some theta in the range."""
    chain = PlanarChain.from_preset(DEFAULT_PRESET)
    fn = aux_contact(DEFAULT_PRESET)
    theta = np.linspace(0.30, 0.43, 200)
    net = np.array(
        [float(chain.gravity_force(t)) + float(ca.mtimes(chain.contact_jacobian(t).T, fn(t, 0))) for t in theta]
    )
    assert net[0] > 0 and net[-1] < 0  # gravity wins before contact, the cushion wins deep in it
    rest = theta[np.argmin(np.abs(net))]
    assert DEFAULT_PRESET.theta_contact < rest < DEFAULT_PRESET.theta_max


def test_slot_checks_name_the_problem():
    check_contact_function(no_contact(1), 1)
    q2, qd2, q1, qd1 = ca.SX.sym("q", 2), ca.SX.sym("qd", 2), ca.SX.sym("q"), ca.SX.sym("qd")
    with pytest.raises(ContactModelError, match=r"contact.q"):
        check_contact_function(ca.Function("f", [q2, qd2], [ca.SX.zeros(6)]), 1)
    with pytest.raises(ContactModelError, match=r"contact.wrench"):
        check_contact_function(ca.Function("f", [q1, qd1], [ca.SX.zeros(3)]), 1)
    with pytest.raises(ContactModelError, match=r"^contact: expected inputs"):
        check_contact_function(ca.Function("f", [q1], [ca.SX.zeros(6)]), 1)
    with pytest.raises(ContactModelError, match=r"^contact: unknown contact model"):
        contact_from_spec("bogus", DEFAULT_PRESET)
    with pytest.raises(ContactModelError, match="does not exist"):
        contact_from_spec("model:/nonexistent/surrogate.json", DEFAULT_PRESET)
    assert contact_from_spec("none", DEFAULT_PRESET) is None


class _OpaqueContact(ca.Callback):
    """A contact computed in Python: CasADi cannot see (or differentiate) inside it."""

    def __init__(self):
        ca.Callback.__init__(self)
        self.construct("opaque", {})

    def get_n_in(self):
        return 2

    def get_n_out(self):
        return 1

    def get_sparsity_out(self, i):
        return ca.Sparsity.dense(6, 1)

    def eval(self, arg):
        return [ca.DM.zeros(6, 1)]


def test_a_contact_without_symbolic_derivatives_is_rejected_clearly():
    from alcove.science.ocp.solve import solve_task
    from alcove.science.ocp.task_spec import task_preset

    opaque = _OpaqueContact()
    q, qd = ca.MX.sym("q"), ca.MX.sym("qd")
    wrapped = ca.Function("wrapped", [q, qd], [opaque(q, qd)])
    with pytest.raises(ContactModelError, match=r"^contact: must be twice differentiable"):
        solve_task(task_preset("head-headrest-2phase").with_intervals(5), wrapped)
