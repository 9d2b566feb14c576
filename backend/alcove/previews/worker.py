"""The worker side of editor previews: claim the row with a conditional update (a duplicate
delivery does nothing), compute outside any transaction (a task solved once with the
auxiliary contact, or an oracle replaying the reference head motion; the science is
imported lazily), record the result or the error."""

from __future__ import annotations

import logging
import math
import time
from typing import Any

import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove.errors import InvalidInput, NotFound
from alcove.models import Preview, PreviewKind, PreviewStatus, utcnow
from alcove.previews.service import PREVIEW_IPOPT_MAX_ITER, STALE_AFTER, grid_summary, preview_grid
from alcove.science.oracles.builtin import BUILTIN_TYPE_NAMES

log = logging.getLogger(__name__)


def claim(session: Session, preview_id: int, worker_name: str) -> int | None:
    """Take the row (pending, or running but stale); returns the attempt number or None."""
    now = utcnow()
    res = session.execute(
        sa.update(Preview)
        .where(
            Preview.id == preview_id,
            sa.or_(
                Preview.status == PreviewStatus.pending.value,
                sa.and_(Preview.status == PreviewStatus.running.value, Preview.started_at < now - STALE_AFTER),
            ),
        )
        .values(
            status=PreviewStatus.running.value, started_at=now, worker_name=worker_name, attempts=Preview.attempts + 1
        )
        .returning(Preview.attempts)
    ).first()
    return None if res is None else int(res[0])


def run_preview(preview_id: int, worker_name: str) -> str:
    """The worker's job: claim, compute, record. Returns the final status (or ``skipped``)."""
    from alcove.db import run_transaction

    attempt = run_transaction(lambda s: claim(s, preview_id, worker_name))
    if attempt is None:
        return "skipped"  # a duplicate delivery, or already done
    row = run_transaction(lambda s: _snapshot(s, preview_id))
    try:
        result = compute(row["kind"], row["spec"], row["options"], row["catalogue"])
        status, error = PreviewStatus.succeeded.value, None
    except Exception as err:
        log.info("preview %d failed: %s", preview_id, err, exc_info=not isinstance(err, ValueError))
        result, status, error = None, PreviewStatus.failed.value, _error_text(err)

    def record(s: Session) -> None:
        s.execute(
            sa.update(Preview)
            .where(Preview.id == preview_id, Preview.status == PreviewStatus.running.value, Preview.attempts == attempt)
            .values(status=status, result=result, error=error, finished_at=utcnow())
        )

    run_transaction(record)
    return status


def _error_text(err: BaseException) -> str:
    field = getattr(err, "field", None)
    reason = getattr(err, "reason", None)
    if field and reason:
        return f"{field}: {reason}"
    return f"{type(err).__name__}: {err}"[:2000]


def _snapshot(s: Session, preview_id: int) -> dict[str, Any]:
    row = s.get(Preview, preview_id)
    if row is None:  # deleted since it was claimed (its owner deleted, or failed as stale and pruned)
        raise NotFound("preview", preview_id)
    catalogue = None
    if row.kind == PreviewKind.oracle.value and row.spec.get("type") not in BUILTIN_TYPE_NAMES:
        from alcove.oracles.service import command_catalogue

        catalogue = command_catalogue(s)  # the administrator's entries: the command run is theirs
    return {"kind": row.kind, "spec": dict(row.spec), "options": dict(row.options), "catalogue": catalogue}


def _finite(values: Any) -> Any:
    """Lists of floats for JSON (non-finite numbers become null)."""
    import numpy as np

    a = np.asarray(values, float)
    out = a.tolist()
    if np.isfinite(a).all():
        return out

    def clean(v: Any) -> Any:
        return [clean(x) for x in v] if isinstance(v, list) else (v if math.isfinite(v) else None)

    return clean(out)


def _scalar(v: Any) -> Any:
    v = float(v)
    return v if math.isfinite(v) else None


def compute(kind: str, spec: dict[str, Any], options: dict[str, Any], catalogue: Any) -> dict[str, Any]:
    if kind == PreviewKind.task.value:
        intervals = options.get("intervals")
        per_phase = options.get("intervals_per_phase") or preview_grid(spec, int(intervals) if intervals else None)
        return solve_task_once(spec, [int(n) for n in per_phase], int(intervals) if intervals else None)
    return test_oracle(spec["type"], spec.get("params") or {}, float(options.get("dt") or 0.0025), catalogue)


def _node_wrench(contact: Any, q: Any, qd: Any) -> Any:
    """The contact model's wrench (fx fy fz mx my mz on the head, in H) at the solution's nodes
    (the picture's force arrow and force plot; the OCP itself evaluates it between nodes)."""
    import numpy as np

    q, qd = np.asarray(q, float), np.asarray(qd, float)
    if contact is None or q.ndim != 2 or not len(q):
        return None
    return _finite(np.asarray(contact.map(q.shape[0])(q.T, qd.T)).T)


def solve_task_once(spec: dict[str, Any], per_phase: list[int], intervals: int | None = None) -> dict[str, Any]:
    """Solve the task once with the auxiliary (penalty) contact, ``per_phase[m]`` intervals in
    phase m: the trajectory on the OCP grid (t, q, qd, node torques tau, the contact wrench at the
    nodes), the solver's status,
    cost, iterations, wall time, and the grid in words (``intervals``: what the request asked)."""
    from alcove.science.ocp.contact import contact_from_spec
    from alcove.science.ocp.solve import solve_task
    from alcove.science.ocp.task_spec import parse_task

    if len(per_phase) != len(spec["phases"]):
        raise InvalidInput.one("intervals_per_phase", f"has {len(per_phase)} entries for {len(spec['phases'])} phases")
    data = {**spec, "phases": [{**ph, "intervals": n} for ph, n in zip(spec["phases"], per_phase, strict=True)]}
    task = parse_task(data)
    t0 = time.perf_counter()
    # a chain model (n-DOF preset or user-defined): the aux contact fed by its head's pose
    aux = contact_from_spec("aux", task.chain() if task.model.is_chain else task.preset())
    sol = solve_task(task, aux, max_attempts=1, ipopt_options={"ipopt.max_iter": PREVIEW_IPOPT_MAX_ITER})
    return {
        "wrench": _node_wrench(aux, sol.q, sol.qd),
        "t": _finite(sol.t),
        "q": _finite(sol.q),
        "qd": _finite(sol.qd),
        "tau": _finite(sol.tau),
        "status": sol.status,
        "converged": bool(sol.converged),
        "cost": _scalar(sol.cost),
        "iterations": int(sol.iterations),
        "constraint_violation": _scalar(sol.constraint_violation),
        "wall_time_s": float(time.perf_counter() - t0),
        "intervals": int(sol.controls.shape[0]),
        "intervals_per_phase": list(per_phase),
        "grid": grid_summary(spec, list(per_phase), intervals),
    }


def test_oracle(type_name: str, params: dict[str, Any], dt: float, catalogue: Any) -> dict[str, Any]:
    """Replay the FE reference head motion (1 s: clear of the headrest, into the cushion and
    back) sampled every ``dt`` through the oracle: t, the motion (q, qd), the force and moment
    on the head (fx..mz, headrest frame) and the oracle's diagnostics."""

    from alcove.science.geometry import DEFAULT_PRESET
    from alcove.science.json_values import json_safe
    from alcove.science.oracles.fe_headrest.reference import reference_motion
    from alcove.science.oracles.registry import build_oracle

    oracle = build_oracle(type_name, params, DEFAULT_PRESET, catalogue=catalogue)
    traj = reference_motion(DEFAULT_PRESET, dt=dt)
    res = oracle.run(traj)
    out: dict[str, Any] = {
        "ok": bool(res.ok),
        "failure_reason": res.failure_reason,
        "wall_time_s": float(res.wall_time),
        "trajectory": {"t": _finite(traj.t), "q": _finite(traj.q), "qd": _finite(traj.qd)},
        "diagnostics": json_safe(res.diagnostics),
        "t": None,
        "fx": None,
        "fy": None,
        "fz": None,
        "mx": None,
        "my": None,
        "mz": None,
        "peak_force_n": None,
    }
    if res.forces is not None:
        f = res.forces.wrench
        out.update(
            t=_finite(res.forces.t),
            peak_force_n=_scalar(res.forces.peak_force),
            **{c: _finite(f[:, j]) for j, c in enumerate(("fx", "fy", "fz", "mx", "my", "mz"))},
        )
    return out
