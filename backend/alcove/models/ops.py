"""Operational tables: worker heartbeats, the smoke job's results, the job outbox."""

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


class JobOutbox(Base):
    """Every job the application sends, recorded in the transaction that makes it needed
    (the transactional outbox): a relay sends rows not yet sent, once each, and sends again
    the rows a broker restart lost (sent to an earlier broker incarnation and never picked
    up by a worker). See :mod:`alcove.jobs.outbox`."""

    __tablename__ = "job_outbox"
    __table_args__ = (sa.Index("ix_job_outbox_delivered_at_sent_at", "delivered_at", "sent_at"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    job_name: Mapped[str] = mapped_column(sa.String(100), comment="Celery job name, e.g. alcove.train.step")
    queue: Mapped[str] = mapped_column(sa.String(32))
    args: Mapped[list[Any]] = mapped_column(default=list, comment="the message's positional arguments (JSON)")
    message_id: Mapped[str] = mapped_column(sa.String(100), unique=True, comment="the Celery task id it is sent as")
    subject: Mapped[str] = mapped_column(
        sa.String(100), index=True, comment="what it runs, e.g. preview/12 or campaign/3/k2/train"
    )
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())
    sent_at: Mapped[datetime | None] = mapped_column(comment="last handed to the broker; NULL: waiting for it")
    sent_to: Mapped[str | None] = mapped_column(
        sa.String(64), comment="the broker incarnation it was sent to (Redis run_id); another one lost it"
    )
    send_count: Mapped[int] = mapped_column(default=0, server_default="0")
    last_error: Mapped[str | None] = mapped_column(sa.Text, comment="why the last send failed")
    delivered_at: Mapped[datetime | None] = mapped_column(comment="a worker started the job")
