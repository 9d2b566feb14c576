"""Who may see and change which object.

A user sees the objects they own and those shared with them (``shares``); anything else
answers 404, exactly as if it did not exist. ``edit`` needs ownership or an ``edit`` share
(403 otherwise); deleting and sharing need ownership. Admins manage users and the command
catalogue, but get no special access to members' objects.
"""

from __future__ import annotations

from typing import Literal, TypeVar

import sqlalchemy as sa
from sqlalchemy.orm import InstrumentedAttribute, Session

from alcove.errors import NotFound, PermissionDenied
from alcove.models import (
    Base,
    Campaign,
    OracleDefinition,
    Share,
    SharePermission,
    SurrogateConfigDefinition,
    TaskDefinition,
    User,
)

#: the objects that can be owned and shared
Shareable = TaskDefinition | OracleDefinition | SurrogateConfigDefinition | Campaign
T = TypeVar("T", bound=Shareable)

Need = Literal["view", "edit", "owner"]

# keyed by type[Base]: mypy does not see type[T] (T bound to the union) as one of the union's classes
SHARE_COLUMN: dict[type[Base], InstrumentedAttribute[int | None]] = {
    TaskDefinition: Share.task_definition_id,
    OracleDefinition: Share.oracle_definition_id,
    SurrogateConfigDefinition: Share.surrogate_config_id,
    Campaign: Share.campaign_id,
}
OBJECT_TYPES: dict[str, type[Shareable]] = {
    "task": TaskDefinition,
    "oracle": OracleDefinition,
    "surrogate_config": SurrogateConfigDefinition,
    "campaign": Campaign,
}
LABEL: dict[type[Base], str] = {
    TaskDefinition: "task",
    OracleDefinition: "oracle",
    SurrogateConfigDefinition: "surrogate config",
    Campaign: "campaign",
}


def visible_clause(model: type[T], user: User) -> sa.ColumnElement[bool]:
    """SQL condition: ``model`` rows that ``user`` may see."""
    shared = sa.select(SHARE_COLUMN[model]).where(Share.user_id == user.id, SHARE_COLUMN[model].is_not(None))
    return sa.or_(model.owner_id == user.id, model.id.in_(shared))


def share_permission(session: Session, model: type[T], object_id: int, user: User) -> str | None:
    return session.scalar(sa.select(Share.permission).where(Share.user_id == user.id, SHARE_COLUMN[model] == object_id))


def get_for(session: Session, model: type[T], object_id: int, user: User, need: Need = "view") -> T:
    """The object if ``user`` may ``need`` it: 404 if not visible, 403 if visible but not allowed."""
    obj = session.get(model, object_id)
    if obj is None:
        raise NotFound(LABEL[model], object_id)
    if obj.owner_id == user.id:
        return obj
    permission = share_permission(session, model, object_id, user)
    if permission is None:
        raise NotFound(LABEL[model], object_id)
    if need == "owner" or (need == "edit" and permission != SharePermission.edit.value):
        raise PermissionDenied(f"{LABEL[model]} {object_id} is shared with you for {permission} only")
    return obj


def can_edit(session: Session, obj: T, user: User) -> bool:
    if obj.owner_id == user.id:
        return True
    return share_permission(session, type(obj), obj.id, user) == SharePermission.edit.value
