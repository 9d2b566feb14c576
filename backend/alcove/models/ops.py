"""Operational tables: worker heartbeats and the smoke job's results."""

from __future__ import annotations

from datetime import datetime
from typing import Any

import sqlalchemy as sa
from sqlalchemy.orm import Mapped, mapped_column

from alcove.models.base import Base, utcnow


class WorkerHeartbeat(Base):
    """One row per worker name, refreshed periodically by the worker; readiness and the
    reconciler read ``last_seen_at`` (a worker that stops consuming stops beating)."""

    __tablename__ = "worker_heartbeats"

    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(sa.String(200), unique=True, comment="Celery node name, e.g. ocp-1@host")
    hostname: Mapped[str] = mapped_column(sa.String(200), default="", server_default="")
    pid: Mapped[int | None]
    queues: Mapped[list[Any]] = mapped_column(default=list)
    concurrency: Mapped[int | None]
    version: Mapped[str] = mapped_column(sa.String(100), default="", server_default="")
    started_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())
    last_seen_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now(), index=True)
    stopped_at: Mapped[datetime | None]
    meta: Mapped[dict[str, Any]] = mapped_column(default=dict)


class SmokeCheck(Base):
    """Written by the ``smoke`` job in one transaction: proof that a message went through
    the broker to a worker and its result was committed."""

    __tablename__ = "smoke_checks"

    id: Mapped[int] = mapped_column(primary_key=True)
    token: Mapped[str] = mapped_column(sa.String(64), unique=True)
    worker_name: Mapped[str] = mapped_column(sa.String(200))
    payload: Mapped[dict[str, Any]] = mapped_column(default=dict)
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())
