"""Solve a task: cached transcriptions, initial guesses, bounded retries, the result object.

``solve_task`` is what the campaign engine calls every iteration. The NLP (SX, IPOPT with
exact Hessian) is built once per (task, contact structure) and cached; a contact function
with a third input ``p`` takes its parameters as NLP parameters, so changing them reuses the
solver. A result always records IPOPT's return status, iterations, cost, constraint
violation and wall time; ``converged`` is IPOPT's own success flag and a non-converged
result is returned as such (the caller decides by policy).
"""

from __future__ import annotations

import threading
import time
from collections import OrderedDict
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, TypedDict

import casadi as ca
import numpy as np
from scipy.interpolate import CubicHermiteSpline

from alcove.science.arrays import FloatArray
from alcove.science.geometry import RelativeKinematics
from alcove.science.multibody import PlanarChain
from alcove.science.ocp.contact import ContactHistory
from alcove.science.ocp.dmocc import IpoptResult, OptionValue, Transcription
from alcove.science.ocp.rollout import passive_rollout
from alcove.science.ocp.task_spec import TaskSpec
from alcove.science.series import SeriesFormatError, Trajectory

CACHE_SIZE = 8
CacheKey = tuple[str, str, str, str, str]  # task, contact structure, IPOPT options, graph, path constraint

#: an optional path constraint ``(q, qd[, p]) -> scalar`` and its upper bound, e.g. the trust
#: region ``sigma_F^2 <= max_std^2`` (:func:`alcove.science.surrogate.trust.force_variance_function`)
PathConstraint = tuple[ca.Function, float]


class _ThreadCache(threading.local):
    """IPOPT solver objects are not for concurrent use: one cache of transcriptions per thread."""

    def __init__(self) -> None:
        self.transcriptions: OrderedDict[CacheKey, Transcription] = OrderedDict()


_LOCAL = _ThreadCache()


def _cache() -> OrderedDict[CacheKey, Transcription]:
    return _LOCAL.transcriptions


class AttemptRecord(TypedDict):
    """One IPOPT run of :func:`solve_task`: the initial guess it started from and how it ended."""

    guess: str
    status: str
    success: bool
    iterations: int
    cost: float
    constraint_violation: float
    wall_time_s: float


class OcpSummary(TypedDict):
    """JSON-ready summary of a solution (:meth:`OcpSolution.summary`)."""

    task: str
    status: str
    converged: bool
    iterations: int
    cost: float
    constraint_violation: float
    wall_time_s: float
    intervals: int
    attempts: list[AttemptRecord]
    q_range: list[float]
    max_abs_tau: float


@dataclass
class OcpSolution:
    """Solution on the OCP grid: nodes t (N+1), q, qd (N+1, ndof); interval torques ``controls`` (N, ndof).

    ``tau`` at the nodes is the mean of the torques of the adjacent intervals (the one-sided
    value at the ends), which is what the discrete forces apply at a node.
    """

    t: FloatArray
    q: FloatArray
    qd: FloatArray
    controls: FloatArray
    status: str
    converged: bool
    iterations: int
    cost: float
    constraint_violation: float
    wall_time: float
    chain: PlanarChain
    task_name: str = ""
    attempts: list[AttemptRecord] = field(default_factory=list)
    x: FloatArray | None = None
    lam_x: FloatArray | None = None
    lam_g: FloatArray | None = None

    @property
    def tau(self) -> FloatArray:
        u = self.controls
        return np.concatenate([u[:1], 0.5 * (u[:-1] + u[1:]), u[-1:]])

    @property
    def trajectory(self) -> Trajectory:
        """The solution on its grid, with the contact body's pose (``Trajectory.pose``) from the chain."""
        return Trajectory(self.t, self.q, self.qd, self.tau, model=self.chain.head_pose)

    def resample(self, t_grid: FloatArray) -> Trajectory:
        """The solution on ``t_grid``: cubic Hermite q (with qd its derivative) kept within the
        joint range, linear tau."""
        t_grid = np.asarray(t_grid, float)
        if t_grid.ndim != 1 or t_grid.size == 0:
            raise SeriesFormatError("t", "the resampling grid must be a non-empty 1-D array")
        if t_grid.min() < self.t[0] - 1e-12 or t_grid.max() > self.t[-1] + 1e-12:
            raise SeriesFormatError("t", f"resampling grid leaves the solution's time span [{self.t[0]}, {self.t[-1]}]")
        t_grid = np.clip(t_grid, self.t[0], self.t[-1])
        spline = CubicHermiteSpline(self.t, self.q, self.qd, axis=0)
        tau = np.stack([np.interp(t_grid, self.t, self.tau[:, j]) for j in range(self.q.shape[1])], -1)
        # between nodes that sit on a joint limit the cubic may overshoot it slightly
        q = np.clip(spline(t_grid), self.chain.q_min, self.chain.q_max)
        return Trajectory(t_grid, q, spline.derivative()(t_grid), tau, model=self.chain.head_pose)

    def head_pose(self, t_grid: FloatArray | None = None) -> RelativeKinematics:
        """Pose and velocity of the head relative to the headrest (in H) on the OCP grid or ``t_grid``."""
        tr = self.trajectory if t_grid is None else self.resample(t_grid)
        return self.chain.relative_kinematics(tr.q, tr.qd)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready state (grid, states, torques, multipliers) to warm-start a later solve elsewhere."""
        arrays = {k: getattr(self, k) for k in ("t", "q", "qd", "controls", "x", "lam_x", "lam_g")}
        return {**self.summary(), **{k: None if v is None else np.asarray(v).tolist() for k, v in arrays.items()}}

    @classmethod
    def from_dict(cls, data: dict[str, Any], chain: PlanarChain) -> OcpSolution:
        """Inverse of :meth:`to_dict` (``chain``: the task's chain, e.g. ``task.chain()``)."""

        def optional(key: str) -> FloatArray | None:
            return None if data.get(key) is None else np.asarray(data[key], float)

        return cls(
            t=np.asarray(data["t"], float),
            q=np.asarray(data["q"], float),
            qd=np.asarray(data["qd"], float),
            controls=np.asarray(data["controls"], float),
            status=data["status"],
            converged=data["converged"],
            iterations=data["iterations"],
            cost=data["cost"],
            constraint_violation=data["constraint_violation"],
            wall_time=data["wall_time_s"],
            chain=chain,
            task_name=data.get("task", ""),
            attempts=list(data.get("attempts", [])),
            x=optional("x"),
            lam_x=optional("lam_x"),
            lam_g=optional("lam_g"),
        )

    def summary(self) -> OcpSummary:
        """JSON-ready summary."""
        return {
            "task": self.task_name,
            "status": self.status,
            "converged": bool(self.converged),
            "iterations": int(self.iterations),
            "cost": float(self.cost),
            "constraint_violation": float(self.constraint_violation),
            "wall_time_s": float(self.wall_time),
            "intervals": int(self.controls.shape[0]),
            "attempts": self.attempts,
            "q_range": [float(self.q.min()), float(self.q.max())],
            "max_abs_tau": float(np.abs(self.controls).max()),
        }


_CONTACT_KEYS: OrderedDict[int, tuple[ca.Function, str]] = OrderedDict()  # id -> (function kept alive, key)
_CONTACT_KEYS_LOCK = threading.Lock()


def _contact_key(contact: ca.Function | None) -> str:
    """The contact function's structure as a cache key (its serialization, memoized per object:
    serializing a surrogate takes ~10 ms and a parametric one is passed again every iteration)."""
    if contact is None:
        return "none"
    with _CONTACT_KEYS_LOCK:
        hit = _CONTACT_KEYS.get(id(contact))
    if hit is not None and hit[0] is contact:
        return hit[1]
    try:
        key = contact.serialize()
    except Exception:
        key = f"id:{id(contact)}"
    with _CONTACT_KEYS_LOCK:
        _CONTACT_KEYS[id(contact)] = (contact, key)
        while len(_CONTACT_KEYS) > 4 * CACHE_SIZE:
            _CONTACT_KEYS.popitem(last=False)
    return key


def get_transcription(
    task: TaskSpec,
    contact: ca.Function | None,
    ipopt_options: Mapping[str, OptionValue] | None = None,
    graph: str = "auto",
    path: PathConstraint | None = None,
    exploration: PathConstraint | None = None,
    history: ContactHistory | None = None,
) -> Transcription:
    """The cached transcription for (task, contact structure, options, graph, path constraint,
    exploration term, history states); built on first use.

    The cache holds the last ``CACHE_SIZE`` transcriptions of the calling thread.
    """
    if graph == "auto":
        # with history states the derivatives are CasADi's (no structured blocks): inlined in one SX
        # graph an IPOPT iteration costs about a fifth of the MX graph's (measured on the head-headrest
        # task, K = 5, 200 intervals: 1.4 s against 6.4 s CPU for 25 iterations), for a slower build
        graph = "SX" if history is not None else "MX"
    cache = _cache()
    path_key = "none" if path is None else f"{_contact_key(path[0])}<={float(path[1])!r}"
    if exploration is not None and exploration[1] > 0:
        path_key += f";explore {_contact_key(exploration[0])}*{float(exploration[1])!r}"
    if history is not None:
        path_key += f";history {_contact_key(history.step)} {_contact_key(history.steady)}"
    key = (task.model_dump_json(), _contact_key(contact), repr(sorted((ipopt_options or {}).items())), graph, path_key)
    if key in cache:
        cache.move_to_end(key)
        return cache[key]
    tr = Transcription(
        task.chain(),
        task.discrete_problem(),
        contact,
        dict(ipopt_options or {}),
        graph,
        path=None if path is None else path[0],
        path_upper=np.inf if path is None else float(path[1]),
        exploration=None if exploration is None or exploration[1] <= 0 else (exploration[0], float(exploration[1])),
        history=history,
    )
    cache[key] = tr
    while len(cache) > CACHE_SIZE:
        cache.popitem(last=False)
    return tr


def clear_cache() -> None:
    """Forget the cached transcriptions of the calling thread."""
    _cache().clear()


# ---- initial guesses ------------------------------------------------------------------
def _holding_torque(chain: PlanarChain, q: FloatArray) -> FloatArray:
    """Torque that holds the chain still at the interval midpoints of nodes q (N+1, ndof)."""
    qm = 0.5 * (q[:-1] + q[1:])
    g = np.asarray(chain.gravity_force.map(qm.shape[0])(qm.T)).T
    return -g


def _guess_static(tr: Transcription) -> FloatArray:
    """Hold still at the initial pose (or mid-range when it is free)."""
    lo, hi = tr.unpack(tr.lbx)[0], tr.unpack(tr.ubx)[0]
    start = tr.problem.q_start if tr.problem.q_start is not None else 0.5 * (lo[0] + hi[0])
    q = np.clip(np.broadcast_to(start, lo.shape), lo, hi)
    return tr.pack(q, _holding_torque(tr.chain, q))


PASSIVE_TIME_CONSTANT = 0.05  # s, joint damping c_i = M_ii(q0) / PASSIVE_TIME_CONSTANT


def _guess_passive(tr: Transcription, contact_params: FloatArray | None = None) -> FloatArray:
    """Let the chain move passively from the initial state (gravity, contact, joint damping).

    A dynamically feasible guess: for the head-headrest task the head falls onto the
    headrest and settles there. Cached on the transcription (it depends on nothing else).
    """
    if tr.passive_guess is not None and tr.n_par == 0:
        return tr.passive_guess
    prob, chain = tr.problem, tr.chain
    lo, hi = tr.unpack(tr.lbx)[0], tr.unpack(tr.ubx)[0]
    q0 = prob.q_start if prob.q_start is not None else 0.5 * (lo[0] + hi[0])
    qd0 = prob.qd_start if prob.qd_start is not None else np.zeros(chain.ndof)
    damping = np.diag(np.asarray(chain.mass_matrix(q0))) / PASSIVE_TIME_CONSTANT
    tau_hi = tr.unpack(tr.ubx)[1][0]
    contact = tr.contact
    if contact is not None and (tr.n_par or tr.history is not None):
        # freeze the parameters of a parametric contact model; a model with memory sees the
        # steady history states of each state (the guess only: the NLP carries the recursion)
        if tr.n_par and contact_params is None:
            raise ValueError("contact_params: the contact function takes parameters; pass their values")
        qs, qds = ca.SX.sym("q", chain.ndof), ca.SX.sym("qd", chain.ndof)
        args: list[ca.SX | ca.DM] = [qs, qds]
        if tr.history is not None:
            args.append(tr.history.steady(qs, qds))
        if contact_params is not None and tr.n_par:
            args.append(ca.DM(contact_params))
        contact = ca.Function("contact_frozen", [qs, qds], [contact(*args)])
    q, u = passive_rollout(chain, q0, qd0, prob.steps(), damping, tau_hi, contact)
    if not np.all(np.isfinite(q)):
        return _guess_static(tr)
    x0 = tr.pack(np.clip(q, lo, hi), u)
    tr.passive_guess = x0
    return x0


def _guess_ramp(tr: Transcription) -> FloatArray:
    """Move smoothly toward the upper half of the range during the first phase, then hold."""
    lo, hi = tr.unpack(tr.lbx)[0], tr.unpack(tr.ubx)[0]
    start = tr.problem.q_start if tr.problem.q_start is not None else 0.5 * (lo[0] + hi[0])
    goal = 0.5 * (start + np.where(np.isfinite(hi[-1]), hi[-1], start + 1.0))
    t = tr.t
    t1 = tr.problem.phases[0].duration
    s = np.clip(t / t1, 0, 1)
    s = s * s * (3 - 2 * s)
    q = np.clip(start + s[:, None] * (goal - start), lo, hi)
    return tr.pack(q, _holding_torque(tr.chain, q))


def _guess_from_solution(tr: Transcription, previous: OcpSolution | Trajectory) -> FloatArray:
    """A previous solution or trajectory (any grid, scaled to this horizon) interpolated onto this grid.

    A trajectory without torques gets the torques that hold its poses still.
    """
    t = tr.t
    t0, t1 = previous.t[0], previous.t[-1]
    ts = np.clip(t0 + t * (t1 - t0) / t[-1], t0, t1)
    q = previous.resample(ts).q
    if previous.tau is None:
        return tr.pack(q, _holding_torque(tr.chain, q))
    tm = 0.5 * (ts[:-1] + ts[1:])
    u = np.stack([np.interp(tm, previous.t, previous.tau[:, j]) for j in range(q.shape[1])], -1)
    return tr.pack(q, u)


def initial_guesses(
    tr: Transcription, previous: OcpSolution | Trajectory | None = None, contact_params: FloatArray | None = None
) -> list[tuple[str, Callable[[], FloatArray]]]:
    """Ordered initial guesses, computed on demand: the previous solution when given, then
    passive motion, a ramp, holding still.

    With a path constraint (the trust region) holding still comes right after the previous
    solution: it stays at the start state, so it satisfies a bound the start state satisfies,
    while passive motion falls into the contact where the members disagree most; from that
    infeasible start IPOPT often ends in local infeasibility (measured on the head-headrest
    task with a K = 5 ensemble, bench/figures/ocp.py, with the exact path Hessian: static 73
    iterations to the optimum, passive 32 iterations to "infeasible" and then the ramp 89
    iterations; static with the convexified path Hessian and mu_init 1e-6: 27, docs/ocp.md)."""
    out: list[tuple[str, Callable[[], FloatArray]]] = []
    if previous is not None and previous.q.shape[1] == tr.chain.ndof:
        out.append(("previous", lambda: _guess_from_solution(tr, previous)))
    static = ("static", lambda: _guess_static(tr))
    if tr.path is not None:
        out.append(static)
    out.append(("passive", lambda: _guess_passive(tr, contact_params)))
    out.append(("ramp", lambda: _guess_ramp(tr)))
    if tr.path is None:
        out.append(static)
    return out


def _warm_start_point(
    tr: Transcription, previous: OcpSolution | Trajectory | None
) -> tuple[FloatArray, FloatArray, FloatArray] | None:
    """(x, lam_x, lam_g) of a previous solution of the same NLP shape, to warm-start IPOPT with
    its multipliers; None if there is no such solution."""
    if not isinstance(previous, OcpSolution):
        return None
    x, lam_x, lam_g = previous.x, previous.lam_x, previous.lam_g
    if x is None or lam_x is None or lam_g is None:
        return None
    if x.shape != tr.lbx.shape or lam_g.shape != np.shape(tr.lbg) or not np.allclose(previous.t, tr.t):
        return None
    return x, lam_x, lam_g


# ---- solve ----------------------------------------------------------------------------
def solve_task(
    task: TaskSpec,
    contact: ca.Function | None,
    initial_guess: OcpSolution | Trajectory | None = None,
    *,
    contact_params: FloatArray | None = None,
    max_attempts: int = 3,
    ipopt_options: Mapping[str, OptionValue] | None = None,
    graph: str = "auto",
    on_attempt: Callable[[AttemptRecord], None] | None = None,
    path: PathConstraint | None = None,
    exploration: PathConstraint | None = None,
    history: ContactHistory | None = None,
) -> OcpSolution:
    """Solve ``task`` with the contact model ``contact`` (``None``: no contact).

    Tries the initial guesses in order (previous solution, passive motion, ramp, static hold) until IPOPT
    reports success, at most ``max_attempts`` runs. Returns the converged solution, or the
    attempt with the smallest constraint violation marked ``converged=False``.

    ``initial_guess``: a previous solution (any grid; on the same grid its multipliers
    warm-start IPOPT) or a stored trajectory. ``contact_params``: values of the parameter input of a
    parametric contact function. ``graph``: ``"MX"`` (fast build) or ``"SX"`` (slow build, faster
    iterations; worth it when one task and contact are solved many times); ``"auto"`` (default):
    ``"SX"`` with history states, else ``"MX"``.
    ``ipopt_options`` are merged into the nlpsol options. ``on_attempt`` receives the
    record of every IPOPT run. ``path``: an optional path constraint ``(fn, upper)``,
    ``fn(q, qd[, p]) <= upper`` at every interval midpoint (the trust region). ``exploration``:
    an optional ``(fn, w)``, the cost minus ``w sum_k h_k fn(q_k+1/2, v_k[, p])`` (with the
    ensemble's force variance: a reward for motions where the members disagree; w = 0: none).
    ``history``: the history states of a contact model with memory (its input ``z``; ``path`` and
    ``exploration`` then take ``z`` too), carried by the NLP (:mod:`.dmocc`).
    """
    if max_attempts < 1:
        raise ValueError("max_attempts: must be >= 1")
    t_start = time.perf_counter()
    tr = get_transcription(task, contact, ipopt_options, graph, path, exploration, history)
    if tr.n_par and contact_params is None:
        raise ValueError("contact_params: the contact function takes parameters; pass their values")
    if contact_params is not None:
        contact_params = np.asarray(contact_params, float).ravel()
        if contact_params.size != tr.n_par:
            raise ValueError(
                f"contact_params: the contact function takes {tr.n_par} parameter(s), got {contact_params.size}"
            )
        if not np.all(np.isfinite(contact_params)):
            raise ValueError("contact_params: values must be finite")
    attempts: list[AttemptRecord] = []
    best: tuple[float, IpoptResult, AttemptRecord] | None = None
    for name, make_guess in initial_guesses(tr, initial_guess, contact_params)[:max_attempts]:
        t0 = time.perf_counter()
        lam_x0 = lam_g0 = None
        warm = _warm_start_point(tr, initial_guess) if name == "previous" else None
        if warm is not None:
            x0, lam_x0, lam_g0 = warm
        else:
            x0 = make_guess()
        res = tr.solve(x0, contact_params, lam_x0, lam_g0)
        stats = res["stats"]
        violation = tr.constraint_violation(res["x"], res["g"])
        record: AttemptRecord = {
            "guess": name,
            "status": str(stats["return_status"]),
            "success": bool(stats["success"]),
            "iterations": int(stats["iter_count"]),
            "cost": float(res["cost"]),
            "constraint_violation": violation,
            "wall_time_s": time.perf_counter() - t0,
        }
        attempts.append(record)
        if on_attempt is not None:
            on_attempt(record)
        score = violation if np.isfinite(res["cost"]) else np.inf
        if best is None or record["success"] or score < best[0]:
            best = (score, res, record)
        if record["success"]:
            break
    assert best is not None  # max_attempts >= 1 and there are always at least three guesses
    _, res, record = best
    q, u = tr.unpack(res["x"])
    qd = tr.node_velocities(res["x"], contact_params)
    return OcpSolution(
        t=tr.t,
        q=q,
        qd=qd,
        controls=u,
        status=record["status"],
        converged=record["success"],
        iterations=sum(a["iterations"] for a in attempts),
        cost=record["cost"],
        constraint_violation=record["constraint_violation"],
        wall_time=time.perf_counter() - t_start,
        chain=tr.chain,
        task_name=task.name,
        attempts=attempts,
        x=res["x"],
        lam_x=res["lam_x"],
        lam_g=res["lam_g"],
    )


__all__ = ["OcpSolution", "PathConstraint", "clear_cache", "get_transcription", "initial_guesses", "solve_task"]
