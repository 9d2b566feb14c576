"""User definitions, each with immutable versions: tasks, oracles, surrogate configs.

Pattern (the same for the three kinds):

* ``<kind>`` row = the identity a user sees and renames (owner, name, description);
* ``<kind>_versions`` rows = numbered snapshots of the validated content (``spec``).
  ``(definition_id, version)`` is unique and versions start at 1.
* A version becomes immutable when first used by a campaign: the service sets
  ``locked_at`` and from then on editing the content creates version n+1. The ORM
  refuses to change a locked version's content (:class:`ImmutableRowError`).
* ``spec_hash`` = SHA-256 of the canonical JSON of ``spec`` (see :func:`spec_hash`), so
  "is this edit a no-op?" is a string comparison.
"""

from __future__ import annotations

import hashlib
import json
from datetime import datetime
from typing import TYPE_CHECKING, Any, ClassVar

import sqlalchemy as sa
from sqlalchemy.orm import Mapped, declared_attr, mapped_column, relationship

from alcove.models.base import Base, TimestampMixin, utcnow

if TYPE_CHECKING:
    from alcove.models.users import User


def canonical_json(obj: Any) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False)


def spec_hash(spec: Any) -> str:
    return hashlib.sha256(canonical_json(spec).encode()).hexdigest()


class _DefinitionMixin(TimestampMixin):
    """Columns shared by task_definitions, oracle_definitions and surrogate_configs."""

    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(sa.String(200))
    description: Mapped[str] = mapped_column(sa.Text, default="", server_default="")
    preset_key: Mapped[str | None] = mapped_column(
        sa.String(100), comment="built-in preset this was copied from, if any"
    )
    latest_version: Mapped[int] = mapped_column(default=0, server_default="0", comment="highest version number")
    archived_at: Mapped[datetime | None] = mapped_column(comment="hidden from lists; kept for campaigns that use it")

    @declared_attr
    def owner_id(cls) -> Mapped[int]:
        return mapped_column(sa.ForeignKey("users.id", ondelete="RESTRICT"), index=True)

    @declared_attr
    def owner(cls) -> Mapped[User]:
        return relationship()


class _VersionMixin:
    """Columns shared by the *_versions tables. Content is ``spec`` (validated JSON)."""

    #: columns that may not change once ``locked_at`` is set (checked at flush time)
    __immutable_when_locked__: ClassVar[tuple[str, ...]] = ("spec", "spec_hash", "version", "schema_version")

    id: Mapped[int] = mapped_column(primary_key=True)
    version: Mapped[int] = mapped_column(comment="1, 2, ... within the definition")
    spec: Mapped[dict[str, Any]] = mapped_column(comment="validated content (pydantic model dump)")
    spec_hash: Mapped[str] = mapped_column(sa.String(64), comment="sha256 of canonical JSON of spec")
    schema_version: Mapped[int] = mapped_column(default=1, server_default="1", comment="format version of spec")
    note: Mapped[str] = mapped_column(sa.Text, default="", server_default="", comment="change note")
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())
    locked_at: Mapped[datetime | None] = mapped_column(
        comment="set when first used by a campaign; immutable from then on"
    )

    @declared_attr
    def created_by_id(cls) -> Mapped[int | None]:
        return mapped_column(sa.ForeignKey("users.id", ondelete="SET NULL"))

    @property
    def is_locked(self) -> bool:
        return self.locked_at is not None


# ----------------------------------------------------------------------------- tasks


class TaskDefinition(_DefinitionMixin, Base):
    """A user's OCP task: model preset and parameters, phases (durations, cost weights),
    boundary conditions, bounds, discretisation. The content lives in TaskVersion.spec."""

    __tablename__ = "task_definitions"

    versions: Mapped[list[TaskVersion]] = relationship(
        back_populates="definition", order_by="TaskVersion.version", cascade="all, delete-orphan"
    )


class TaskVersion(_VersionMixin, Base):
    __tablename__ = "task_versions"
    __table_args__ = (
        sa.UniqueConstraint("definition_id", "version"),
        sa.CheckConstraint("version >= 1", name="version_positive"),
    )

    definition_id: Mapped[int] = mapped_column(sa.ForeignKey("task_definitions.id", ondelete="CASCADE"), index=True)
    definition: Mapped[TaskDefinition] = relationship(back_populates="versions")


# ----------------------------------------------------------------------------- oracles


class OracleDefinition(_DefinitionMixin, Base):
    """An oracle: a type (``fe-headrest-2d``, ``aux-penalty``, ``command``, ...) plus validated
    parameters. Type and parameters live in OracleVersion."""

    __tablename__ = "oracle_definitions"

    versions: Mapped[list[OracleVersion]] = relationship(
        back_populates="definition", order_by="OracleVersion.version", cascade="all, delete-orphan"
    )


class OracleVersion(_VersionMixin, Base):
    __tablename__ = "oracle_versions"
    __table_args__ = (
        sa.UniqueConstraint("definition_id", "version"),
        sa.CheckConstraint("version >= 1", name="version_positive"),
    )
    __immutable_when_locked__ = (*_VersionMixin.__immutable_when_locked__, "oracle_type")

    definition_id: Mapped[int] = mapped_column(sa.ForeignKey("oracle_definitions.id", ondelete="CASCADE"), index=True)
    oracle_type: Mapped[str] = mapped_column(
        sa.String(64), comment="registered oracle type name; spec = its validated params"
    )
    definition: Mapped[OracleDefinition] = relationship(back_populates="versions")


# ----------------------------------------------------------------------------- surrogate configs


class SurrogateConfigDefinition(_DefinitionMixin, Base):
    """Surrogate settings: features, MLP architectures (force / moment), training protocol
    (splits, optimiser, batch size, early stopping), warm start, sample weighting."""

    __tablename__ = "surrogate_configs"

    versions: Mapped[list[SurrogateConfigVersion]] = relationship(
        back_populates="config", order_by="SurrogateConfigVersion.version", cascade="all, delete-orphan"
    )


class SurrogateConfigVersion(_VersionMixin, Base):
    __tablename__ = "surrogate_config_versions"
    __table_args__ = (
        sa.UniqueConstraint("config_id", "version"),
        sa.CheckConstraint("version >= 1", name="version_positive"),
    )

    config_id: Mapped[int] = mapped_column(sa.ForeignKey("surrogate_configs.id", ondelete="CASCADE"), index=True)
    config: Mapped[SurrogateConfigDefinition] = relationship(back_populates="versions")


# ----------------------------------------------------------------------------- command oracle catalogue


class CommandOracle(TimestampMixin, Base):
    """Admin-managed catalogue entry of an external program usable as a ``command`` oracle.

    Members reference an entry by ``name`` in a command oracle's parameters; they never
    supply a command line themselves.
    """

    __tablename__ = "command_oracles"

    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(sa.String(100), unique=True)
    description: Mapped[str] = mapped_column(sa.Text, default="", server_default="")
    argv: Mapped[list[Any]] = mapped_column(comment="program and arguments; placeholders for the input/output files")
    working_dir: Mapped[str | None] = mapped_column(sa.String(1000))
    env: Mapped[dict[str, Any]] = mapped_column(default=dict, comment="extra environment variables")
    timeout_s: Mapped[float] = mapped_column(sa.Float, default=3600.0, server_default="3600")
    launcher: Mapped[dict[str, Any] | None] = mapped_column(
        comment="where the program runs: NULL on the oracle worker, else the batch scheduler and the job's resources"
    )
    enabled: Mapped[bool] = mapped_column(default=True, server_default=sa.true())
    created_by_id: Mapped[int | None] = mapped_column(sa.ForeignKey("users.id", ondelete="SET NULL"))
