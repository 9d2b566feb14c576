"""The discrete mechanics of one interval: discrete Lagrangian, discrete forces, running cost.

On an interval of step h between the nodes q_a and q_b (midpoint rule)::

    L_d(q_a, q_b) = h L(q_m, v),          q_m = (q_a + q_b) / 2,  v = (q_b - q_a) / h
    f^- = f^+ = h/2 (u - c v + J(q_m)^T w(q_m, v))

with u the interval torque, c the joint dampers (if any) and w the contact wrench; joint
springs are part of L (the chain's potential). :func:`interval_functions` gives the
two sides of the forced discrete Euler-Lagrange equations, ``D1 L_d + f^-`` (= -p_a) and
``D2 L_d + f^+`` (= p_b), and the running cost terms ``h u^T u`` and ``h T(q_m, v)``, as
SX functions that the transcription (:mod:`.dmocc`) and the rollouts (:mod:`.rollout`)
map over the grid.
"""

from __future__ import annotations

import casadi as ca

from alcove.science.multibody import PlanarChain
from alcove.science.ocp.contact import ContactModelError, check_contact_function, history_input_size
from alcove.science.ocp.problem import DiscreteProblem
from alcove.science.symbolic import Symbolic


def contact_parameter_count(contact: ca.Function | None) -> int:
    """Length of the parameter input ``p`` of a contact function (0: none): its last input after
    ``q``, ``qd`` and the history states ``z`` if it has them."""
    if contact is None or contact.n_in() != 3 + (history_input_size(contact) > 0):
        return 0
    return int(contact.size1_in(contact.n_in() - 1))


def interval_functions(chain: PlanarChain, contact: ca.Function | None) -> tuple[ca.Function, ca.Function]:
    """SX functions of one interval: dynamics (qa, qb, u, h, p) -> (-p_k^-, p_k+1^+) and
    cost terms (qa, qb, u, h) -> (h u^T u, h T(q_k+1/2, v_k)). A contact model with history
    states takes them at the interval: dynamics (qa, qb, u, h, z, p)."""
    n = chain.ndof
    qa, qb, u = ca.SX.sym("qa", n), ca.SX.sym("qb", n), ca.SX.sym("u", n)
    h = ca.SX.sym("h")
    n_par = contact_parameter_count(contact)
    par = ca.SX.sym("p", n_par)
    z = ca.SX.sym("z", history_input_size(contact))
    qm, v = 0.5 * (qa + qb), (qb - qa) / h
    Ld = h * chain.lagrangian(qm, v)
    force = u
    damping = chain.damping_force(v)
    if damping is not None:
        force = force + damping
    if contact is not None:
        state = [qm, v, z] if z.numel() else [qm, v]
        wrench = contact(*state, par) if n_par else contact(*state)
        force = force + chain.generalized_contact_force_expr(qm, wrench)
    fd = 0.5 * h * force
    left = ca.gradient(Ld, qa) + fd  # D1 L_d + f^-  = -p_k^-
    right = ca.gradient(Ld, qb) + fd  # D2 L_d + f^+ = p_k+1^+
    kinetic = 0.5 * ca.dot(v, ca.mtimes(chain.mass_matrix(qm), v))
    args, names = [qa, qb, u, h, par], ["qa", "qb", "u", "h", "p"]
    if z.numel():
        args, names = [qa, qb, u, h, z, par], ["qa", "qb", "u", "h", "z", "p"]
    dynamics = ca.Function("interval_dynamics", args, [left, right], names, ["left", "right"])
    cost = ca.Function("interval_cost", args[:4], [h * ca.dot(u, u), h * kinetic], names[:4], ["effort", "kinetic"])
    return dynamics, cost


def with_path(dynamics: ca.Function, path: ca.Function, ndof: int, n_par: int) -> ca.Function:
    """One SX function ``(qa, qb, u, h, p) -> (left, right, path value at the midpoint)``.

    The contact model and a path constraint on the same ensemble (the trust region) evaluate
    the same member networks: building both in one graph and eliminating common
    subexpressions (``ca.cse``) evaluates each member once per interval, not twice.
    """
    qa, qb, u = ca.SX.sym("qa", ndof), ca.SX.sym("qb", ndof), ca.SX.sym("u", ndof)
    h, par = ca.SX.sym("h"), ca.SX.sym("p", n_par)
    left, right = dynamics(qa, qb, u, h, par)
    value = path(0.5 * (qa + qb), (qb - qa) / h, par)
    outs = ca.cse([left, right, value])
    names = ["qa", "qb", "u", "h", "p"]
    return ca.Function("interval_dynamics_path", [qa, qb, u, h, par], outs, names, ["left", "right", "path"])


def node_constraints(
    chain: PlanarChain, prob: DiscreteProblem, Q: Symbolic, left: Symbolic, right: Symbolic
) -> list[Symbolic]:
    """The constraint rows of the grid, in order: the start momentum (if ``qd_start``), the DEL
    equations of the inner nodes, the end momentum (if ``qd_end``); ``left``/``right`` (ndof x N)
    are the interval sides of :func:`interval_functions` mapped over the grid, ``Q`` the nodes."""
    N = prob.intervals
    g = []
    if prob.qd_start is not None:
        g.append(ca.mtimes(chain.mass_matrix(Q[:, 0]), ca.DM(prob.qd_start)) + left[:, 0])
    if N > 1:
        g.append(ca.vec(right[:, :-1] + left[:, 1:]))
    if prob.qd_end is not None:
        g.append(right[:, N - 1] - ca.mtimes(chain.mass_matrix(Q[:, N]), ca.DM(prob.qd_end)))
    return g


def prepare_contact(contact: ca.Function | None, ndof: int) -> ca.Function | None:
    """Check a contact function against the slot, expand it to SX and make sure CasADi can
    take its second derivatives (IPOPT gets exact Hessians); :class:`ContactModelError` if not."""
    if contact is None:
        return None
    check_contact_function(contact, ndof)
    if not contact.is_a("SXFunction"):
        try:
            contact = contact.expand()
        except RuntimeError as exc:
            raise ContactModelError("contact", f"must be expandable to SX (scalar operations only): {exc}") from exc
    q, qd, z = ca.SX.sym("q", ndof), ca.SX.sym("qd", ndof), ca.SX.sym("z", history_input_size(contact))
    history = [z] if z.numel() else []
    parameters = [ca.SX.sym("p", contact_parameter_count(contact))] if contact.n_in() == 3 + len(history) else []
    wrench = contact(q, qd, *history, *parameters)
    try:
        ca.hessian(ca.sum1(wrench), ca.vertcat(q, qd, z))
    except RuntimeError as exc:
        raise ContactModelError("contact", f"must be twice differentiable by CasADi (exact Hessians): {exc}") from exc
    return contact


__all__ = ["contact_parameter_count", "interval_functions", "node_constraints", "prepare_contact", "with_path"]
