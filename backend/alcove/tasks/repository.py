"""Queries of task definitions (the shared versioned-definition queries of
:mod:`alcove.versioning`, for tasks). Never commits."""

from __future__ import annotations

from collections.abc import Sequence

from sqlalchemy.orm import Session

from alcove import versioning
from alcove.models import TaskDefinition, TaskVersion, User
from alcove.users.access import Need, get_for

KIND = versioning.TASKS


def get_task(s: Session, task_id: int, user: User, need: Need = "view") -> TaskDefinition:
    """The definition if ``user`` may ``need`` it (404 if not visible, 403 if not allowed)."""
    return get_for(s, TaskDefinition, task_id, user, need=need)


def list_visible(
    s: Session, user: User, *, include_archived: bool = False, limit: int = 100, offset: int = 0
) -> list[tuple[TaskDefinition, TaskVersion, str]]:
    return versioning.list_visible(s, KIND, user, include_archived=include_archived, limit=limit, offset=offset)


def latest_version(s: Session, definition: TaskDefinition) -> TaskVersion:
    return versioning.latest(s, KIND, definition)


def versions(s: Session, definition: TaskDefinition) -> Sequence[TaskVersion]:
    return versioning.versions(s, KIND, definition)


def get_version(s: Session, definition: TaskDefinition, number: int) -> TaskVersion:
    return versioning.get_version(s, KIND, definition, number)


def is_used(s: Session, version: TaskVersion) -> bool:
    return versioning.is_used(s, KIND, version)
