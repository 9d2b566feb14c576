"""Worker heartbeats in the database (``worker_heartbeats``).

A worker that silently stops consuming (e.g. after a Redis reconnect) also stops
beating, so readiness and the reconciler can see it. The beat runs in a daemon thread of
the worker's main process.
"""

from __future__ import annotations

import logging
import os
import socket
import threading
from datetime import UTC, timedelta
from typing import Any

import sqlalchemy as sa

import alcove
from alcove.db import open_transaction, run_transaction
from alcove.models import WorkerHeartbeat, utcnow

log = logging.getLogger(__name__)


def beat(
    name: str,
    *,
    queues: list[str] | None = None,
    concurrency: int | None = None,
    meta: dict[str, Any] | None = None,
    starting: bool = False,
) -> None:
    """Insert or refresh the heartbeat row of worker ``name``."""

    def work(s: sa.orm.Session) -> None:
        now = utcnow()
        row = s.scalar(sa.select(WorkerHeartbeat).where(WorkerHeartbeat.name == name))
        if row is None:
            row = WorkerHeartbeat(name=name, started_at=now)
            s.add(row)
        if starting or row.stopped_at is not None:
            row.started_at = now
            row.stopped_at = None
        row.last_seen_at = now
        row.hostname = socket.gethostname()
        row.pid = os.getpid()
        row.version = alcove.__version__
        if queues is not None:
            row.queues = list(queues)
        if concurrency is not None:
            row.concurrency = concurrency
        if meta is not None:
            row.meta = meta

    run_transaction(work)


def mark_stopped(name: str) -> None:
    def work(s: sa.orm.Session) -> None:
        s.execute(sa.update(WorkerHeartbeat).where(WorkerHeartbeat.name == name).values(stopped_at=utcnow()))

    run_transaction(work)


def live_workers(stale_seconds: float, session: sa.orm.Session | None = None) -> list[WorkerHeartbeat]:
    """Workers seen within ``stale_seconds`` and not stopped."""
    cutoff = utcnow() - timedelta(seconds=stale_seconds)
    q = (
        sa.select(WorkerHeartbeat)
        .where(WorkerHeartbeat.last_seen_at >= cutoff, WorkerHeartbeat.stopped_at.is_(None))
        .order_by(WorkerHeartbeat.name)
    )
    if session is not None:
        return list(session.scalars(q))
    with open_transaction() as s:
        return list(s.scalars(q))


class HeartbeatThread(threading.Thread):
    def __init__(self, name: str, interval: float, queues: list[str], concurrency: int | None) -> None:
        super().__init__(name=f"alcove-heartbeat-{name}", daemon=True)
        self.worker_name = name
        self.interval = interval
        self.queues = queues
        self.concurrency = concurrency
        self._stop_event = threading.Event()

    def run(self) -> None:
        first = True
        while not self._stop_event.is_set():
            try:
                beat(self.worker_name, queues=self.queues, concurrency=self.concurrency, starting=first)
                first = False
            except Exception:
                log.exception("heartbeat of %s failed", self.worker_name)
            self._stop_event.wait(self.interval)

    def stop(self) -> None:
        self._stop_event.set()
        self.join(timeout=5)
        try:
            mark_stopped(self.worker_name)
        except Exception:
            log.exception("could not mark %s stopped", self.worker_name)


def dead_worker_reason(session: sa.orm.Session, name: str | None) -> str | None:
    """Why the worker ``name`` is dead (it shut down, or its heartbeat is older than
    ``ALCOVE_WORKER_DEAD_SECONDS``), or None while it beats or has no heartbeat row (a worker
    that never beat). A slow worker keeps beating from its main process however long its job
    computes, so a long job is never called dead here."""
    from alcove.settings import get_settings

    hb = session.scalar(sa.select(WorkerHeartbeat).where(WorkerHeartbeat.name == name)) if name else None
    if hb is None:
        return None
    if hb.stopped_at is not None:
        return "shut down before finishing it"
    dead_s = get_settings().worker_dead_seconds
    seen = (
        hb.last_seen_at if hb.last_seen_at.tzinfo is not None else hb.last_seen_at.replace(tzinfo=UTC)
    )  # SQLite: naive UTC
    if seen < utcnow() - timedelta(seconds=dead_s):
        return f"stopped beating (no heartbeat for more than {dead_s:g} s)"
    return None
