"""Versioned user definitions (tasks, oracles, surrogate configs): the rules shared by
their services. Services never commit.

* create: the definition row plus version 1 holding the validated ``spec``;
* update: name/description change in place; a changed ``spec`` (or oracle type) edits the
  latest version in place while no campaign uses it, and otherwise creates version n+1
  (a used version is immutable); an unchanged spec (same hash) creates nothing;
* delete: a definition no campaign uses is deleted, a used one is archived (hidden from
  lists, kept for its campaigns).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

import sqlalchemy as sa
from sqlalchemy.orm import InstrumentedAttribute, Session

from alcove.errors import NotFound
from alcove.models import (
    Campaign,
    OracleDefinition,
    OracleVersion,
    SurrogateConfigDefinition,
    SurrogateConfigVersion,
    TaskDefinition,
    TaskVersion,
    User,
    spec_hash,
    utcnow,
)
from alcove.users.access import can_edit, visible_clause

#: the versioned definitions and their version rows
DefinitionRow = TaskDefinition | OracleDefinition | SurrogateConfigDefinition
VersionRow = TaskVersion | OracleVersion | SurrogateConfigVersion
D = TypeVar("D", bound=DefinitionRow)
V = TypeVar("V", bound=VersionRow)
D_co = TypeVar("D_co", bound=DefinitionRow, covariant=True)
V_co = TypeVar("V_co", bound=VersionRow, covariant=True)


@dataclass(frozen=True)
class Kind(Generic[D_co, V_co]):
    label: str
    definition: type[D_co]
    version: type[V_co]
    parent_column: InstrumentedAttribute[int]  # the version's foreign key to its definition
    campaign_column: InstrumentedAttribute[int]

    @property
    def parent_key(self) -> str:
        """Name of the version's foreign key to its definition."""
        return self.parent_column.key


TASKS = Kind("task", TaskDefinition, TaskVersion, TaskVersion.definition_id, Campaign.task_version_id)
ORACLES = Kind("oracle", OracleDefinition, OracleVersion, OracleVersion.definition_id, Campaign.oracle_version_id)
SURROGATE_CONFIGS = Kind(
    "surrogate config",
    SurrogateConfigDefinition,
    SurrogateConfigVersion,
    SurrogateConfigVersion.config_id,
    Campaign.surrogate_config_version_id,
)


def list_visible(
    session: Session,
    kind: Kind[D, V],
    user: User,
    *,
    include_archived: bool = False,
    limit: int = 100,
    offset: int = 0,
    extra: Sequence[Any] = (),
) -> list[tuple[D, V, str]]:
    """(definition, latest version, owner e-mail) rows the user may see, newest first."""
    d, v = kind.definition, kind.version
    q = (
        sa.select(d, v, User.email)
        .join(v, sa.and_(kind.parent_column == d.id, v.version == d.latest_version))
        .join(User, User.id == d.owner_id)
        .where(visible_clause(d, user), *extra)
        .order_by(d.id.desc())
        .limit(limit)
        .offset(offset)
    )
    if not include_archived:
        q = q.where(d.archived_at.is_(None))
    return [(definition, version, email) for definition, version, email in session.execute(q).all()]


def latest(session: Session, kind: Kind[D, V], definition: D) -> V:
    return get_version(session, kind, definition, definition.latest_version)


def get_version(session: Session, kind: Kind[D, V], definition: D, number: int) -> V:
    row = session.scalar(
        sa.select(kind.version).where(kind.parent_column == definition.id, kind.version.version == number)
    )
    if row is None:
        raise NotFound(f"{kind.label} {definition.id} version", number)
    return row


def versions(session: Session, kind: Kind[D, V], definition: D) -> Sequence[V]:
    return session.scalars(
        sa.select(kind.version).where(kind.parent_column == definition.id).order_by(kind.version.version)
    ).all()


def is_used(session: Session, kind: Kind[D, V], version: V) -> bool:
    """A version is immutable once locked by the engine or referenced by any campaign."""
    if version.locked_at is not None:
        return True
    return session.scalar(sa.select(sa.exists().where(kind.campaign_column == version.id))) or False


def definition_meta(
    session: Session, kind: Kind[D, V], definition: D, version: V, user: User, owner_email: str | None = None
) -> dict[str, Any]:
    """The fields every versioned definition shows (:class:`alcove.versioning.schemas.DefinitionMeta`)."""
    d: Any = definition
    return {
        "id": d.id,
        "name": d.name,
        "description": d.description,
        "owner_id": d.owner_id,
        "owner": owner_email or (d.owner.email if d.owner else None),
        "preset_key": d.preset_key,
        "version": version.version,
        "version_locked": is_used(session, kind, version),
        "can_edit": can_edit(session, d, user),
        "archived": d.archived_at is not None,
        "created_at": d.created_at,
        "updated_at": d.updated_at,
    }


def version_meta(session: Session, kind: Kind[D, V], version: V) -> dict[str, Any]:
    """The fields every version shows (:class:`alcove.versioning.schemas.VersionMeta`)."""
    v: Any = version
    return {
        "version": v.version,
        "spec_hash": v.spec_hash,
        "note": v.note,
        "locked": is_used(session, kind, version),
        "created_at": v.created_at,
    }


def definition_used(session: Session, kind: Kind[D, V], definition: D) -> bool:
    ids = sa.select(kind.version.id).where(kind.parent_column == definition.id)
    locked = sa.exists().where(kind.parent_column == definition.id, kind.version.locked_at.is_not(None))
    return bool(session.scalar(sa.select(sa.or_(sa.exists().where(kind.campaign_column.in_(ids)), locked))))


def create(
    session: Session,
    kind: Kind[D, V],
    owner: User,
    *,
    name: str,
    description: str,
    spec: dict[str, Any],
    preset_key: str | None = None,
    note: str = "",
    **version_columns: Any,
) -> tuple[D, V]:
    definition = kind.definition(
        owner_id=owner.id, name=name, description=description, preset_key=preset_key, latest_version=1
    )
    session.add(definition)
    session.flush()
    version = kind.version(
        version=1,
        spec=spec,
        spec_hash=spec_hash(spec),
        note=note,
        created_by_id=owner.id,
        **{kind.parent_key: definition.id},
        **version_columns,
    )
    session.add(version)
    session.flush()
    return definition, version


def update(
    session: Session,
    kind: Kind[D, V],
    definition: D,
    user: User,
    *,
    name: str | None,
    description: str | None,
    spec: dict[str, Any] | None,
    note: str = "",
    **version_columns: Any,
) -> tuple[V, bool]:
    """Apply an edit; returns (latest version, whether a new version was created)."""
    if name is not None:
        definition.name = name
    if description is not None:
        definition.description = description
    current = latest(session, kind, definition)
    created = False
    if spec is not None:
        new_hash = spec_hash(spec)
        changed = new_hash != current.spec_hash or any(getattr(current, k) != v for k, v in version_columns.items())
        if changed:
            if is_used(session, kind, current):
                current = kind.version(
                    version=current.version + 1,
                    spec=spec,
                    spec_hash=new_hash,
                    note=note,
                    created_by_id=user.id,
                    **{kind.parent_key: definition.id},
                    **version_columns,
                )
                session.add(current)
                definition.latest_version = current.version
                created = True
            else:
                current.spec, current.spec_hash = spec, new_hash
                for k, v in version_columns.items():
                    setattr(current, k, v)
                if note:
                    current.note = note
    definition.updated_at = utcnow()
    session.flush()
    return current, created


def delete(session: Session, kind: Kind[D, V], definition: D) -> str:
    """Delete, or archive when a campaign uses it. Returns ``"deleted"`` or ``"archived"``."""
    if definition_used(session, kind, definition):
        definition.archived_at = definition.archived_at or utcnow()
        session.flush()
        return "archived"
    session.delete(definition)
    session.flush()
    return "deleted"


def preset_version_id(
    session: Session,
    kind: Kind[D, V],
    owner_id: int,
    preset_key: str,
    content_hash: str,
    version_fields: dict[str, Any],
) -> int | None:
    """The newest version of the owner's definitions copied from ``preset_key`` with this
    content (and these column values), if any."""
    definition_cls, version_cls = kind.definition, kind.version
    q = (
        sa.select(version_cls.id)
        .join(definition_cls, kind.parent_column == definition_cls.id)
        .where(
            definition_cls.owner_id == owner_id,
            definition_cls.preset_key == preset_key,
            version_cls.spec_hash == content_hash,
        )
    )
    for k, v in version_fields.items():
        q = q.where(getattr(version_cls, k) == v)
    return session.scalar(q.order_by(version_cls.id.desc()).limit(1))
