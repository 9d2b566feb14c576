"""Editor previews: one "solve once" of a task or one "test on a sample trajectory" of an
oracle, requested by a user in the UI and run by a worker (never in the API process)."""

from __future__ import annotations

import enum
from datetime import datetime
from typing import Any

import sqlalchemy as sa
from sqlalchemy.orm import Mapped, mapped_column

from alcove.models.base import Base, enum_check, utcnow


class PreviewKind(str, enum.Enum):
    task = "task"  # solve the task's OCP once with the auxiliary contact (queue ocp)
    oracle = "oracle"  # replay a sample trajectory through the oracle (queue oracle)


class PreviewStatus(str, enum.Enum):
    pending = "pending"  # committed; the job is sent after the commit
    running = "running"  # claimed by a worker
    succeeded = "succeeded"
    failed = "failed"


class Preview(Base):
    """The request (a snapshot of what to run: the task spec, or the oracle type and
    parameters, so an edit after the request does not change it), its state and result.
    Owner-only; a worker claims the row with a conditional update, so a duplicate
    delivery of the job does nothing."""

    __tablename__ = "previews"
    __table_args__ = (
        enum_check("kind", PreviewKind),
        enum_check("status", PreviewStatus),
        sa.Index("ix_previews_owner_id_status", "owner_id", "status"),
    )

    id: Mapped[int] = mapped_column(primary_key=True)
    owner_id: Mapped[int] = mapped_column(sa.ForeignKey("users.id", ondelete="CASCADE"))
    kind: Mapped[str] = mapped_column(sa.String(16))
    status: Mapped[str] = mapped_column(
        sa.String(16), default=PreviewStatus.pending.value, server_default=PreviewStatus.pending.value
    )
    task_version_id: Mapped[int | None] = mapped_column(
        sa.ForeignKey("task_versions.id", ondelete="SET NULL"),
        comment="the task version previewed (a draft is an unsaved edit of it)",
    )
    oracle_version_id: Mapped[int | None] = mapped_column(sa.ForeignKey("oracle_versions.id", ondelete="SET NULL"))
    draft: Mapped[bool] = mapped_column(
        default=False, server_default=sa.false(), comment="the spec/params were an unsaved edit sent with the request"
    )
    spec: Mapped[dict[str, Any]] = mapped_column(
        default=dict, comment="task spec, or {type, params} of the oracle: what the worker runs"
    )
    options: Mapped[dict[str, Any]] = mapped_column(
        default=dict, comment="intervals (task), dt (oracle sample trajectory)"
    )
    result: Mapped[dict[str, Any] | None] = mapped_column(
        comment="t, q, qd, tau + solver summary (task); t, q, qd, fx..mz + diagnostics (oracle)"
    )
    error: Mapped[str | None] = mapped_column(sa.Text)
    worker_name: Mapped[str | None] = mapped_column(sa.String(200))
    attempts: Mapped[int] = mapped_column(default=0, server_default="0")
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())
    started_at: Mapped[datetime | None]
    finished_at: Mapped[datetime | None]
