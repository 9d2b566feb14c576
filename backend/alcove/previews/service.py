"""Editor previews: "solve once" for a task (queue ``ocp``) and "test on a sample
trajectory" for an oracle (queue ``oracle``).

The API side (:func:`create_task_preview`, :func:`create_oracle_preview`, :func:`get`)
validates, snapshots what to run into a ``previews`` row and records its job in the job
outbox (:mod:`alcove.jobs.outbox`) in the same transaction; the route commits and only
then sends the job (:func:`send`). While the broker is down the job waits in the outbox
(the preview says "waiting for the job queue") and is sent when the broker is back. The worker side is
:mod:`alcove.previews.worker`. Importing this module imports neither torch nor casadi.
"""

from __future__ import annotations

import logging
from datetime import UTC, timedelta
from typing import Any

import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove.errors import InvalidInput, NotFound, TooManyRequests
from alcove.jobs import outbox
from alcove.jobs.heartbeat import dead_worker_reason
from alcove.models import (
    OracleDefinition,
    Preview,
    PreviewKind,
    PreviewStatus,
    TaskDefinition,
    User,
    utcnow,
)
from alcove.users.access import get_for
from alcove.users.limits import check_sizes
from alcove.versioning import ORACLES, TASKS, D, Kind, V

log = logging.getLogger(__name__)

#: Job names (``alcove.<queue>.<what>`` routes them to their queue).
TASK_PREVIEW_JOB = "alcove.ocp.preview"
ORACLE_PREVIEW_JOB = "alcove.oracle.preview"
JOB_FOR = {PreviewKind.task.value: TASK_PREVIEW_JOB, PreviewKind.oracle.value: ORACLE_PREVIEW_JOB}

#: At most this many previews of one user may be pending or running at once (429 beyond).
MAX_ACTIVE_PER_USER = 3
#: A pending/running preview older than this no longer counts toward the limit (no worker
#: took it, or its worker died) and may be claimed again by a worker.
STALE_AFTER = timedelta(minutes=10)
#: Finished previews kept per user (older ones are deleted when a new one is made).
KEEP_PER_USER = 50
#: A task preview solves on the task's own grid (its intervals per phase; the paper's task,
#: 100 per phase, takes ~0.1-0.3 s) unless the request names ``intervals`` per phase; either
#: way at most this many intervals per phase.
MAX_PREVIEW_INTERVALS = 200
#: IPOPT iteration cap of a preview solve.
PREVIEW_IPOPT_MAX_ITER = 1000


class TooManyPreviews(TooManyRequests):
    """More than :data:`MAX_ACTIVE_PER_USER` previews pending: answered 429."""

    def __init__(self, message: str, retry_after_s: int = 10) -> None:
        super().__init__(message, retry_after_s)


def _check_capacity(session: Session, user: User) -> None:
    active = session.execute(
        sa.select(sa.func.count())
        .select_from(Preview)
        .where(
            Preview.owner_id == user.id,
            Preview.status.in_((PreviewStatus.pending.value, PreviewStatus.running.value)),
            Preview.created_at > utcnow() - STALE_AFTER,
        )
    ).scalar_one()
    if active >= MAX_ACTIVE_PER_USER:
        raise TooManyPreviews(
            f"you have {active} previews pending or running (at most {MAX_ACTIVE_PER_USER}); wait for one to finish"
        )


def _prune(session: Session, user: User) -> None:
    keep = (
        sa.select(Preview.id)
        .where(Preview.owner_id == user.id)
        .order_by(Preview.id.desc())
        .limit(KEEP_PER_USER)
        .scalar_subquery()
    )
    session.execute(
        sa.delete(Preview).where(
            Preview.owner_id == user.id,
            Preview.status.in_((PreviewStatus.succeeded.value, PreviewStatus.failed.value)),
            Preview.id.not_in(keep),
        )
    )


def _version(session: Session, kind: Kind[D, V], definition: D, number: int | None) -> V:
    n = number or definition.latest_version
    row = session.scalar(sa.select(kind.version).where(kind.parent_column == definition.id, kind.version.version == n))
    if row is None:
        raise InvalidInput.one("version", f"version {n} does not exist")
    return row


def preview_grid(spec: dict[str, Any], intervals: int | None) -> list[int]:
    """Intervals per phase of a preview solve: ``intervals`` in every phase, or (None) each
    phase's own; capped at :data:`MAX_PREVIEW_INTERVALS`."""
    own = [int(ph.get("intervals") or 100) for ph in spec["phases"]]
    return [min(intervals if intervals else n, MAX_PREVIEW_INTERVALS) for n in own]


def grid_summary(spec: dict[str, Any], per_phase: list[int], intervals: int | None) -> str:
    """In words: which grid a preview solved on (and whether the task's was capped)."""
    grid = " + ".join(str(n) for n in per_phase)
    own = [int(ph.get("intervals") or 100) for ph in spec["phases"]]
    if intervals:
        return f"{grid} intervals ({intervals} per phase, as asked; the task's own: {' + '.join(map(str, own))})"
    if own != per_phase:
        capped = f"capped at {MAX_PREVIEW_INTERVALS} per phase for a preview"
        return f"{grid} intervals (the task's {' + '.join(map(str, own))}, {capped})"
    return f"{grid} intervals (the task's own grid)"


def create_task_preview(
    session: Session, user: User, task_id: int, *, version: int | None, spec: Any | None, intervals: int | None
) -> Preview:
    """A "solve once" of task ``task_id`` (its latest or given version, or ``spec``: an
    unsaved edit of it) with the auxiliary contact, on the task's own grid (each phase's
    intervals) or ``intervals`` per phase, at most :data:`MAX_PREVIEW_INTERVALS` per phase."""
    from alcove.tasks.service import check_spec

    check_sizes(session, user.id, [("intervals", intervals, "max_ocp_intervals")])
    definition = get_for(session, TaskDefinition, task_id, user)
    tv = _version(session, TASKS, definition, version)
    if spec is not None:
        parsed, errors = check_spec(spec)
        if parsed is None:
            raise InvalidInput(errors)
        snapshot = parsed.model_dump(mode="json")
    else:
        snapshot = tv.spec
    _check_capacity(session, user)
    _prune(session, user)
    row = Preview(
        owner_id=user.id,
        kind=PreviewKind.task.value,
        task_version_id=tv.id,
        draft=spec is not None,
        spec=snapshot,
        options={"intervals": intervals, "intervals_per_phase": preview_grid(snapshot, intervals)},
    )
    return _with_job(session, row)


def create_oracle_preview(
    session: Session, user: User, oracle_id: int, *, version: int | None, params: Any | None, dt: float
) -> Preview:
    """A "test on a sample trajectory" of oracle ``oracle_id`` (its latest or given version, or
    ``params``: an unsaved edit of its parameters) on the FE reference head motion sampled
    every ``dt`` seconds. A command oracle runs the administrator's command as configured."""
    from alcove.oracles.service import check

    definition = get_for(session, OracleDefinition, oracle_id, user)
    ov = _version(session, ORACLES, definition, version)
    if params is not None:
        normalized, errors = check(session, ov.oracle_type, params)
        if normalized is None:
            raise InvalidInput(errors)
    else:
        normalized = ov.spec
    _check_capacity(session, user)
    _prune(session, user)
    row = Preview(
        owner_id=user.id,
        kind=PreviewKind.oracle.value,
        oracle_version_id=ov.id,
        draft=params is not None,
        spec={"type": ov.oracle_type, "params": normalized},
        options={"dt": dt},
    )
    return _with_job(session, row)


def _with_job(session: Session, row: Preview) -> Preview:
    """Store the preview and record its job in the outbox, in the same transaction."""
    session.add(row)
    session.flush()
    outbox.record(session, JOB_FOR[row.kind], (row.id,), subject=subject(row.id))
    return row


def subject(preview_id: int) -> str:
    """The outbox subject of a preview's job."""
    return f"preview/{preview_id}"


def status_details(session: Session, rows: list[Preview]) -> dict[int, str]:
    """What each pending preview waits for, in words: the job queue (the broker was not
    reachable when it was asked for; it is sent as soon as the broker answers), or a worker."""
    pending = [r for r in rows if r.status == PreviewStatus.pending.value]
    if not pending:
        return {}
    unsent = outbox.waiting(session, [subject(r.id) for r in pending])
    out = {}
    for r in pending:
        if subject(r.id) in unsent:
            out[r.id] = f"{outbox.WAITING_FOR_QUEUE}: the broker is not reachable; it is sent as soon as it is back"
        else:
            out[r.id] = f"waiting for a worker on queue '{_queue(r)}'"
    return out


def _queue(row: Preview) -> str:
    return "ocp" if row.kind == PreviewKind.task.value else "oracle"


def get(session: Session, user: User, preview_id: int) -> Preview:
    """The user's own preview; anybody else's is "not found"."""
    row = session.get(Preview, preview_id)
    if row is None or row.owner_id != user.id:
        raise NotFound("preview", preview_id)
    _fail_if_stale(session, row)
    return row


def list_for(session: Session, user: User, limit: int) -> list[Preview]:
    rows = list(
        session.scalars(sa.select(Preview).where(Preview.owner_id == user.id).order_by(Preview.id.desc()).limit(limit))
    )
    for row in rows:
        _fail_if_stale(session, row)
    return rows


def _fail_if_stale(session: Session, row: Preview) -> None:
    """A preview no worker took (or whose worker died) within :data:`STALE_AFTER` is marked
    failed when it is read, with the reason, instead of staying "pending" for ever. The
    update is conditional, so a worker finishing at the same moment wins or loses cleanly
    (its own update requires ``running`` with its attempt number)."""
    active = (PreviewStatus.pending.value, PreviewStatus.running.value)
    if row.status not in active:
        return
    running = row.status == PreviewStatus.running.value
    dead = dead_worker_reason(session, row.worker_name) if running else None
    if dead is not None:
        error = f"the worker running it ({row.worker_name}) {dead}. Ask for a new preview."
    else:
        # a pending preview counts from when its job reached the broker: while it waits for
        # the job queue (broker down) it is not stale, it is sent when the broker is back
        since = row.started_at if running else outbox.sent_at(session, subject(row.id))
        if since is None or _aware(since) > utcnow() - STALE_AFTER:
            return
        minutes = int(STALE_AFTER.total_seconds() // 60)
        what = "no worker finished it" if running else "no worker took it from the job queue"
        error = (
            f"{what} within {minutes} minutes: is a worker listening on queue '{_queue(row)}'? Ask for a new preview."
        )
    from alcove.db import run_transaction

    now = utcnow()
    stmt = (
        sa.update(Preview)
        .where(Preview.id == row.id, Preview.status == row.status, Preview.attempts == row.attempts)
        .values(status=PreviewStatus.failed.value, error=error, finished_at=now)
    )
    # its own short write transaction: a GET's session only reads (and is rolled back). The
    # read transaction ends first, so the request never holds two connections of the pool
    # at once (see tests/api/test_connection_use.py); expire_on_commit is off, rows stay loaded
    if session.in_transaction() and not session.new and not session.dirty and not session.deleted:
        session.commit()

    def fail(s: Session) -> int:
        result = s.execute(stmt)
        assert isinstance(
            result, sa.CursorResult
        )  # an UPDATE's result is a CursorResult (Session.execute is typed Result)
        return result.rowcount

    if run_transaction(fail):
        session.expunge(row)  # answer with the new state without writing through this session
        row.status, row.error, row.finished_at = PreviewStatus.failed.value, error, now


def _aware(moment: Any) -> Any:
    """SQLite hands back naive datetimes (stored in UTC)."""

    return moment if moment.tzinfo is not None else moment.replace(tzinfo=UTC)


def send(row_id: int) -> None:
    """After the commit: send the preview's job now. A failed send loses nothing: the job
    waits in the outbox (the preview says "waiting for the job queue") and the outbox relay
    sends it when the broker is back."""
    from alcove.db import open_transaction

    with open_transaction() as s:
        ids = outbox.unsent_ids(s, subject(row_id))
    outbox.send_now(ids)
