"""The job outbox: nothing is lost while the broker is down.

Every job the application sends (a campaign step, an editor preview, a validation motion's
replay or a validation-suite evaluation) is first a row of ``job_outbox``, written by
:func:`record` in the transaction that makes the job needed. After that transaction commits,
its rows are sent at once (:func:`send_now`: the fast path; campaign steps through
:func:`alcove.jobs.campaign.stage` and ``send_committed``, jobs written inside another
domain's transaction through :func:`alcove.jobs.after_commit.send_after_commit`); a
:class:`RelayThread` (one in every API process and one in every worker's main process) sends
whatever is left:

* rows never sent (the broker was unreachable, or the process died between its commit and
  the send): sent as soon as the broker answers again;
* rows sent to an earlier *incarnation* of the broker and never picked up by a worker: a
  Redis restart without persistence loses its queues, and Redis names each start with a new
  ``run_id`` (``INFO server``). A row records the incarnation it was sent to
  (``sent_to``); when the relay meets a new one it sends the row again. A Redis that kept
  its data (AOF, a replica promoted with the same data) may then hold a message twice: the
  second is a no-op, because every job claims its row with a conditional update first.

Send once per row: a pass locks the rows it sends (``FOR UPDATE SKIP LOCKED`` on
PostgreSQL; SQLite has one writer at a time), so two relays (or a relay and the fast path)
never send the same row to the same incarnation. A worker marks a row delivered
(:func:`mark_delivered`) when it starts the job; from then on the job's own recovery applies
(the campaign reconciler for steps, the stale claim for previews).

Why both the API and the workers relay: the API is what accepts a user's jobs (a preview
requested while Redis is down must go out when Redis is back, with no other process
involved); the workers' relay covers the jobs workers create (a step's next step) and an API
that is down or restarting. Either one suffices; each pass is one indexed query.
"""

from __future__ import annotations

import logging
import threading
import uuid
from collections.abc import Iterable, Sequence
from datetime import timedelta
from typing import Any

import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove.db import get_sessionmaker, run_transaction
from alcove.jobs import queue_for, send_job
from alcove.models import JobOutbox, utcnow
from alcove.settings import get_settings

log = logging.getLogger(__name__)

#: What the user is told while a job waits for the broker (API status, UI).
WAITING_FOR_QUEUE = "waiting for the job queue"
#: Rows sent per relay pass at most (the rest go in the next pass, at once).
BATCH = 200
#: Delivered rows are deleted after this (they only serve diagnostics).
KEEP_DELIVERED = timedelta(days=2)


def record(
    session: Session,
    job_name: str,
    args: Sequence[Any],
    *,
    subject: str,
    queue: str | None = None,
    message_id: str | None = None,
) -> JobOutbox:
    """Record job ``job_name(*args)`` in the caller's transaction (sent after its commit)."""
    row = JobOutbox(
        job_name=job_name,
        queue=queue or queue_for(job_name),
        args=list(args),
        subject=subject,
        message_id=message_id or f"{subject.replace('/', '-')}-{uuid.uuid4().hex[:8]}",
    )
    session.add(row)
    session.flush()
    return row


# ----------------------------------------------------------------------------- the broker's incarnation

_redis_lock = threading.Lock()
_redis: Any = None


def broker_incarnation() -> str | None:
    """Which start of the broker answers now: Redis's ``run_id`` (new at every start), a
    constant for brokers that keep their messages (the embedded folders), None when the
    broker does not answer (then nothing is sent: the rows wait)."""
    s = get_settings()
    if not s.is_redis_broker:
        return "filesystem" if s.is_embedded_broker else "broker"
    global _redis
    try:
        with _redis_lock:
            if _redis is None:
                import redis

                _redis = redis.Redis.from_url(s.broker_url, socket_connect_timeout=1.0, socket_timeout=2.0)
            client = _redis
        return str(client.info("server")["run_id"])
    except Exception as err:
        log.debug("broker not reachable: %s", err)
        return None


def reset_broker_client() -> None:
    """Forget the cached Redis client (tests that change the broker URL)."""
    global _redis
    with _redis_lock:
        _redis = None


# ----------------------------------------------------------------------------- sending


def _pending(ids: Sequence[int] | None, incarnation: str, dialect: str) -> sa.Select[JobOutbox]:
    q = (
        sa.select(JobOutbox)
        .where(
            JobOutbox.delivered_at.is_(None),
            sa.or_(JobOutbox.sent_at.is_(None), JobOutbox.sent_to != incarnation),
        )
        .order_by(JobOutbox.id)
        .limit(BATCH)
    )
    if ids is not None:
        q = q.where(JobOutbox.id.in_(ids))
    if dialect == "postgresql":
        q = q.with_for_update(skip_locked=True)
    return q


def _anything_to_send(incarnation: str) -> bool:
    with get_sessionmaker()() as s:
        q = sa.select(JobOutbox.id).where(
            JobOutbox.delivered_at.is_(None),
            sa.or_(JobOutbox.sent_at.is_(None), JobOutbox.sent_to != incarnation),
        )
        return s.scalar(q.limit(1)) is not None


def relay_pass(ids: Iterable[int] | None = None) -> int:
    """Send the rows waiting for the broker (only ``ids``, if given), each once per broker
    incarnation. Returns how many were sent; 0 while the broker does not answer."""
    wanted = None if ids is None else list(ids)
    if wanted is not None and not wanted:
        return 0
    incarnation = broker_incarnation()
    if incarnation is None:
        return 0
    if wanted is None and not _anything_to_send(incarnation):
        return 0  # the usual case: a read, no write transaction (SQLite's write lock stays free)

    def work(s: Session) -> int:
        rows = list(s.scalars(_pending(wanted, incarnation, s.get_bind().dialect.name)))
        sent = 0
        for row in rows:
            try:
                send_job(row.job_name, *row.args, queue=row.queue, task_id=row.message_id, quick=True)
            except Exception as err:  # the broker went away mid-pass: the rest wait for the next one
                row.last_error = f"{type(err).__name__}: {err}"[:500]
                log.warning("sending job %s (%s) failed; it waits for the broker: %s", row.id, row.subject, err)
                break
            if row.sent_at is not None:
                log.warning("job %s (%s) sent again: the broker restarted before a worker took it", row.id, row.subject)
            row.sent_at, row.sent_to, row.send_count, row.last_error = utcnow(), incarnation, row.send_count + 1, None
            sent += 1
        return sent

    return run_transaction(work)


def send_now(ids: Iterable[int]) -> None:
    """The fast path, after the commit that recorded ``ids``: send them now. A failure loses
    nothing: the rows stay unsent and a relay sends them when the broker answers."""
    try:
        relay_pass(ids)
    except Exception:
        log.exception("sending jobs failed; the outbox relay will send them")


def mark_delivered(message_id: str) -> None:
    """A worker started the job sent as ``message_id`` (no re-send after a broker restart)."""

    def work(s: Session) -> None:
        s.execute(
            sa.update(JobOutbox)
            .where(JobOutbox.message_id == message_id, JobOutbox.delivered_at.is_(None))
            .values(delivered_at=utcnow())
        )

    run_transaction(work)


def waiting(session: Session, subjects: Sequence[str]) -> set[str]:
    """Which of ``subjects`` have a job that never reached the broker."""
    if not subjects:
        return set()
    q = sa.select(JobOutbox.subject).where(
        JobOutbox.subject.in_(subjects), JobOutbox.sent_at.is_(None), JobOutbox.delivered_at.is_(None)
    )
    return set(session.scalars(q))


def unsent_ids(session: Session, subject: str) -> list[int]:
    """The outbox rows of ``subject`` not sent yet."""
    q = sa.select(JobOutbox.id).where(JobOutbox.subject == subject, JobOutbox.sent_at.is_(None))
    return list(session.scalars(q))


def sent_at(session: Session, subject: str) -> Any:
    """When the job of ``subject`` last reached the broker (None: not yet, or no job)."""
    return session.scalar(sa.select(sa.func.max(JobOutbox.sent_at)).where(JobOutbox.subject == subject))


def prune() -> int:
    """Delete delivered rows older than :data:`KEEP_DELIVERED`."""

    def work(s: Session) -> int:
        res = s.execute(sa.delete(JobOutbox).where(JobOutbox.delivered_at < utcnow() - KEEP_DELIVERED))
        return int(getattr(res, "rowcount", 0) or 0)

    return run_transaction(work)


class RelayThread(threading.Thread):
    """:func:`relay_pass` every ``interval`` s (and :func:`prune` now and then), in a daemon thread."""

    def __init__(self, interval: float = 1.0, name: str = "alcove-outbox-relay") -> None:
        super().__init__(name=name, daemon=True)
        self.interval = interval
        self._stop_event = threading.Event()

    def run(self) -> None:
        passes = 0
        while not self._stop_event.is_set():
            try:
                relay_pass()
                if passes % 3600 == 0:
                    prune()
            except Exception:
                log.exception("outbox relay pass failed")
            passes += 1
            self._stop_event.wait(self.interval)

    def stop(self) -> None:
        self._stop_event.set()
