"""What a user may build a campaign from: definitions and versions they can see, datasets
they uploaded. Each check raises :class:`InvalidInput` naming the request's field."""

from __future__ import annotations

from typing import Any

from sqlalchemy.orm import Session

from alcove import versioning
from alcove.api.params import MAX_ID
from alcove.errors import InvalidInput, NotFound
from alcove.models import User
from alcove.pool import repository as pool_repo
from alcove.users.access import get_for

#: Request fields that name a definition version directly, and the kind of definition.
VERSION_FIELDS: dict[str, versioning.Kind[versioning.DefinitionRow, versioning.VersionRow]] = {
    "task_version_id": versioning.TASKS,
    "oracle_version_id": versioning.ORACLES,
    "surrogate_config_version_id": versioning.SURROGATE_CONFIGS,
}


def version_id(
    session: Session,
    user: User,
    kind: versioning.Kind[versioning.DefinitionRow, versioning.VersionRow],
    definition_id: int,
    number: int | None,
    field: str,
) -> int:
    """The id of version ``number`` (default: the latest) of a definition the user may see;
    ``field`` names the request's field (``task_id``, ...)."""
    try:
        definition = get_for(session, kind.definition, definition_id, user)
    except NotFound:
        raise InvalidInput.one(field, f"no such {field.removesuffix('_id')} (or not shared with you)") from None
    n = number or definition.latest_version
    try:
        return int(versioning.get_version(session, kind, definition, n).id)
    except NotFound:
        raise InvalidInput.one(field.removesuffix("_id") + "_version", f"version {n} does not exist") from None


def check_version_ids(session: Session, user: User, body: Any, fields: list[str]) -> None:
    """Version ids given directly (config update, fork) must belong to definitions the user may see."""
    for field in fields:
        vid = getattr(body, field, None)
        if vid is None:
            continue
        kind = VERSION_FIELDS[field]
        row = session.get(kind.version, vid) if 1 <= vid <= MAX_ID else None
        try:
            if row is None:
                raise NotFound(field, vid)
            get_for(session, kind.definition, getattr(row, kind.parent_key), user)
        except NotFound:
            raise InvalidInput.one(field, f"no such version {vid} (or not shared with you)") from None


def check_datasets(session: Session, user: User, ids: list[int] | None, task_version_id: int | None = None) -> None:
    """Preliminary datasets must be the user's own uploads, with values within the range of
    the campaign's task model (task version ``task_version_id``) when given."""
    if not ids:
        return
    owned = pool_repo.owned_dataset_ids(session, user.id, ids)
    for i, ident in enumerate(ids):
        if ident not in owned:
            raise InvalidInput.one(f"preliminary.dataset_ids.{i}", f"no uploaded dataset {ident} of yours")
    if task_version_id is None:
        return
    from alcove.models import TaskVersion
    from alcove.pool import service as pool_service
    from alcove.science.surrogate.dataset import PoolDataError

    version = session.get(TaskVersion, task_version_id)
    assert version is not None  # resolved by version_id() before
    state = pool_service.state_range_of_task(version.spec)
    for i, dataset in enumerate(pool_repo.datasets(session, ids)):
        try:
            pool_service.check_datasets_plausible(session, [dataset], state)
        except PoolDataError as err:
            raise InvalidInput.one(f"preliminary.dataset_ids.{i}", f"dataset {dataset.id}: {err}") from None
