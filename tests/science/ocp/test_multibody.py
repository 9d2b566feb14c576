"""The planar chain: Lagrangian terms, kinematics relative to the headrest, the contact Jacobian."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from alcove.science.geometry import DEFAULT_PRESET, HeadNeckPreset, relative_kinematics
from alcove.science.multibody import Headrest, Link, PlanarChain

from .double_pendulum import double_pendulum, textbook_mass_matrix


def three_link_chain() -> PlanarChain:
    links = (Link(4.0, 0.2, 0.05, 0.45), Link(2.5, 0.15, 0.02, 0.3), Link(1.2, 0.1, 0.01, 0.2))
    return PlanarChain(
        links, q_min=(-3,) * 3, q_max=(3,) * 3, torque_limit=(50,) * 3, headrest=Headrest((-0.3, 0.6), 0.2)
    )


def test_preset_chain_gives_the_shared_geometry_exactly():
    rng = np.random.default_rng(0)
    for preset in (
        DEFAULT_PRESET,
        HeadNeckPreset(mass=4.2, com_distance=0.1, inertia_joint=0.08, tilt=0.4, theta_contact=0.28),
    ):
        chain = PlanarChain.from_preset(preset)
        theta = rng.uniform(preset.theta_min, preset.theta_max, 50)
        theta_dot = rng.normal(0, 2, 50)
        ref = relative_kinematics(preset, theta, theta_dot)
        got = chain.relative_kinematics(theta, theta_dot)
        for name in ("r_rel", "v_rel", "T_rel", "omega_rel"):
            np.testing.assert_allclose(getattr(got, name), getattr(ref, name), rtol=0, atol=1e-15, err_msg=name)


def test_preset_mass_matrix_is_the_joint_inertia():
    chain = PlanarChain.from_preset(DEFAULT_PRESET)
    assert float(chain.mass_matrix(0.3)) == pytest.approx(DEFAULT_PRESET.inertia_joint, rel=1e-14)


def test_mass_matrix_symmetric_positive_definite():
    chain = three_link_chain()
    rng = np.random.default_rng(1)
    for q in rng.uniform(-3, 3, (20, 3)):
        M = np.asarray(chain.mass_matrix(q))
        np.testing.assert_allclose(M, M.T, atol=1e-14)
        assert np.linalg.eigvalsh(M).min() > 0


def test_double_pendulum_mass_matrix_matches_textbook_formula():
    chain = double_pendulum()
    for q2 in (-1.0, 0.0, 0.7):
        M = np.asarray(chain.mass_matrix(np.array([0.3, q2])))
        np.testing.assert_allclose(M, textbook_mass_matrix(q2), rtol=1e-13)


def test_gravity_pushes_the_head_toward_the_headrest():
    p = DEFAULT_PRESET
    chain = PlanarChain.from_preset(p)
    theta = np.linspace(p.theta_min, p.theta_max, 9)
    g = np.array([float(chain.gravity_force(t)) for t in theta])
    assert np.all(g > 0)
    np.testing.assert_allclose(g, p.mass * p.gravity * p.com_distance * np.sin(theta), rtol=1e-13)
    assert float(chain.gravity_force(-0.2)) < 0  # tilted forward, gravity pulls forward


def test_contact_jacobian_against_finite_differences():
    chain = three_link_chain()
    rng = np.random.default_rng(2)
    eps = 1e-6
    for q in rng.uniform(-1, 1, (5, 3)):
        J = np.asarray(chain.contact_jacobian(q))
        for j in range(3):
            dq = np.zeros(3)
            dq[j] = eps
            kp, km = chain.relative_kinematics(q + dq, np.zeros(3)), chain.relative_kinematics(q - dq, np.zeros(3))
            np.testing.assert_allclose(J[:3, j], (kp.r_rel[0] - km.r_rel[0]) / (2 * eps), atol=1e-8)
            # omega_y = -d(angle)/dt for a backward tilt
            np.testing.assert_allclose(J[4, j], -(kp.angle[0] - km.angle[0]) / (2 * eps), atol=1e-8)
        assert np.all(J[[1, 3, 5]] == 0)  # planar: no out-of-plane velocity or rotation


def test_generalized_contact_force_is_virtual_power():
    """A force on the head in H: J^T w . qd equals the power F . v + M . omega."""
    chain = three_link_chain()
    rng = np.random.default_rng(3)
    q, qd, w = rng.normal(size=3), rng.normal(size=3), rng.normal(size=6)
    kin = chain.relative_kinematics(q, qd)
    power = w[:3] @ kin.v_rel[0] + w[3:] @ kin.omega_rel[0]
    Q = chain.generalized_contact_force(q, w)[0]
    assert Q @ qd == pytest.approx(power, rel=1e-12)


def test_unforced_dynamics_conserve_energy():
    """M, C and g from one Lagrangian: the ODE conserves energy (checks C against M)."""
    chain = three_link_chain()
    fd = chain.forward_dynamics

    def rhs(_t, x):
        return np.concatenate([x[3:], np.asarray(fd(x[:3], x[3:], np.zeros(3), np.zeros(6))).ravel()])

    x0 = np.array([0.4, -0.3, 0.8, 0.5, 0.0, -1.0])
    sol = solve_ivp(rhs, (0, 1), x0, method="DOP853", rtol=1e-11, atol=1e-12)
    E = [float(chain.energy(x[:3], x[3:])) for x in sol.y.T]
    assert np.ptp(E) < 1e-7 * max(1.0, abs(E[0]))
    assert np.ptp(sol.y[0]) > 0.1  # it actually moved


def test_chain_rejects_inconsistent_definitions():
    with pytest.raises(ValueError, match="q_min"):
        PlanarChain((Link(1, 0.1, 0.01),), (0.5,), (0.2,), (1,))
    with pytest.raises(ValueError, match="torque_limit"):
        PlanarChain((Link(1, 0.1, 0.01),), (0.0,), (0.2,), (1, 2))
    with pytest.raises(ValueError, match="mass"):
        Link(0.0, 0.1, 0.01)
