"""Queries of oracle definitions (the shared versioned-definition queries of
:mod:`alcove.versioning`, for oracles) and of the administrators' command-oracle entries.
Never commits."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove import versioning
from alcove.models import CommandOracle, OracleDefinition, OracleRun, User
from alcove.users.access import Need, get_for

KIND = versioning.ORACLES


def get_oracle(s: Session, oracle_id: int, user: User, need: Need = "view") -> OracleDefinition:
    """The definition if ``user`` may ``need`` it (404 if not visible, 403 if not allowed)."""
    return get_for(s, OracleDefinition, oracle_id, user, need=need)


def list_visible(
    s: Session, user: User, *, include_archived: bool = False, limit: int = 100, offset: int = 0
) -> list[tuple[Any, Any, str]]:
    return versioning.list_visible(s, KIND, user, include_archived=include_archived, limit=limit, offset=offset)


def latest_version(s: Session, definition: OracleDefinition) -> Any:
    return versioning.latest(s, KIND, definition)


def versions(s: Session, definition: OracleDefinition) -> Sequence[Any]:
    return versioning.versions(s, KIND, definition)


def get_version(s: Session, definition: OracleDefinition, number: int) -> Any:
    return versioning.get_version(s, KIND, definition, number)


def is_used(s: Session, version: Any) -> bool:
    return versioning.is_used(s, KIND, version)


# ----------------------------------------------------------------------------- command oracles


def get_command(s: Session, entry_id: int) -> CommandOracle | None:
    return s.get(CommandOracle, entry_id)


def command_exists(s: Session, name: str) -> bool:
    return s.scalar(sa.select(CommandOracle.id).where(CommandOracle.name == name)) is not None


def commands(s: Session, *, enabled_only: bool = False) -> list[CommandOracle]:
    q = sa.select(CommandOracle).order_by(CommandOracle.name)
    if enabled_only:
        q = q.where(CommandOracle.enabled.is_(True))
    return list(s.scalars(q))


def add_command(s: Session, row: CommandOracle) -> CommandOracle:
    s.add(row)
    s.flush()
    return row


def delete_command(s: Session, row: CommandOracle) -> None:
    s.delete(row)


def runs_of_iteration(s: Session, iteration_id: int) -> list[OracleRun]:
    """Every oracle run (attempt) of a campaign iteration, in order."""
    q = sa.select(OracleRun).where(OracleRun.iteration_id == iteration_id).order_by(OracleRun.attempt)
    return list(s.scalars(q))


def replayed_input(s: Session, iteration_id: int) -> str | None:
    """The blob of the motion (t, q, qd, tau) the iteration's accepted oracle run replayed."""
    q = sa.select(OracleRun.input_sha256).where(OracleRun.iteration_id == iteration_id, OracleRun.status == "ok")
    return s.scalar(q.order_by(OracleRun.id.desc()).limit(1))
