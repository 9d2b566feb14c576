"""DMOCC transcription: exact discrete optimum, second order, symplectic energy behaviour."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from alcove.science.multibody import Link, PlanarChain
from alcove.science.ocp.dmocc import Transcription
from alcove.science.ocp.problem import DiscreteProblem, PhaseGrid
from alcove.science.ocp.rollout import simulate

BIG = np.array([1e3])


def double_integrator() -> PlanarChain:
    """A free rotor with unit inertia and no gravity: qdd = u."""
    return PlanarChain((Link(1.0, 0.0, 1.0),), (-1e3,), (1e3,), (1e3,), gravity=0.0)


def rest_to_rest(phases: list[tuple[float, int]]) -> DiscreteProblem:
    grids = tuple(PhaseGrid(d, n, 1.0, 0.0, -BIG, BIG, BIG) for d, n in phases)
    zero = np.zeros(1)
    return DiscreteProblem(grids, q_start=zero, qd_start=zero, q_end=np.ones(1), qd_end=zero)


def solve(chain: PlanarChain, problem: DiscreteProblem, graph: str = "MX"):
    tr = Transcription(chain, problem, graph=graph)
    N = problem.intervals
    res = tr.solve(np.zeros(2 * N + 1))
    assert res["stats"]["success"]
    return tr, res


@pytest.mark.parametrize("N", [10, 20, 40])
@pytest.mark.parametrize("graph", ["MX", "SX"])
def test_rest_to_rest_double_integrator_exact_discrete_optimum(N, graph):
    """min sum h u_k^2, D = 1 in T = 1 at rest at both ends: exactly 12 N^2 / (N^2 - 1)."""
    tr, res = solve(double_integrator(), rest_to_rest([(1.0, N)]), graph)
    assert res["cost"] == pytest.approx(12 * N**2 / (N**2 - 1), rel=1e-10)
    # node velocities from the discrete Legendre transforms vanish at both ends
    qd = tr.node_velocities(res["x"])
    assert abs(qd[0, 0]) < 1e-9 and abs(qd[-1, 0]) < 1e-9
    # and the midpoint velocity peaks at 1.5 D / T like the continuous optimum (to O(h^2))
    assert qd[N // 2, 0] == pytest.approx(1.5, abs=2.0 / N**2)


def test_phase_junction_is_momentum_matching():
    """Splitting one grid into two phases with the same step changes nothing; unequal steps
    still converge to the continuous optimum J* = 12 with momenta continuous."""
    one = solve(double_integrator(), rest_to_rest([(1.0, 20)]))[1]["cost"]
    two = solve(double_integrator(), rest_to_rest([(0.35, 7), (0.65, 13)]))[1]["cost"]
    assert two == pytest.approx(one, rel=1e-12)
    costs = [solve(double_integrator(), rest_to_rest([(0.3, 3 * k), (0.7, 2 * k)]))[1]["cost"] for k in (4, 8, 16)]
    errors = np.abs(np.array(costs) - 12.0)
    assert np.all(np.diff(errors) < 0)
    assert errors[-1] < 0.01


def pendulum() -> PlanarChain:
    return PlanarChain((Link(1.0, 1.0, 0.0, 1.0),), (-10,), (10,), (10,), gravity=9.81)


def pendulum_reference(q0: float, T: float) -> float:
    """Angle at T from a tight-tolerance solve_ivp (qdd = g/l sin q for the backward tilt)."""
    sol = solve_ivp(
        lambda t, x: [x[1], 9.81 * np.sin(x[0])], (0, T), [q0, 0.0], method="DOP853", rtol=1e-13, atol=1e-13
    )
    return float(sol.y[0, -1])


def test_free_pendulum_converges_at_second_order():
    chain, q0, T = pendulum(), np.pi - 1.0, 1.0  # swinging about the hanging position q = pi
    ref = pendulum_reference(q0, T)
    errors = []
    for N in (50, 100, 200):
        q, _ = simulate(chain, [q0], [0.0], T / N, N)
        errors.append(abs(q[-1, 0] - ref))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(orders - 2.0) < 0.15), orders


def test_free_pendulum_energy_does_not_drift():
    """Symplectic: the energy error oscillates but stays bounded over ~150 periods."""
    chain, q0, h, N = pendulum(), np.pi - 1.0, 0.02, 10000
    q, qd = simulate(chain, [q0], [0.0], h, N)
    E = np.array(chain.energy.map(N + 1)(q.T, qd.T)).ravel()
    err = np.abs(E - E[0])
    assert err.max() < 1e-2 * abs(chain.potential_energy([np.pi]) - chain.potential_energy([q0]))
    early, late = err[: N // 10].max(), err[-N // 10 :].max()
    assert late < 1.5 * early  # no secular growth


def test_forced_del_matches_ode_with_constant_torque():
    """The discrete forces h/2 u on both sides: with a constant torque the motion still converges at second order."""
    chain, q0, T, u = pendulum(), np.pi - 0.5, 1.0, 2.0
    sol = solve_ivp(
        lambda t, x: [x[1], 9.81 * np.sin(x[0]) + u], (0, T), [q0, 0.0], method="DOP853", rtol=1e-13, atol=1e-13
    )
    errors = [
        abs(simulate(chain, [q0], [0.0], T / N, N, tau=np.full((N, 1), u))[0][-1, 0] - sol.y[0, -1]) for N in (50, 100)
    ]
    assert np.log2(errors[0] / errors[1]) == pytest.approx(2.0, abs=0.15)


def test_soft_endpoint_cost_has_the_exact_discrete_optimum():
    """Free final pose with E = w (q_N - 1)^2: the problem is linear-quadratic, so the
    rest-to-rest cost of a distance D is c_N D^2 with c_N = 12 N^2 / (N^2 - 1) and the
    optimum is D* = w / (c_N + w), J* = c_N w / (c_N + w)."""
    N, w = 20, 5.0
    grid = (PhaseGrid(1.0, N, 1.0, 0.0, -BIG, BIG, BIG),)
    zero = np.zeros(1)
    prob = DiscreteProblem(grid, zero, zero, q_end=None, qd_end=zero, endpoint_w_q=w, endpoint_q_ref=np.ones(1))
    tr, res = solve(double_integrator(), prob)
    c = 12 * N**2 / (N**2 - 1)
    q, _ = tr.unpack(res["x"])
    assert q[-1, 0] == pytest.approx(w / (c + w), rel=1e-9)
    assert res["cost"] == pytest.approx(c * w / (c + w), rel=1e-9)


def test_phase_target_pose_and_torque_bounds_are_honoured():
    chain = double_integrator()
    zero, one = np.zeros(1), np.ones(1)
    phases = (
        PhaseGrid(0.5, 10, 1.0, 0.0, -BIG, BIG, np.array([7.0]), target_q=np.array([0.8])),
        PhaseGrid(0.5, 10, 1.0, 0.0, -BIG, np.array([1.0]), BIG),
    )
    tr, res = solve(chain, DiscreteProblem(phases, zero, zero, one, zero))
    q, u = tr.unpack(res["x"])
    assert q[10, 0] == pytest.approx(0.8, abs=1e-9)
    assert np.abs(u[:10]).max() <= 7.0 + 1e-8 and np.isclose(
        np.abs(u[:10]).max(), 7.0, atol=1e-6
    )  # the bound is active
    assert q[10:, 0].max() <= 1.0 + 1e-8
    free = solve(chain, rest_to_rest([(0.5, 10), (0.5, 10)]))[1]["cost"]
    assert res["cost"] > free  # constraints cost something
