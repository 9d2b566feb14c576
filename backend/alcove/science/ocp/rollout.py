"""Forward rollouts of the forced discrete Euler-Lagrange (DEL) equations, one compiled call each.

The same discrete mechanics as the transcription (:mod:`.discrete_mechanics`), integrated
forward on the state [q; p]: :func:`simulate` with given torques (tests compare it with
continuous solutions) and :func:`passive_rollout` with joint damping (the passive initial
guess of :mod:`.solve`).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from alcove.science.arrays import FloatArray
from alcove.science.multibody import PlanarChain
from alcove.science.ocp.discrete_mechanics import interval_functions, prepare_contact


def _del_step(chain: PlanarChain, contact: ca.Function | None) -> ca.Function:
    """One step of the forced DEL equations on the state [q; p]: (state, u, h) -> next state.

    Solves p_k + D1 L_d(q_k, q_k+1) + f_k^- = 0 for q_k+1 by Newton's method and returns
    p_k+1 = D2 L_d(q_k, q_k+1) + f_k^+.
    """
    n = chain.ndof
    dynamics, _ = interval_functions(chain, prepare_contact(contact, n))
    qa, qb, u, p_in = (ca.SX.sym(name, n) for name in ("qa", "qb", "u", "p_in"))
    h = ca.SX.sym("h")
    empty = ca.DM.zeros(0, 1)
    residual = ca.Function("residual", [qb, ca.vertcat(qa, u, p_in, h)], [p_in + dynamics(qa, qb, u, h, empty)[0]])
    newton = ca.rootfinder("del_newton", "newton", residual, {"abstol": 1e-13, "max_iter": 50, "error_on_fail": False})
    state, um, hm = ca.MX.sym("state", 2 * n), ca.MX.sym("u", n), ca.MX.sym("h")
    q, p = state[:n], state[n:]
    q_next = newton(q + hm * ca.solve(chain.mass_matrix(q), p), ca.vertcat(q, um, p, hm))
    p_next = dynamics(q, q_next, um, hm, empty)[1]
    return ca.Function("del_step", [state, um, hm], [ca.vertcat(q_next, p_next)], ["state", "u", "h"], ["next"])


def _initial_state(chain: PlanarChain, q0: FloatArray, qd0: FloatArray) -> FloatArray:
    """[q_0; p_0] with the momentum p_0 = M(q_0) qd_0."""
    q0 = np.asarray(q0, float).ravel()
    return np.concatenate([q0, np.asarray(chain.mass_matrix(q0)).dot(np.asarray(qd0, float).ravel())])


def _states_to_nodes(chain: PlanarChain, S: FloatArray) -> tuple[FloatArray, FloatArray]:
    n = chain.ndof
    q, p = S[:, :n], S[:, n:]
    M = np.asarray(chain.mass_matrix.map(q.shape[0])(q.T)).reshape(n, -1, n).transpose(1, 0, 2)
    qd = np.asarray(np.linalg.solve(M, p[..., None])[..., 0], dtype=np.float64)
    return q, qd


def simulate(
    chain: PlanarChain,
    q0: FloatArray | list[float],
    qd0: FloatArray | list[float],
    step: float | FloatArray,
    steps: int | None = None,
    tau: FloatArray | None = None,
    contact: ca.Function | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Integrate the forced discrete Euler-Lagrange equations forward (one compiled call).

    ``step`` is the step h (with ``steps`` the number of steps) or an array of steps;
    ``tau`` (steps, ndof) are the interval torques (default zero). Returns the nodes
    q (steps+1, ndof) and node velocities qd (steps+1, ndof) from the discrete Legendre
    transforms.
    """
    n = chain.ndof
    if np.ndim(step) == 0:
        if steps is None:
            raise ValueError("steps: the number of steps is needed with a single step size")
        hs = np.full(int(steps), float(step))
    else:
        hs = np.asarray(step, float).ravel()
    N = hs.size
    U = np.zeros((N, n)) if tau is None else np.asarray(tau, float).reshape(N, n)
    s0 = _initial_state(chain, np.asarray(q0, float), np.asarray(qd0, float))
    S = _del_step(chain, contact).mapaccum("del_rollout", N)(s0, U.T, hs[None, :])
    return _states_to_nodes(chain, np.vstack([s0, np.asarray(S).T]))


def passive_rollout(
    chain: PlanarChain,
    q0: FloatArray,
    qd0: FloatArray,
    steps: FloatArray,
    damping: FloatArray,
    tau_max: FloatArray,
    contact: ca.Function | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Passive motion with joint damping, tau_k = clip(-damping * qd_k, +-tau_max), by the DEL
    equations in one compiled call. Returns q (N+1, ndof) and the interval torques u (N, ndof)."""
    n = chain.ndof
    step = _del_step(chain, contact)
    state, hm = ca.MX.sym("state", 2 * n), ca.MX.sym("h")
    qd = ca.solve(chain.mass_matrix(state[:n]), state[n:])
    tau = ca.fmin(ca.fmax(-ca.DM(damping) * qd, -ca.DM(tau_max)), ca.DM(tau_max))
    passive = ca.Function("passive_step", [state, hm], [step(state, tau, hm), tau])
    s0 = _initial_state(chain, q0, qd0)
    S, U = passive.mapaccum("passive_rollout", len(steps))(s0, ca.DM(np.asarray(steps, float)).T)
    return np.vstack([s0[:n], np.asarray(S)[:n].T]), np.asarray(U).T


__all__ = ["passive_rollout", "simulate"]
