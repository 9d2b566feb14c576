"""Structured exact derivatives of the DMOCC NLP: local blocks per interval, assembled once.

Every DEL residual and cost term of interval k depends only on its local variables
``z_k = [q_k; q_k+1; u_k]`` (3 ndof). So the constraint Jacobian is a sum of local blocks
d[left_k; right_k]/dz_k (2 ndof x 3 ndof) and the Hessian of the Lagrangian a sum of local
blocks d^2 L_k/dz_k^2 (3 ndof x 3 ndof) with

    L_k = lam_k . left_k + lam_k+1 . right_k + sigma (w_tau,k effort_k + w_T,k kinetic_k),

lam_k being the multiplier of the constraint at node k (zero where a boundary node has no
constraint). The boundary momenta and the endpoint cost add small blocks on the first and
last interval. The local blocks are SX functions mapped over the grid (one call each) and
scattered into the global sparse matrices with a constant 0/1 matrix. The contact force
depends on z_k only through (q_k+1/2, v_k), so its derivatives are taken in those 2 ndof
directions and mapped back to z_k by the chain rule. One local function gives an interval's
constraint values and its Jacobian block (jac_g's g comes from it: the contact is evaluated once
per call, not once for g and once for J); with a path constraint on the same ensemble (the trust
region's force variance) the contact and the path share the members' evaluations (``ca.cse``:
about 30 % fewer operations per IPOPT iteration on the bench's K = 5 trust region). Compared with
CasADi's automatic jacobian/hessian of the mapped graph (colored directional sweeps) this
evaluates each contact second derivative once per interval: about 2x fewer operations per
IPOPT iteration with a surrogate contact (measured; see bench/figures/ocp.py).
"""

from __future__ import annotations

from collections.abc import Sequence

import casadi as ca
import numpy as np
import scipy.sparse as sps

from alcove.science.arrays import IntArray
from alcove.science.multibody import PlanarChain
from alcove.science.ocp.discrete_mechanics import node_constraints
from alcove.science.ocp.problem import DiscreteProblem
from alcove.science.parallel import grid_map


def _scatter(nrow: int, ncol: int, blocks: Sequence[tuple[ca.MX, IntArray, IntArray]], upper: bool = False) -> ca.MX:
    """Sum of local blocks as one sparse MX matrix.

    Each block set is (values (r x c K) -- K blocks side by side --, rows (K, r), cols (K, c));
    a row index < 0 drops the entry. With ``upper`` only the upper triangle is kept (local
    blocks are symmetric: their upper entries are mapped to (min, max) global indices).
    """
    row_parts: list[IntArray] = []
    col_parts: list[IntArray] = []
    value_parts: list[IntArray] = []
    parts: list[ca.MX] = []
    offset = 0
    for values, rows, cols in blocks:
        K, r = rows.shape
        c = cols.shape[1]
        k, i, j = np.meshgrid(np.arange(K), np.arange(r), np.arange(c), indexing="ij")
        gi, gj = rows[k, i], cols[k, j]
        idx = offset + (k * c + j) * r + i  # column-major position in vec(values)
        keep = gi >= 0
        if upper:
            keep &= i <= j
            gi, gj = np.minimum(gi, gj), np.maximum(gi, gj)
        row_parts.append(gi[keep])
        col_parts.append(gj[keep])
        value_parts.append(idx[keep])
        parts.append(ca.vec(values))
        offset += r * c * K
    grow, gcol, vidx = np.concatenate(row_parts), np.concatenate(col_parts), np.concatenate(value_parts)
    # nonzeros in column-major (CCS) order: sort by the linear index col * nrow + row
    keys = gcol.astype(np.int64) * nrow + grow
    unique_keys, nz = np.unique(keys, return_inverse=True)
    sparsity = ca.Sparsity.triplet(nrow, ncol, (unique_keys % nrow).tolist(), (unique_keys // nrow).tolist())
    A = sps.csc_matrix((np.ones(nz.size), (nz.ravel(), vidx)), shape=(unique_keys.size, offset))
    A_dm = ca.DM(ca.Sparsity(A.shape[0], A.shape[1], A.indptr.tolist(), A.indices.tolist()), A.data.tolist())
    return ca.MX(sparsity, ca.mtimes(A_dm, ca.vertcat(*parts)))


def psd_part_2x2(H: ca.SX) -> ca.SX:
    """The positive semidefinite part (H + |H|) / 2 of a symmetric 2 x 2 matrix, in closed form.

    |H| = sqrt(H^2) and for a 2 x 2 positive semidefinite M, sqrt(M) = (M + sqrt(det M) I) /
    sqrt(tr M + 2 sqrt(det M)); here sqrt(det H^2) = |det H|. A positive semidefinite H is
    returned unchanged (up to rounding), a negative semidefinite one as 0.
    """
    H2 = ca.mtimes(H, H)
    det = ca.fabs(H[0, 0] * H[1, 1] - H[0, 1] * H[1, 0])
    scale = ca.sqrt(H2[0, 0] + H2[1, 1] + 2 * det)
    absolute = (H2 + det * ca.SX.eye(2)) / ca.fmax(scale, 1e-300)
    return 0.5 * (H + absolute)


def structured_derivatives(
    chain: PlanarChain,
    problem: DiscreteProblem,
    mechanics: ca.Function,
    contact: ca.Function | None,
    interval_cost: ca.Function,
    n_par: int,
    x: ca.MX,
    par: ca.MX,
    node_rows: IntArray,
    path: ca.Function | None = None,
    path_hessian: str = "exact",
) -> tuple[ca.Function, ca.Function]:
    """``jac_g(x, p) -> (g, J)`` and ``hess_lag(x, p, lam_f, lam_g) -> triu(H)`` for nlpsol.

    ``mechanics`` are the interval functions without the contact (:func:`.discrete_mechanics.interval_functions`).

    ``node_rows`` (N+1, ndof): the row of g holding the constraint of node k (-1: none).
    ``path`` ``(q, qd, p) -> scalar``: a path constraint at every interval midpoint, the N
    rows of g after the node constraints (:func:`.dmocc.nlp_expressions`); like the contact it
    depends on z_k only through y = (q_k+1/2, v_k), so its gradient and its multiplier-weighted
    Hessian are taken in y and mapped back with T. ``path_hessian="convex"``: the path term's
    Hessian block in y is replaced by its positive semidefinite part (:func:`psd_part_2x2`; for a
    1-DOF chain, where y has 2 entries; exact otherwise): a convexified Hessian of the Lagrangian.
    IPOPT still converges to a KKT point of the exact problem (the gradients and the
    constraint values are exact; only its Newton model changes).
    """
    n, N = chain.ndof, problem.intervals
    n_q = n * (N + 1)
    # ---- local SX functions --------------------------------------------------------
    z = ca.SX.sym("z", 3 * n)
    qa, qb, u = z[:n], z[n : 2 * n], z[2 * n :]
    h, wt, wk, sigma = ca.SX.sym("h"), ca.SX.sym("w_tau"), ca.SX.sym("w_T"), ca.SX.sym("sigma")
    p = ca.SX.sym("p", n_par)
    lam_a, lam_b, lam_e = ca.SX.sym("lam_a", n), ca.SX.sym("lam_b", n), ca.SX.sym("lam_e", n)
    effort, kinetic = interval_cost(qa, qb, u, h)
    # mechanical part (inertia, gravity, torque) differentiated in z directly
    mech_left, mech_right = mechanics(qa, qb, u, h, ca.DM.zeros(0, 1))
    jac_z = ca.jacobian(ca.vertcat(mech_left, mech_right), z)
    lag_mech = ca.dot(lam_a, mech_left) + ca.dot(lam_b, mech_right) + sigma * (wt * effort + wk * kinetic)
    hess_z = ca.hessian(lag_mech, z)[0]
    # the contact force and the path constraint depend on z only through y = (q_k+1/2, v_k):
    # differentiate in the 2 ndof directions of y and map back with the constant-in-z matrix T = dy/dz
    y = ca.SX.sym("y", 2 * n)
    eye, zeros = ca.SX.eye(n), ca.SX.zeros(n, n)
    T = ca.vertcat(ca.horzcat(0.5 * eye, 0.5 * eye, zeros), ca.horzcat(-eye / h, eye / h, zeros))
    y_of_z = ca.vertcat(0.5 * (qa + qb), (qb - qa) / h)
    # the contact force and the path value, their first and second derivatives in y: with the
    # trust region both terms evaluate the same ensemble members, and ca.cse merges the common
    # parts (each member and its derivatives evaluated once per interval, not twice)
    y_terms = []
    if contact is not None:
        wrench = contact(y[:n], y[n:], p) if n_par else contact(y[:n], y[n:])
        y_terms.append(chain.generalized_contact_force_expr(y[:n], wrench))
    if path is not None:
        y_terms.append(path(y[:n], y[n:], p))
    shared = len(y_terms) == 2

    def merged(exprs: list[ca.SX]) -> list[ca.SX]:
        # ca.cse costs build time (~0.1 s per function): only where two terms share members
        return ca.cse(exprs) if shared else exprs

    lam_c, lam_p = ca.SX.sym("lam_c", n), ca.SX.sym("lam_path")
    y_jacs = [ca.jacobian(term, y) for term in y_terms]
    y_hess = []
    if contact is not None:
        y_hess.append(ca.hessian(ca.dot(lam_c, y_terms[0]), y)[0])
    if path is not None:
        y_hess.append(ca.hessian(lam_p * y_terms[-1], y)[0])
    left, right = mech_left, mech_right
    if y_terms:
        at_y = ca.Function("at_y", [y, p], merged(y_terms + y_jacs))
        terms = at_y.call([y_of_z, p])
        if contact is not None:
            fd = 0.5 * h * terms[0]
            left, right = left + fd, right + fd
            df = 0.5 * h * ca.mtimes(terms[len(y_terms)], T)
            jac_z = jac_z + ca.vertcat(df, df)
        if path is not None:
            path_value = terms[len(y_terms) - 1]
            path_grad = ca.mtimes(terms[-1], T)
        lam_c_in = [0.5 * h * (lam_a + lam_b)] if contact is not None else []
        hess_in = [lam_c] if contact is not None else []
        hess_at_y = ca.Function("hess_at_y", [y, p, *hess_in, lam_p], merged(y_hess))
        blocks = hess_at_y.call([y_of_z, p, *lam_c_in, lam_p])
        if contact is not None:
            hess_z = hess_z + ca.mtimes([T.T, blocks[0], T])
        if path is not None:
            path_block = blocks[-1]
            if path_hessian == "convex" and 2 * n == 2:
                path_block = psd_part_2x2(path_block)
            hess_z = hess_z + ca.mtimes([T.T, path_block, T])
    # the interval's constraint values and their Jacobian in one function: jac_g gets g from it too
    local_outputs = [left, right, ca.densify(jac_z)]
    if path is not None:
        local_outputs += [path_value, ca.densify(path_grad)]
    local_jac = ca.Function("local_jac", [z, h, p], local_outputs)
    local_hess = ca.Function("local_hess", [z, h, wt, wk, p, lam_a, lam_b, sigma, lam_p], [ca.densify(hess_z)])

    # boundary momenta (constraint terms) and endpoint cost on the first / last interval
    zero = ca.SX.zeros(n)
    g_first = ca.mtimes(chain.mass_matrix(qa), ca.DM(problem.qd_start)) if problem.qd_start is not None else zero
    g_last = -ca.mtimes(chain.mass_matrix(qb), ca.DM(problem.qd_end)) if problem.qd_end is not None else zero
    endpoint = ca.SX(0)
    if problem.endpoint_w_q > 0 and problem.endpoint_q_ref is not None:
        endpoint = endpoint + problem.endpoint_w_q * ca.sumsqr(qb - ca.DM(problem.endpoint_q_ref))
    if problem.endpoint_w_qd > 0:
        endpoint = endpoint + problem.endpoint_w_qd * ca.sumsqr(ca.solve(chain.mass_matrix(qb), right))
    first_jac = ca.Function("first_jac", [z], [ca.densify(ca.jacobian(g_first, z))])
    last_jac = ca.Function("last_jac", [z], [ca.densify(ca.jacobian(g_last, z))])
    first_hess = ca.Function("first_hess", [z, lam_e], [ca.densify(ca.hessian(ca.dot(lam_e, g_first), z)[0])])
    last_hess = ca.Function(
        "last_hess", [z, h, p, lam_e, sigma], [ca.densify(ca.hessian(ca.dot(lam_e, g_last) + sigma * endpoint, z)[0])]
    )

    # ---- index maps ---------------------------------------------------------------------
    k = np.arange(N)[:, None]
    i = np.arange(n)[None, :]
    z_cols = np.hstack([n * k + i, n * (k + 1) + i, n_q + n * k + i])  # (N, 3n)
    jac_rows = np.hstack([node_rows[:-1], node_rows[1:]])  # left_k -> node k, right_k -> node k+1

    # ---- evaluate on the grid -------------------------------------------------------------
    Q = ca.reshape(x[:n_q], n, N + 1)
    U = ca.reshape(x[n_q:], n, N)
    Z = ca.vertcat(Q[:, :-1], Q[:, 1:], U)
    H = ca.DM(problem.steps()).T
    phase = problem.phase_of_interval()
    W_tau = ca.DM([problem.phases[mm].w_tau for mm in phase]).T
    W_T = ca.DM([problem.phases[mm].w_T for mm in phase]).T
    Pm = ca.repmat(par, 1, N)
    z0, zN = Z[:, 0], Z[:, N - 1]

    local = grid_map(local_jac, N).call([Z, H, Pm])
    left_all, right_all, J_local = local[0], local[1], local[2]
    first_rows = node_rows[:1] if problem.qd_start is not None else -np.ones((1, n), int)
    last_rows = node_rows[-1:] if problem.qd_end is not None else -np.ones((1, n), int)
    jac_blocks = [
        (J_local, jac_rows, z_cols),
        (first_jac(z0), first_rows, z_cols[:1]),
        (last_jac(zN), last_rows, z_cols[-1:]),
    ]
    g_local = node_constraints(chain, problem, Q, left_all, right_all)
    path_row = int(ca.vertcat(*g_local).shape[0])  # the path rows follow the node constraints
    if path is not None:
        jac_blocks.append((local[4], path_row + np.arange(N)[:, None], z_cols))
        g_local.append(ca.vec(local[3]))
    g = ca.vertcat(*g_local)
    m = int(g.shape[0])
    J = _scatter(m, x.shape[0], jac_blocks)
    jac_g = ca.Function("nlp_jac_g", [x, par], [g, J], ["x", "p"], ["g", "jac_g_x"])

    lam_f = ca.MX.sym("lam_f")
    lam_g = ca.MX.sym("lam_g", m)
    # multipliers per node (zero where a node has no constraint)
    padded = ca.vertcat(lam_g, 0)
    node_lam = padded[np.where(node_rows.ravel() >= 0, node_rows.ravel(), m).tolist()]
    LN = ca.reshape(node_lam, n, N + 1)
    lam_path = lam_g[path_row : path_row + N].T if path is not None else ca.MX.zeros(1, N)
    H_local = grid_map(local_hess, N)(Z, H, W_tau, W_T, Pm, LN[:, :-1], LN[:, 1:], ca.repmat(lam_f, 1, N), lam_path)
    hess = _scatter(
        x.shape[0],
        x.shape[0],
        [
            (H_local, z_cols, z_cols),
            (first_hess(z0, LN[:, 0]), z_cols[:1], z_cols[:1]),
            (last_hess(zN, H[N - 1], par, LN[:, N], lam_f), z_cols[-1:], z_cols[-1:]),
        ],
        upper=True,
    )
    hess_lag = ca.Function(
        "nlp_hess_l", [x, par, lam_f, lam_g], [hess], ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"]
    )
    return jac_g, hess_lag


__all__ = ["psd_part_2x2", "structured_derivatives"]
