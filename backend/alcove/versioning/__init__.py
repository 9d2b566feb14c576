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
from typing import Any

import sqlalchemy as sa
from sqlalchemy.orm import InstrumentedAttribute, Session

from alcove.errors import NotFound
from alcove.models import (
    Campaign,
    OracleDefinition,
    OracleVersion,
    SurrogateConfig,
    SurrogateConfigVersion,
    TaskDefinition,
    TaskVersion,
    User,
    spec_hash,
    utcnow,
)
from alcove.users.access import visible_clause


@dataclass(frozen=True)
class Kind:
    label: str
    definition: type
    version: type
    parent_key: str  # name of the version's foreign key to its definition
    campaign_column: InstrumentedAttribute

    @property
    def parent_column(self) -> InstrumentedAttribute:
        return getattr(self.version, self.parent_key)


TASKS = Kind("task", TaskDefinition, TaskVersion, "definition_id", Campaign.task_version_id)
ORACLES = Kind("oracle", OracleDefinition, OracleVersion, "definition_id", Campaign.oracle_version_id)
SURROGATE_CONFIGS = Kind(
    "surrogate config", SurrogateConfig, SurrogateConfigVersion, "config_id", Campaign.surrogate_config_version_id
)


def list_visible(
    session: Session,
    kind: Kind,
    user: User,
    *,
    include_archived: bool = False,
    limit: int = 100,
    offset: int = 0,
    extra: Sequence[Any] = (),
) -> list[tuple[Any, Any, str]]:
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
    return [tuple(r) for r in session.execute(q).all()]  # type: ignore[misc]


def latest(session: Session, kind: Kind, definition: Any) -> Any:
    return get_version(session, kind, definition, definition.latest_version)


def get_version(session: Session, kind: Kind, definition: Any, number: int) -> Any:
    row = session.scalar(
        sa.select(kind.version).where(kind.parent_column == definition.id, kind.version.version == number)
    )
    if row is None:
        raise NotFound(f"{kind.label} {definition.id} version", number)
    return row


def versions(session: Session, kind: Kind, definition: Any) -> Sequence[Any]:
    return session.scalars(
        sa.select(kind.version).where(kind.parent_column == definition.id).order_by(kind.version.version)
    ).all()


def is_used(session: Session, kind: Kind, version: Any) -> bool:
    """A version is immutable once locked by the engine or referenced by any campaign."""
    if version.locked_at is not None:
        return True
    return session.scalar(sa.select(sa.exists().where(kind.campaign_column == version.id))) or False


def definition_used(session: Session, kind: Kind, definition: Any) -> bool:
    ids = sa.select(kind.version.id).where(kind.parent_column == definition.id)
    locked = sa.exists().where(kind.parent_column == definition.id, kind.version.locked_at.is_not(None))
    return bool(session.scalar(sa.select(sa.or_(sa.exists().where(kind.campaign_column.in_(ids)), locked))))


def create(
    session: Session,
    kind: Kind,
    owner: User,
    *,
    name: str,
    description: str,
    spec: dict[str, Any],
    preset_key: str | None = None,
    note: str = "",
    **version_columns: Any,
) -> tuple[Any, Any]:
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
    kind: Kind,
    definition: Any,
    user: User,
    *,
    name: str | None,
    description: str | None,
    spec: dict[str, Any] | None,
    note: str = "",
    **version_columns: Any,
) -> tuple[Any, bool]:
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


def delete(session: Session, kind: Kind, definition: Any) -> str:
    """Delete, or archive when a campaign uses it. Returns ``"deleted"`` or ``"archived"``."""
    if definition_used(session, kind, definition):
        definition.archived_at = definition.archived_at or utcnow()
        session.flush()
        return "archived"
    session.delete(definition)
    session.flush()
    return "deleted"
