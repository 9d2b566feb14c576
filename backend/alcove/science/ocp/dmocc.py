"""DMOCC transcription of a multi-phase OCP for a planar chain (Leyendecker et al. 2010).

With joint angles as coordinates a serial chain has no holonomic constraints, so DMOCC
reduces to DMOC (see ``design/dmocc.md``). On each interval k (step h of its phase)::

    L_d(q_k, q_k+1) = h L(q_k+1/2, v_k),          v_k = (q_k+1 - q_k) / h
    f_k^- = f_k^+ = h/2 (u_k + J(q_k+1/2)^T w(q_k+1/2, v_k))

and the NLP unknowns are the nodes q_0..q_N and the interval torques u_0..u_N-1 of all
phases. Constraints::

    start   p_0 + D1 L_d(q_0, q_1) + f_0^- = 0                   (p_0 = M(q_0) qd_0)
    DEL     D2 L_d(q_k-1, q_k) + f_k-1^+ + D1 L_d(q_k, q_k+1) + f_k^- = 0,   k = 1..N-1
    end     -p_N + D2 L_d(q_N-1, q_N) + f_N-1^+ = 0

At a phase junction the DEL equation mixes the steps of both phases: that is momentum
matching. Cost: sum_k h (w_tau u_k^T u_k + w_T T(q_k+1/2, v_k)) + endpoint cost.
Discrete momenta (discrete Legendre transforms) give the node velocities qd_k = M(q_k)^-1 p_k.

A contact model with memory (:class:`.contact.ContactHistory`) adds its history states z_k at the
interval midpoints as unknowns, with the recursion as equality constraints after the DEL rows::

    z_0 = steady(q_1/2, v_0),   z_k = step(z_k-1, q_k+1/2, v_k, (h_k-1 + h_k) / 2),   k = 1..N-1

continuous across phase junctions (one recursion over the whole grid), and the wrench of interval
k is w(q_k+1/2, v_k, z_k). These are the same states a prediction along the solution's midpoints
computes (:mod:`alcove.science.surrogate.history`).

The interval terms (:mod:`.discrete_mechanics`; the contact function is expanded to SX) are
mapped over the grid; IPOPT gets the exact Jacobian and Hessian, assembled from local
interval blocks (:mod:`.derivatives`). The resolved problem is :mod:`.problem`; forward
rollouts of the same equations are :mod:`.rollout`. ``PhaseGrid``, ``DiscreteProblem``,
``simulate`` and ``passive_rollout`` are re-exported here.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Generic, TypeAlias, TypedDict

import casadi as ca
import numpy as np

from alcove.science.arrays import FloatArray, IntArray
from alcove.science.multibody import PlanarChain
from alcove.science.ocp.contact import ContactHistory, history_input_size
from alcove.science.ocp.derivatives import structured_derivatives
from alcove.science.ocp.discrete_mechanics import (
    contact_parameter_count,
    interval_functions,
    node_constraints,
    prepare_contact,
    with_path,
)
from alcove.science.ocp.problem import DiscreteProblem, PhaseGrid
from alcove.science.ocp.rollout import passive_rollout, simulate
from alcove.science.parallel import grid_map
from alcove.science.symbolic import Symbolic

OptionValue: TypeAlias = bool | int | float | str | ca.Function
SolverOptions: TypeAlias = dict[str, OptionValue]

DEFAULT_IPOPT_OPTIONS: SolverOptions = {
    "ipopt.print_level": 0,
    "ipopt.sb": "yes",
    "print_time": False,
    "ipopt.hessian_approximation": "exact",
    "ipopt.max_iter": 500,  # bounds a failing attempt (the stiffest aux variants need ~250)
    "ipopt.tol": 1e-8,
    # the default guess is a dynamically feasible rollout: start with a small barrier
    # parameter (19 instead of 27 iterations on the head-headrest task, measured)
    "ipopt.mu_init": 1e-4,
    # the tasks' costs are small (1e-5 to 3e-4 on head-headrest: the approach's kinetic energy and
    # torque integrals with the paper's weights) beside constraint residuals of 1e-3 to 1e-2, so the
    # filter line search all but ignored the cost and backtracked (restoration phases on a float32-
    # trained K = 5 model). IPOPT's gradient scaling only ever scales down. Scaling the cost by 100
    # leaves the optimum as it is (the same KKT point) and cut the bench's passive-guess solves from
    # 14-36 to 9-17 iterations (6 model pairs, docs/ocp.md); the path-constrained solve keeps 1
    "ipopt.obj_scaling_factor": 100.0,
}


#: with a path constraint (the trust region) the first guess is holding still, feasible but far
#: from the optimum: a smaller barrier parameter than the default's 1e-4 (with the convexified
#: path Hessian: 27 instead of 35 iterations on the bench's K = 5 trust region, 1e-5: 29,
#: 1e-7: 31, 1e-8: 37; docs/ocp.md)
PATH_IPOPT_OPTIONS: SolverOptions = {"ipopt.mu_init": 1e-6, "ipopt.obj_scaling_factor": 1.0}
#: a warm start with a path constraint keeps the unscaled cost as well (the trust region took
#: 27 iterations unscaled, 10x longer with the cost scaled by 10 or 100: docs/ocp.md)
PATH_WARM_OPTIONS: SolverOptions = {"ipopt.obj_scaling_factor": 1.0}


WARM_START_OPTIONS: SolverOptions = {
    "ipopt.warm_start_init_point": "yes",
    "ipopt.mu_init": 1e-6,
    "ipopt.warm_start_bound_push": 1e-9,
    "ipopt.warm_start_bound_frac": 1e-9,
    "ipopt.warm_start_slack_bound_push": 1e-9,
    "ipopt.warm_start_slack_bound_frac": 1e-9,
    "ipopt.warm_start_mult_bound_push": 1e-9,
}


class IpoptResult(TypedDict):
    """One IPOPT run: the point (inside the bounds), cost, constraint values, multipliers and
    IPOPT's statistics (``return_status``, ``success``, ``iter_count``, ...)."""

    x: FloatArray
    cost: float
    g: FloatArray
    lam_x: FloatArray
    lam_g: FloatArray
    stats: dict[str, Any]


@dataclass(frozen=True)
class NlpExpressions(Generic[Symbolic]):
    """The NLP in one graph type: unknowns x, parameters p, cost, constraints g and the node
    momenta (ndof x N+1) for the discrete Legendre transforms."""

    x: Symbolic
    par: Symbolic
    cost: Symbolic
    g: Symbolic
    momenta: Symbolic


def nlp_expressions(
    sym: type[Symbolic],
    chain: PlanarChain,
    prob: DiscreteProblem,
    dynamics: ca.Function,
    interval_cost: ca.Function,
    n_par: int,
    path: ca.Function | None = None,
    exploration: tuple[ca.Function, float] | None = None,
    history: ContactHistory | None = None,
) -> NlpExpressions[Symbolic]:
    """Map the interval functions over the grid and assemble cost and constraints (see the module docstring).

    ``path`` ``(q, qd, p) -> scalar`` is evaluated at every interval midpoint (where the contact
    model is: ``(q_k + q_k+1) / 2``, ``(q_k+1 - q_k) / h``) and appended to g as N rows after
    the dynamics (the caller bounds them). ``exploration`` ``(fn, w)``: the cost rewards ``fn``
    ``(q, qd, p) -> scalar`` (the ensemble's force variance) along the motion,
    ``- w sum_k h_k fn(q_k+1/2, v_k)``. ``history``: the contact's history states, unknowns after
    the torques, their recursion as constraint rows after the dynamics (module docstring); ``path``
    and ``exploration`` then take them as well, ``fn(q, qd, z, p)``."""
    if history is not None:
        return _history_expressions(sym, chain, prob, dynamics, interval_cost, n_par, path, exploration, history)
    n, N = chain.ndof, prob.intervals
    n_q, n_u = n * (N + 1), n * N
    x = sym.sym("x", n_q + n_u)
    par = sym.sym("p", n_par)
    Q = ca.reshape(x[:n_q], n, N + 1)
    U = ca.reshape(x[n_q:], n, N)
    H = ca.DM(prob.steps()).T
    phase = prob.phase_of_interval()
    w_tau = ca.DM([prob.phases[m].w_tau for m in phase]).T
    w_T = ca.DM([prob.phases[m].w_T for m in phase]).T
    Pm = ca.repmat(par, 1, N)
    if path is not None:
        # one graph for the contact and the path constraint: the ensemble's members evaluated once
        left, right, values = grid_map(with_path(dynamics, path, n, n_par), N).call([Q[:, :-1], Q[:, 1:], U, H, Pm])
    else:
        left, right = grid_map(dynamics, N).call([Q[:, :-1], Q[:, 1:], U, H, Pm])
    effort, kinetic = interval_cost.map(N).call([Q[:, :-1], Q[:, 1:], U, H])
    cost = ca.sum2(w_tau * effort) + ca.sum2(w_T * kinetic)
    if exploration is not None and exploration[1] > 0:
        (reward,) = grid_map(_midpoint_function(exploration[0], n, n_par), N).call([Q[:, :-1], Q[:, 1:], H, Pm])
        cost = cost - float(exploration[1]) * ca.sum2(H * reward)
    g = node_constraints(chain, prob, Q, left, right)
    if path is not None:
        g.append(ca.vec(values))

    return _assembled(chain, prob, x, par, cost, g, Q, left, right)


def _assembled(
    chain: PlanarChain,
    prob: DiscreteProblem,
    x: Symbolic,
    par: Symbolic,
    cost: Symbolic,
    g: list[Symbolic],
    Q: Symbolic,
    left: Symbolic,
    right: Symbolic,
) -> NlpExpressions[Symbolic]:
    """The NLP with the endpoint cost added and the node momenta for the Legendre transforms."""
    qN = Q[:, prob.intervals]
    if prob.endpoint_w_q > 0 and prob.endpoint_q_ref is not None:
        cost = cost + prob.endpoint_w_q * ca.sumsqr(qN - ca.DM(prob.endpoint_q_ref))
    if prob.endpoint_w_qd > 0:
        vN = right[:, prob.intervals - 1]  # momentum at the end node
        qdN = ca.solve(chain.mass_matrix(qN), vN)
        cost = cost + prob.endpoint_w_qd * ca.sumsqr(qdN)
    # node momenta for the Legendre transforms: p_0 = -left_0, p_k = right_k-1
    momenta = ca.horzcat(-left[:, 0], right)
    return NlpExpressions(x, par, cost, ca.vertcat(*g), momenta)


def _history_expressions(
    sym: type[Symbolic],
    chain: PlanarChain,
    prob: DiscreteProblem,
    dynamics: ca.Function,
    interval_cost: ca.Function,
    n_par: int,
    path: ca.Function | None,
    exploration: tuple[ca.Function, float] | None,
    history: ContactHistory,
) -> NlpExpressions[Symbolic]:
    """:func:`nlp_expressions` with the contact's history states Z (n_z x N) as unknowns."""
    n, N, n_z = chain.ndof, prob.intervals, history.size
    n_q, n_u = n * (N + 1), n * N
    x = sym.sym("x", n_q + n_u + n_z * N)
    par = sym.sym("p", n_par)
    Q = ca.reshape(x[:n_q], n, N + 1)
    U = ca.reshape(x[n_q : n_q + n_u], n, N)
    Z = ca.reshape(x[n_q + n_u :], n_z, N)
    steps = prob.steps()
    H = ca.DM(steps).T
    phase = prob.phase_of_interval()
    w_tau = ca.DM([prob.phases[m].w_tau for m in phase]).T
    w_T = ca.DM([prob.phases[m].w_T for m in phase]).T
    Pm = ca.repmat(par, 1, N)
    left, right = grid_map(dynamics, N).call([Q[:, :-1], Q[:, 1:], U, H, Z, Pm])
    effort, kinetic = interval_cost.map(N).call([Q[:, :-1], Q[:, 1:], U, H])
    cost = ca.sum2(w_tau * effort) + ca.sum2(w_T * kinetic)
    if exploration is not None and exploration[1] > 0:
        (reward,) = grid_map(_midpoint_history_function(exploration[0], n, n_z, n_par), N).call(
            [Q[:, :-1], Q[:, 1:], H, Z, Pm]
        )
        cost = cost - float(exploration[1]) * ca.sum2(H * reward)
    g = node_constraints(chain, prob, Q, left, right)
    # the recursion: z_0 from the first midpoint, z_k from z_k-1 and the midpoint of interval k
    qa, qb, h = ca.SX.sym("qa", n), ca.SX.sym("qb", n), ca.SX.sym("h")
    z0 = ca.SX.sym("z0", n_z)
    first = ca.Function("history_start", [qa, qb, h, z0], [z0 - history.steady(0.5 * (qa + qb), (qb - qa) / h)])
    g.append(first(Q[:, 0], Q[:, 1], float(steps[0]), Z[:, 0]))
    if N > 1:
        z_prev, z_next, h_prev = ca.SX.sym("z_prev", n_z), ca.SX.sym("z", n_z), ca.SX.sym("h_prev")
        update = history.step(z_prev, 0.5 * (qa + qb), (qb - qa) / h, 0.5 * (h_prev + h))
        residual = ca.Function("history_residual", [qa, qb, h, h_prev, z_prev, z_next], [z_next - update])
        (rows,) = grid_map(residual, N - 1).call([Q[:, 1:-1], Q[:, 2:], H[:, 1:], H[:, :-1], Z[:, :-1], Z[:, 1:]])
        g.append(ca.vec(rows))
    if path is not None:
        (values,) = grid_map(_midpoint_history_function(path, n, n_z, n_par), N).call([Q[:, :-1], Q[:, 1:], H, Z, Pm])
        g.append(ca.vec(values))
    return _assembled(chain, prob, x, par, cost, g, Q, left, right)


def _midpoint_history_function(fn: ca.Function, ndof: int, n_z: int, n_par: int) -> ca.Function:
    """``(qa, qb, h, z, p) -> fn(q_k+1/2, v_k, z, p)`` for a path or exploration function of a
    contact with history states (inputs ``(q, qd, z[, p])``)."""
    if fn.n_out() != 1 or fn.size_out(0) != (1, 1) or history_input_size(fn) != n_z:
        raise ValueError(f"path: expected a function (q, qd, z[, p]) -> scalar with z of {n_z} rows")
    qa, qb, h = ca.SX.sym("qa", ndof), ca.SX.sym("qb", ndof), ca.SX.sym("h")
    z, p = ca.SX.sym("z", n_z), ca.SX.sym("p", n_par)
    args = [0.5 * (qa + qb), (qb - qa) / h, z] + ([p] if fn.n_in() == 4 else [])
    return ca.Function("midpoint_history_value", [qa, qb, h, z, p], [fn(*args)], ["qa", "qb", "h", "z", "p"], ["value"])


def _midpoint_function(fn: ca.Function, ndof: int, n_par: int) -> ca.Function:
    """``(qa, qb, h, p) -> fn(q_k+1/2, v_k, p)``: a midpoint function of the grid (SX)."""
    qa, qb, h, p = ca.SX.sym("qa", ndof), ca.SX.sym("qb", ndof), ca.SX.sym("h"), ca.SX.sym("p", n_par)
    value = _prepare_path(fn, ndof, n_par)(0.5 * (qa + qb), (qb - qa) / h, p)
    return ca.Function("midpoint_value", [qa, qb, h, p], [value], ["qa", "qb", "h", "p"], ["value"])


def _prepare_path(path: ca.Function, ndof: int, n_par: int) -> ca.Function:
    """A path-constraint function as ``(q, qd, p) -> scalar`` (SX), ``p`` the contact's parameters."""
    if path.n_out() != 1 or path.size_out(0) != (1, 1) or path.n_in() not in (2, 3):
        raise ValueError("path: expected a function (q, qd[, p]) -> scalar")
    q, qd, p = ca.SX.sym("q", ndof), ca.SX.sym("qd", ndof), ca.SX.sym("p", n_par)
    if path.n_in() == 3 and path.size1_in(2) != n_par:
        raise ValueError(f"path: its parameter input must match the contact's {n_par} parameter(s)")
    out = path(q, qd, p) if path.n_in() == 3 else path(q, qd)
    return ca.Function("path", [q, qd, p], [out], ["q", "qd", "p"], ["value"])


@dataclass
class Transcription:
    """The NLP of one (chain, problem, contact structure), built once and solved many times.

    The interval terms are SX functions (contact expanded) mapped over the grid. ``graph``
    chooses the outer expression graph: ``"MX"`` keeps the maps (fast to build: use it when
    the contact function changes often) and ``"SX"`` inlines everything (slower to build,
    fastest per IPOPT iteration: use it when one transcription is solved many times).
    ``derivatives``: ``"structured"`` assembles the exact Jacobian and Hessian from local
    interval blocks (:mod:`.derivatives`, MX graph only), ``"casadi"`` lets CasADi derive
    them, ``"auto"`` picks structured for MX.
    """

    chain: PlanarChain
    problem: DiscreteProblem
    contact: ca.Function | None = None
    ipopt_options: SolverOptions = field(default_factory=dict)
    graph: str = "MX"
    derivatives: str = "auto"
    #: optional path constraint ``(q, qd, p) -> scalar <= path_upper`` at every interval midpoint
    #: (e.g. the ensemble's force variance: the trust region); its derivatives are structured too
    path: ca.Function | None = None
    path_upper: float = np.inf
    #: ``"convex"``: the path constraint's Hessian term in IPOPT's Newton model is its positive
    #: semidefinite part (1-DOF chains; :func:`.derivatives.psd_part_2x2`), ``"exact"``: as derived
    path_hessian: str = "convex"
    #: optional exploration term ``(fn, w)``: the cost rewards ``fn`` (the ensemble's force variance)
    #: along the motion (:func:`nlp_expressions`); its derivatives are CasADi's
    exploration: tuple[ca.Function, float] | None = None
    #: the history states of a contact model with memory (its input ``z``): unknowns at the
    #: interval midpoints with their recursion as constraints (module docstring)
    history: ContactHistory | None = None
    #: the passive-motion initial guess (:mod:`.solve`), kept once computed for a contact
    #: without parameters: it depends on nothing but this NLP
    passive_guess: FloatArray | None = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        chain, prob = self.chain, self.problem
        n, N = chain.ndof, prob.intervals
        if N < 1:
            raise ValueError("phases: the problem has no intervals")
        self.contact = prepare_contact(self.contact, n)
        self.n_par = contact_parameter_count(self.contact)
        n_z = history_input_size(self.contact)
        if n_z and (self.history is None or self.history.size != n_z):
            raise ValueError(f"history: the contact function takes {n_z} history states z; pass their step and steady")
        if not n_z:
            self.history = None
        dynamics, interval_cost = interval_functions(chain, self.contact)
        self.n_q, self.n_u, self.n_z = n * (N + 1), n * N, n_z * N
        if self.graph not in ("MX", "SX"):
            raise ValueError(f"graph: must be 'MX' or 'SX', got {self.graph!r}")
        if self.path is not None and self.history is None:
            self.path = _prepare_path(self.path, n, self.n_par)
        exploring = self.exploration is not None and self.exploration[1] > 0
        if self.derivatives == "auto":
            # the structured blocks hold the running cost of the effort and the kinetic energy only, and
            # no history states
            self.derivatives = "structured" if self.graph == "MX" and not exploring and not n_z else "casadi"
        if exploring and self.derivatives == "structured":
            raise ValueError("derivatives: an exploration term needs 'casadi' (the structured blocks do not hold it)")
        if n_z and self.derivatives == "structured":
            raise ValueError("derivatives: history states need 'casadi' (the structured blocks do not hold them)")
        if self.path_hessian not in ("exact", "convex"):
            raise ValueError(f"path_hessian: must be 'exact' or 'convex', got {self.path_hessian!r}")
        if self.derivatives not in ("structured", "casadi"):
            raise ValueError(f"derivatives: must be 'structured' or 'casadi', got {self.derivatives!r}")
        if self.derivatives == "structured" and self.graph != "MX":
            raise ValueError("derivatives: 'structured' needs graph='MX'")
        self._derivative_options: SolverOptions = {}
        self._nlp: dict[str, ca.MX] | dict[str, ca.SX]
        if self.graph == "MX":
            mx = nlp_expressions(
                ca.MX, chain, prob, dynamics, interval_cost, self.n_par, self.path, self.exploration, self.history
            )
            self._nlp = {"x": mx.x, "p": mx.par, "f": mx.cost, "g": mx.g}
            self._momenta = ca.Function("momenta", [mx.x, mx.par], [mx.momenta])
            n_constraints = mx.g.shape[0]
            if self.derivatives == "structured":
                jac_g, hess_lag = structured_derivatives(
                    chain,
                    prob,
                    interval_functions(chain, None)[0],
                    self.contact,
                    interval_cost,
                    self.n_par,
                    mx.x,
                    mx.par,
                    self._constraint_rows(),
                    self.path,
                    self.path_hessian,
                )
                self._derivative_options = {"jac_g": jac_g, "hess_lag": hess_lag}
        else:
            sx = nlp_expressions(
                ca.SX, chain, prob, dynamics, interval_cost, self.n_par, self.path, self.exploration, self.history
            )
            self._nlp = {"x": sx.x, "p": sx.par, "f": sx.cost, "g": sx.g}
            self._momenta = ca.Function("momenta", [sx.x, sx.par], [sx.momenta])
            n_constraints = sx.g.shape[0]
        self.lbx, self.ubx = self._variable_bounds()
        n_path = N if self.path is not None else 0
        self.lbg = np.concatenate([np.zeros(n_constraints - n_path), np.full(n_path, -np.inf)])
        self.ubg = np.concatenate([np.zeros(n_constraints - n_path), np.full(n_path, float(self.path_upper))])
        self._solver: ca.Function | None = None
        self._warm_solver: ca.Function | None = None

    def _constraint_rows(self) -> IntArray:
        """(N+1, ndof): the row of g holding the DEL (or boundary momentum) equation of node k, -1: none."""
        prob, n, N = self.problem, self.chain.ndof, self.problem.intervals
        off = n if prob.qd_start is not None else 0
        node_rows = np.full((N + 1, n), -1, dtype=np.int64)
        if prob.qd_start is not None:
            node_rows[0] = np.arange(n)
        node_rows[1:N] = off + np.arange(n * (N - 1)).reshape(N - 1, n)
        if prob.qd_end is not None:
            node_rows[N] = off + n * (N - 1) + np.arange(n)
        return node_rows

    # ---- bounds and grid ----------------------------------------------------------
    def _variable_bounds(self) -> tuple[FloatArray, FloatArray]:
        prob, n, N = self.problem, self.chain.ndof, self.problem.intervals
        q_lo = np.full((N + 1, n), -np.inf)
        q_hi = np.full((N + 1, n), np.inf)
        u_hi = np.zeros((N, n))
        k = 0
        for ph in prob.phases:
            sl = slice(k, k + ph.intervals + 1)  # nodes of this phase (junctions shared)
            q_lo[sl] = np.maximum(q_lo[sl], ph.q_min)
            q_hi[sl] = np.minimum(q_hi[sl], ph.q_max)
            u_hi[k : k + ph.intervals] = ph.tau_max
            k += ph.intervals
            if ph.target_q is not None:
                q_lo[k] = q_hi[k] = ph.target_q
        if prob.q_start is not None:
            q_lo[0] = q_hi[0] = prob.q_start
        if prob.q_end is not None:
            q_lo[N] = q_hi[N] = prob.q_end
        lbx = np.concatenate([q_lo.ravel(), -u_hi.ravel(), np.full(self.n_z, -np.inf)])
        ubx = np.concatenate([q_hi.ravel(), u_hi.ravel(), np.full(self.n_z, np.inf)])
        return lbx, ubx

    @property
    def t(self) -> FloatArray:
        return self.problem.time_grid()

    # ---- packing ------------------------------------------------------------------
    def pack(self, q: FloatArray, u: FloatArray) -> FloatArray:
        """NLP vector from nodes q (N+1, ndof) and torques u (N, ndof); the history states (if any)
        follow from q by their recursion."""
        q = np.asarray(q, float)
        parts = [q.ravel(), np.asarray(u, float).ravel()]
        if self.history is not None:
            parts.append(self.history_states(q).ravel())
        return np.concatenate(parts)

    def history_states(self, q: FloatArray) -> FloatArray:
        """The history states (N, n_z) of nodes q (N+1, ndof) by their recursion over the midpoints."""
        assert self.history is not None
        h = self.problem.steps()
        qm, v = 0.5 * (q[:-1] + q[1:]), (q[1:] - q[:-1]) / h[:, None]
        z = [np.asarray(self.history.steady(qm[0], v[0]), float).ravel()]
        for k in range(1, len(h)):
            z.append(np.asarray(self.history.step(z[-1], qm[k], v[k], 0.5 * (h[k - 1] + h[k])), float).ravel())
        return np.array(z)

    def unpack(self, x: FloatArray) -> tuple[FloatArray, FloatArray]:
        n, N = self.chain.ndof, self.problem.intervals
        x = np.asarray(x, float).ravel()
        return x[: self.n_q].reshape(N + 1, n), x[self.n_q : self.n_q + self.n_u].reshape(N, n)

    def node_velocities(self, x: FloatArray, par: FloatArray | None = None) -> FloatArray:
        """qd_k = M(q_k)^-1 p_k from the discrete Legendre transforms, (N+1, ndof)."""
        par = np.zeros(self.n_par) if par is None else par
        P = np.asarray(self._momenta(x, par))  # (ndof, N+1)
        q, _ = self.unpack(x)
        M = np.asarray(self.chain.mass_matrix.map(q.shape[0])(q.T)).reshape(self.chain.ndof, -1, self.chain.ndof)
        return np.stack([np.linalg.solve(M[:, k, :], P[:, k]) for k in range(q.shape[0])])

    def constraint_violation(self, x: FloatArray, g: FloatArray) -> float:
        """Largest violation of the constraints and the variable bounds."""
        x, g = np.asarray(x).ravel(), np.asarray(g).ravel()
        parts = [
            np.maximum(self.lbx - x, 0),
            np.maximum(x - self.ubx, 0),
            np.maximum(self.lbg - g, 0),
            np.maximum(g - self.ubg, 0),
        ]
        return float(max((p.max() if p.size else 0.0) for p in parts))

    @property
    def solver(self) -> ca.Function:
        """IPOPT on this NLP (built on first use)."""
        if self._solver is None:
            path_options = PATH_IPOPT_OPTIONS if self.path is not None else {}
            options = {**DEFAULT_IPOPT_OPTIONS, **path_options, **self._derivative_options, **self.ipopt_options}
            self._solver = ca.nlpsol("dmocc", "ipopt", self._nlp, options)
        return self._solver

    @property
    def warm_solver(self) -> ca.Function:
        """The same NLP with IPOPT set up for a warm start from a primal-dual point (built on first use)."""
        if self._warm_solver is None:
            path_options = PATH_WARM_OPTIONS if self.path is not None else {}
            options = {
                **DEFAULT_IPOPT_OPTIONS,
                **WARM_START_OPTIONS,
                **path_options,
                **self._derivative_options,
                **self.ipopt_options,
            }
            self._warm_solver = ca.nlpsol("dmocc_warm", "ipopt", self._nlp, options)
        return self._warm_solver

    def solve(
        self,
        x0: FloatArray,
        par: FloatArray | None = None,
        lam_x0: FloatArray | None = None,
        lam_g0: FloatArray | None = None,
    ) -> IpoptResult:
        """One IPOPT run from ``x0`` (warm-started when multipliers are given): x, cost, g, multipliers, stats."""
        par = np.zeros(self.n_par) if par is None else np.asarray(par, float).ravel()
        x0 = np.clip(np.asarray(x0, float).ravel(), self.lbx, self.ubx)
        args = {"x0": x0, "p": par, "lbx": self.lbx, "ubx": self.ubx, "lbg": self.lbg, "ubg": self.ubg}
        solver = self.solver
        if lam_x0 is not None and lam_g0 is not None:
            solver = self.warm_solver
            args.update(lam_x0=lam_x0, lam_g0=lam_g0)
        res = solver(**args)
        return {
            # IPOPT relaxes bounds by ~1e-8 relative: report the point inside the original bounds
            "x": np.clip(np.asarray(res["x"]).ravel(), self.lbx, self.ubx),
            "cost": float(res["f"]),
            "g": np.asarray(res["g"]).ravel(),
            "lam_x": np.asarray(res["lam_x"]).ravel(),
            "lam_g": np.asarray(res["lam_g"]).ravel(),
            "stats": solver.stats(),
        }


__all__ = ["DEFAULT_IPOPT_OPTIONS", "DiscreteProblem", "PhaseGrid", "Transcription", "passive_rollout", "simulate"]
