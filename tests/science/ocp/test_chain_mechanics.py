"""Mechanics of n-joint chains: variational integrator properties, a double pendulum against the
continuous equations, passive joint elements, the contact body's Jacobian and mapped wrench.

Every comparison states its threshold; references are closed forms, tight-tolerance ODE
solutions of independently written equations, or central finite differences.
"""

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from alcove.science.geometry import HeadProfile
from alcove.science.multibody import Headrest, Link, PlanarChain
from alcove.science.ocp.rollout import simulate

from .double_pendulum import G, double_pendulum, textbook_rhs


def offset_chain(**kw) -> PlanarChain:
    """Three links with COG offsets off the link axis, a base tilt, joint springs and the head
    on the middle link with its own origin and tilt: every option of the chain at once."""
    links = (Link(4.0, 0.2, 0.05, 0.45, com_x=0.03), Link(2.5, 0.15, 0.02, 0.3, com_x=-0.02), Link(1.2, 0.1, 0.01))
    defaults = {
        "q_min": (-3,) * 3,
        "q_max": (3,) * 3,
        "torque_limit": (50,) * 3,
        "base": (0.1, -0.2),
        "base_angle": 0.15,
        "headrest": Headrest((-0.3, 0.6), 0.2),
        "stiffness": (5.0, 2.0, 1.0),
        "q_rest": (0.1, -0.2, 0.0),
        "contact_link": 1,
        "contact_origin": (0.04, 0.22),
        "contact_angle": -0.3,
        "profile": HeadProfile(),
    }
    return PlanarChain(links, **{**defaults, **kw})


# ---- variational integrator: energy -----------------------------------------------------
def energy_error(chain: PlanarChain, q0, qd0, h: float, T: float) -> tuple[np.ndarray, float]:
    """|E_k - E_0| at the nodes and the largest kinetic energy on the way (the energy that moves)."""
    N = round(T / h)
    q, qd = simulate(chain, q0, qd0, h, N)
    E = np.asarray(chain.energy.map(N + 1)(q.T, qd.T)).ravel()
    q_sym = ca.SX.sym("q", chain.ndof)
    potential = ca.Function("V", [q_sym], [chain.potential_energy(q_sym)]).map(N + 1)
    kinetic = E - np.asarray(potential(q.T)).ravel()
    return np.abs(E - E[0]), float(kinetic.max())


def test_unforced_chain_energy_stays_bounded_without_drift():
    """The DEL equations of the midpoint discrete Lagrangian are a symplectic integrator: the
    energy error oscillates with an amplitude O(h^2) and does not grow (backward error
    analysis: a modified energy is conserved over exponentially long times).

    Bound stated: over 40 s (4000 steps of 10 ms; the linearised modes are 0.67, 1.6 and 3.0 Hz,
    so 27 to 120 periods) the error stays below 0.2 % of the largest kinetic energy on the way
    (0.08 % measured); its maximum in the last tenth is within 1.5 x that of the first tenth
    (no drift); halving h divides it by 4 +- 1 (second order; 3.9 measured)."""
    chain = offset_chain(base_angle=np.pi)  # hanging from the base, swinging
    q0, qd0 = [0.6, -0.5, 0.8], [0.0, 2.0, -2.0]
    err, scale = energy_error(chain, q0, qd0, 0.01, 40.0)
    assert scale > 1.0
    assert err.max() < 2e-3 * scale, (err.max(), scale)
    tenth = err.size // 10
    assert err[-tenth:].max() < 1.5 * err[:tenth].max(), (err[:tenth].max(), err[-tenth:].max())
    fine, _ = energy_error(chain, q0, qd0, 0.005, 4.0)
    coarse, _ = energy_error(chain, q0, qd0, 0.01, 4.0)
    assert 3.0 < coarse.max() / fine.max() < 5.0, coarse.max() / fine.max()


# ---- double pendulum against the continuous equations ------------------------------------
def test_double_pendulum_converges_to_the_continuous_solution_at_second_order():
    """Hanging double pendulum (q1 near pi) released with a swing: the DEL nodes at T = 1 s
    against solve_ivp (DOP853, rtol = atol = 1e-12) of the hand-written equations; the
    observed order over h = 1/100 .. 1/400 is 2 +- 0.15 and the finest error below 1e-3 rad."""
    q0, qd0, T = np.array([np.pi - 0.6, 0.5]), np.array([0.0, 1.0]), 1.0
    ref = solve_ivp(textbook_rhs, (0, T), [*q0, *qd0], method="DOP853", rtol=1e-12, atol=1e-12).y[:2, -1]
    chain = double_pendulum()
    errors = []
    for N in (100, 200, 400):
        q, _ = simulate(chain, q0, qd0, T / N, N)
        errors.append(np.abs(q[-1] - ref).max())
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(orders - 2.0) < 0.15), orders
    assert errors[-1] < 1e-3


def test_chain_forward_dynamics_match_the_textbook_double_pendulum():
    """The CasADi chain's M, C, g (one Lagrangian) against the hand-written equations, to 1e-12."""
    fd = double_pendulum().forward_dynamics
    rng = np.random.default_rng(4)
    for x in rng.normal(size=(10, 4)):
        got = np.asarray(fd(x[:2], x[2:], np.zeros(2), np.zeros(6))).ravel()
        np.testing.assert_allclose(got, textbook_rhs(0.0, x)[2:], rtol=1e-12, atol=1e-12)


def test_joint_spring_and_damper_give_the_damped_oscillator_at_second_order():
    """One link, no gravity: I qdd = -k (q - q_rest) - c qd, closed form (underdamped); the DEL
    error at T = 2 s has order 2 +- 0.15 over h = 1/50 .. 1/200 (dampers enter as discrete forces)."""
    inertia, k, c, rest = 0.2, 8.0, 0.3, 0.1
    chain = PlanarChain(
        (Link(1.0, 0.0, inertia),), (-9,), (9,), (9,), gravity=0.0, stiffness=(k,), q_rest=(rest,), damping=(c,)
    )
    q0, T = 0.5, 2.0
    zeta, wn = c / (2 * np.sqrt(k * inertia)), np.sqrt(k / inertia)
    wd = wn * np.sqrt(1 - zeta**2)
    a = q0 - rest
    exact = rest + a * np.exp(-zeta * wn * T) * (np.cos(wd * T) + zeta * wn / wd * np.sin(wd * T))
    errors = [abs(simulate(chain, [q0], [0.0], T / N, N)[0][-1, 0] - exact) for N in (100, 200, 400)]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(orders - 2.0) < 0.15), orders


# ---- the contact body: kinematics, Jacobian, mapped wrench ------------------------------------
def test_contact_body_pose_is_the_link_frame_point():
    """The head frame origin is the point contact_origin of link 1's frame and its tilt is
    link 1's plus contact_angle (hand-computed joint chain, 1e-14)."""
    chain = offset_chain()
    q = np.array([0.2, -0.4, 0.3])
    phi0 = 0.15 + q[0]
    phi1 = phi0 + q[1]
    joint1 = np.array([0.1, -0.2]) + 0.45 * np.array([-np.sin(phi0), np.cos(phi0)])
    rot = np.array([[np.cos(phi1), -np.sin(phi1)], [np.sin(phi1), np.cos(phi1)]])
    pos, phi = chain.contact_pose_world(q)
    np.testing.assert_allclose(np.asarray(pos).ravel(), joint1 + rot @ [0.04, 0.22], atol=1e-14)
    assert float(phi) == pytest.approx(phi1 - 0.3, abs=1e-14)
    # the relative pose in H: the world pose seen from the headrest frame
    kin = chain.relative_kinematics(q, np.zeros(3))
    beta = 0.2
    rel = np.array([[np.cos(beta), np.sin(beta)], [-np.sin(beta), np.cos(beta)]]) @ (
        joint1 + rot @ [0.04, 0.22] - [-0.3, 0.6]
    )
    np.testing.assert_allclose(kin.r_rel[0, [0, 2]], rel, atol=1e-14)
    assert kin.angle[0] == pytest.approx(phi1 - 0.3 - beta, abs=1e-14)


@pytest.mark.parametrize("contact_link", [0, 1, 2])
def test_contact_jacobian_and_twist_against_finite_differences(contact_link):
    """J (6 x n) against central differences of the pose in H (step 1e-6, tolerance 1e-8); links
    beyond the contact link do not move the head (zero columns); the twist is J qd."""
    chain = offset_chain(contact_link=contact_link)
    rng = np.random.default_rng(5 + contact_link)
    eps = 1e-6
    for q in rng.uniform(-1, 1, (4, 3)):
        J = np.asarray(chain.contact_jacobian(q))
        for j in range(3):
            dq = np.zeros(3)
            dq[j] = eps
            kp, km = chain.relative_kinematics(q + dq, np.zeros(3)), chain.relative_kinematics(q - dq, np.zeros(3))
            np.testing.assert_allclose(J[:3, j], (kp.r_rel[0] - km.r_rel[0]) / (2 * eps), atol=1e-8)
            np.testing.assert_allclose(J[4, j], -(kp.angle[0] - km.angle[0]) / (2 * eps), atol=1e-8)
        assert np.all(J[:, contact_link + 1 :] == 0)
        qd = rng.normal(size=3)
        kin = chain.relative_kinematics(q, qd)
        np.testing.assert_allclose(np.concatenate([kin.v_rel[0], kin.omega_rel[0]]), J @ qd, atol=1e-13)


def test_mapped_contact_wrench_is_the_virtual_work_of_the_force_and_moment():
    """Q_j = J^T w against central differences of the virtual work F . dr + M_y dphi_y of a
    wrench (force in H at the head origin, moment about it; dphi_y = -d(angle)), step 1e-6, 1e-7."""
    chain = offset_chain()
    rng = np.random.default_rng(9)
    eps = 1e-6
    for q in rng.uniform(-1, 1, (4, 3)):
        w = np.array([rng.normal(), 0.0, rng.normal(), 0.0, rng.normal(), 0.0]) * 50
        Q = chain.generalized_contact_force(q, w)[0]
        for j in range(3):
            dq = np.zeros(3)
            dq[j] = eps
            kp, km = chain.relative_kinematics(q + dq, np.zeros(3)), chain.relative_kinematics(q - dq, np.zeros(3))
            work = w[:3] @ (kp.r_rel[0] - km.r_rel[0]) + w[4] * -(kp.angle[0] - km.angle[0])
            assert Q[j] == pytest.approx(work / (2 * eps), abs=1e-7)


def test_a_contact_force_in_the_del_equations_is_the_mapped_wrench():
    """A constant force pushing the head along x_H in the forced DEL rollout equals applying the
    joint torques J^T w evaluated at the interval midpoints (same nodes to 1e-12) for a
    two-link chain (in the DEL equations both enter as h/2 J(q_m)^T w on each side)."""
    chain = double_pendulum()
    chain = PlanarChain(
        chain.links, chain.q_min, chain.q_max, chain.torque_limit, gravity=G, headrest=Headrest((0.3, 0.4), 0.1)
    )
    w = np.array([5.0, 0, -2.0, 0, 0.3, 0])
    q_s, qd_s = ca.SX.sym("q", 2), ca.SX.sym("qd", 2)
    push = ca.Function("push", [q_s, qd_s], [ca.DM(w)])
    q0, qd0, h, N = [np.pi - 0.4, 0.3], [0.0, 0.0], 0.01, 50
    q_contact, _ = simulate(chain, q0, qd0, h, N, contact=push)
    qm = 0.5 * (q_contact[:-1] + q_contact[1:])
    tau = chain.generalized_contact_force(qm, np.tile(w, (N, 1)))
    q_torque, _ = simulate(chain, q0, qd0, h, N, tau=tau)
    np.testing.assert_allclose(q_torque, q_contact, atol=1e-12)
    assert np.abs(q_contact[-1] - simulate(chain, q0, qd0, h, N)[0][-1]).max() > 1e-3  # the push mattered


def test_head_pose_and_twist_in_the_headrest_frame_along_a_motion():
    """head_pose (x, z, angle, vx, vz, omega in H) of the 3-link chain along a motion: the
    pose agrees with relative_kinematics (1e-14) and the rates with central differences of the
    pose along a smooth cubic q(t) (step 1e-5 s, 1e-7)."""
    chain = offset_chain()
    rng = np.random.default_rng(11)
    a, b, c = rng.normal(size=(3, 3))

    def q_of(t):
        return a + b * t + c * t**3

    def qd_of(t):
        return b + 3 * c * t**2

    for t in (0.1, 0.4, 0.9):
        pose = chain.head_pose(q_of(t), qd_of(t))[0]
        kin = chain.relative_kinematics(q_of(t), qd_of(t))
        np.testing.assert_allclose(pose[:3], [kin.r_rel[0, 0], kin.r_rel[0, 2], kin.angle[0]], atol=1e-14)
        dt = 1e-5
        ahead, behind = chain.head_pose(q_of(t + dt), qd_of(t + dt))[0], chain.head_pose(q_of(t - dt), qd_of(t - dt))[0]
        np.testing.assert_allclose(pose[3:], (ahead[:3] - behind[:3]) / (2 * dt), atol=1e-7)
