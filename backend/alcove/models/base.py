"""Declarative base, naming convention, portable column types and shared enums.

Every table of alcove is declared on :data:`Base.metadata`. Conventions:

* integer surrogate primary keys ``id``; foreign keys ``<thing>_id``;
* all times are timezone-aware UTC (:class:`UTCDateTime`; SQLite stores them naive and
  they come back aware);
* small structured settings are JSON (JSONB on PostgreSQL); arrays never go in JSON, they
  live in :class:`alcove.models.data.Blob` rows (compressed ``.npz`` bytes, content hash);
* enumerations are short strings checked by a named CHECK constraint (portable, readable
  in SQL, and new values only need a migration that replaces the constraint);
* constraint names follow :data:`NAMING_CONVENTION` so Alembic batch mode on SQLite can
  find and alter them.
"""

from __future__ import annotations

import enum
from datetime import UTC, datetime
from typing import Any, ClassVar

import sqlalchemy as sa
from sqlalchemy.dialects import postgresql
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column
from sqlalchemy.types import TypeDecorator

NAMING_CONVENTION = {
    "ix": "ix_%(column_0_label)s",
    "uq": "uq_%(table_name)s_%(column_0_N_name)s",
    "ck": "ck_%(table_name)s_%(constraint_name)s",
    "fk": "fk_%(table_name)s_%(column_0_name)s_%(referred_table_name)s",
    "pk": "pk_%(table_name)s",
}


def utcnow() -> datetime:
    return datetime.now(UTC)


class UTCDateTime(TypeDecorator[datetime]):
    """``TIMESTAMP WITH TIME ZONE``; values are always returned timezone-aware in UTC."""

    impl = sa.DateTime(timezone=True)
    cache_ok = True

    def process_bind_param(self, value: datetime | None, dialect: sa.Dialect) -> datetime | None:
        if value is None:
            return None
        if value.tzinfo is None:
            raise ValueError("naive datetime given to a UTCDateTime column; use alcove.models.utcnow()")
        value = value.astimezone(UTC)
        if dialect.name == "sqlite":
            return value.replace(tzinfo=None)
        return value

    def process_result_value(self, value: datetime | None, dialect: sa.Dialect) -> datetime | None:
        if value is None:
            return None
        if value.tzinfo is None:
            return value.replace(tzinfo=UTC)
        return value.astimezone(UTC)


#: JSON everywhere, JSONB on PostgreSQL.
JSONType = sa.JSON().with_variant(postgresql.JSONB(), "postgresql")


def enum_check(column: str, enum_cls: type[enum.Enum], name: str | None = None) -> sa.CheckConstraint:
    """A named CHECK constraint ``column IN (...)`` over the values of ``enum_cls``."""
    values = ", ".join(f"'{m.value}'" for m in enum_cls)
    return sa.CheckConstraint(f"{column} IN ({values})", name=name or f"{column}_valid")


class Base(DeclarativeBase):
    metadata = sa.MetaData(naming_convention=NAMING_CONVENTION)
    type_annotation_map: ClassVar[dict[Any, Any]] = {
        datetime: UTCDateTime(),
        dict[str, Any]: JSONType,
        list[Any]: JSONType,
    }

    def __repr__(self) -> str:
        keys = (c.key for c in self.__mapper__.primary_key)  # a Column's key is None only before it is named
        pk = ", ".join(f"{k}={getattr(self, k, None)!r}" for k in keys if k is not None)
        return f"<{type(self).__name__} {pk}>"


class TimestampMixin:
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())
    updated_at: Mapped[datetime] = mapped_column(default=utcnow, onupdate=utcnow, server_default=sa.func.now())


# ----------------------------------------------------------------------------- enums


class Role(str, enum.Enum):
    admin = "admin"
    member = "member"


class TokenKind(str, enum.Enum):
    session = "session"  # issued by password login, expires
    personal = "personal"  # created by the user, shown once, revocable


class SharePermission(str, enum.Enum):
    view = "view"
    edit = "edit"


class CampaignStatus(str, enum.Enum):
    draft = "draft"  # created, not started
    queued = "queued"  # started, first step enqueued, nothing running yet
    running = "running"
    pausing = "pausing"  # pause requested; the running step finishes first
    paused = "paused"
    cancelling = "cancelling"  # cancel requested; the running job checks the flag
    cancelled = "cancelled"
    completed = "completed"  # a stopping rule fired; see stop_reason
    failed = "failed"

    @classmethod
    def terminal(cls) -> frozenset[CampaignStatus]:
        return frozenset({cls.cancelled, cls.completed, cls.failed})


class StepName(str, enum.Enum):
    """Steps of an iteration, in order. ``preliminary`` only occurs in iteration 0."""

    preliminary = "preliminary"
    train = "train"
    ocp = "ocp"
    oracle = "oracle"
    evaluate = "evaluate"
    append = "append"


#: The per-iteration sequence for k >= 1.
ITERATION_STEPS: tuple[StepName, ...] = (
    StepName.train,
    StepName.ocp,
    StepName.oracle,
    StepName.evaluate,
    StepName.append,
)


class StepStatus(str, enum.Enum):
    pending = "pending"  # row exists, not yet enqueued
    queued = "queued"  # message sent after commit
    running = "running"  # claimed by a worker (lease_until, heartbeat_at set)
    succeeded = "succeeded"
    failed = "failed"  # attempts exhausted or non-retryable error
    cancelled = "cancelled"
    skipped = "skipped"  # e.g. evaluate/append after a failed OCP with policy "continue"


class IterationStatus(str, enum.Enum):
    pending = "pending"
    running = "running"
    succeeded = "succeeded"
    failed = "failed"
    cancelled = "cancelled"


class DatasetOrigin(str, enum.Enum):
    preliminary = "preliminary"  # Latin-hypercube samples evaluated by an oracle
    oracle = "oracle"  # one OCP trajectory replayed by the campaign's oracle
    upload = "upload"  # a user-uploaded preliminary data set (CSV)
    validation = "validation"  # a held-out validation motion replayed by an oracle (never in a pool)


class BatchJobState(str, enum.Enum):
    """A batch job of an oracle call: waiting in the scheduler's queue, running, ended with its
    result not yet stored, its result stored with the step, or ended without one."""

    queued = "queued"
    running = "running"
    completed = "completed"
    collected = "collected"
    failed = "failed"
    cancelled = "cancelled"


class OracleRunStatus(str, enum.Enum):
    running = "running"
    ok = "ok"
    failed = "failed"  # the oracle raised or timed out
    quarantined = "quarantined"  # ran, but failed the quality gate; see quarantined_results
    cancelled = "cancelled"
