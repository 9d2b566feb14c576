"""Task definitions: validation against :class:`TaskSpec`, versioned CRUD, presets."""

from __future__ import annotations

import json
import threading
from typing import Any

from cachetools import LRUCache, cached
from pydantic import ValidationError
from sqlalchemy.orm import Session

from alcove import versioning
from alcove.errors import FieldError, InvalidInput, NotFound, field_errors_from_pydantic
from alcove.models import TaskDefinition, TaskVersion, User
from alcove.science.ocp.task_spec import TASK_PRESETS, TaskSpec
from alcove.tasks import repository as repo
from alcove.users.access import can_edit

KIND = repo.KIND


def check_spec(spec: Any) -> tuple[TaskSpec | None, list[FieldError]]:
    """Validate a task spec; returns (spec, []) or (None, field errors under ``spec``)."""
    try:
        return TaskSpec.model_validate(spec), []
    except ValidationError as err:
        return None, field_errors_from_pydantic(err, base=("spec",))
    except (TypeError, ValueError) as err:  # defensive: a validator failing in an unexpected way
        return None, [FieldError(("spec",), str(err))]


def dump(spec: TaskSpec) -> dict[str, Any]:
    return spec.model_dump(mode="json")


def create(
    session: Session,
    owner: User,
    *,
    name: str,
    description: str,
    spec: TaskSpec,
    note: str = "",
    preset_key: str | None = None,
) -> tuple[TaskDefinition, Any]:
    return versioning.create(
        session, KIND, owner, name=name, description=description, spec=dump(spec), preset_key=preset_key, note=note
    )


def update(
    session: Session,
    user: User,
    task_id: int,
    *,
    name: str | None,
    description: str | None,
    spec: TaskSpec | None,
    note: str,
) -> tuple[TaskDefinition, Any, bool]:
    definition = repo.get_task(session, task_id, user, need="edit")
    version, created = versioning.update(
        session,
        KIND,
        definition,
        user,
        name=name,
        description=description,
        spec=None if spec is None else dump(spec),
        note=note,
    )
    return definition, version, created


def delete(session: Session, user: User, task_id: int) -> None:
    """Delete ``user``'s task; a task a campaign used is archived instead (hidden, kept for its
    campaigns). Never commits."""
    versioning.delete(session, KIND, repo.get_task(session, task_id, user, need="owner"))


MODEL_PRESET_DESCRIPTIONS = {
    "head-neck-1dof": "the paper's model: one joint (C7/T1) and the head, de Leva (1996) 50th percentile male",
    "head-neck-2dof": "neck link and head, joints C7/T1 and C0/C1 (parameters and sources: docs/multibody.md)",
    "trunk-neck-head-3dof": "trunk, neck and head, joints hip, C7/T1 and C0/C1 (docs/multibody.md)",
}


def model_presets() -> list[dict[str, Any]]:
    """The model presets, each as the ``model`` part of a task spec with every parameter filled in
    (what the task editor loads when the preset is chosen)."""
    from alcove.science.ocp.task_spec import ModelSpec

    out = []
    for key, description in MODEL_PRESET_DESCRIPTIONS.items():
        model = ModelSpec.model_validate({"preset": key})
        out.append({"key": key, "description": description, "ndof": model.ndof, "model": model.model_dump(mode="json")})
    return out


def presets() -> list[dict[str, Any]]:
    out = []
    for key, raw in TASK_PRESETS.items():
        spec = TaskSpec.model_validate(raw)
        out.append({"key": key, "name": spec.name, "description": spec.description, "spec": dump(spec)})
    return out


def copy_preset(session: Session, owner: User, key: str, name: str | None) -> tuple[TaskDefinition, Any]:
    if key not in TASK_PRESETS:
        raise NotFound("task preset", key)
    spec = TaskSpec.model_validate(TASK_PRESETS[key])
    return create(
        session,
        owner,
        name=name or spec.name,
        description=spec.description,
        spec=spec,
        preset_key=key,
        note=f"copied from preset {key}",
    )


def json_schema() -> dict[str, Any]:
    return TaskSpec.model_json_schema()


def check_draft(spec: Any) -> tuple[bool, list[FieldError], dict[str, Any] | None]:
    parsed, errors = check_spec(spec)
    return parsed is not None, errors, dump(parsed) if parsed is not None else None


def editable(session: Session, definition: TaskDefinition, user: User) -> bool:
    return can_edit(session, definition, user)


def require_valid(spec: Any) -> TaskSpec:
    parsed, errors = check_spec(spec)
    if parsed is None:
        raise InvalidInput(errors)
    return parsed


#: Parsed tasks by (the spec's canonical JSON, interval override): keyed by content, not by the
#: version id, so a process that sees several databases (or an id reused after a rollback on
#: SQLite) never gets another database's task.
@cached(
    LRUCache(maxsize=64),
    key=lambda spec, intervals: (json.dumps(spec, sort_keys=True), intervals),
    lock=threading.Lock(),
)
def _parsed_task(spec: dict[str, Any], intervals: int | None) -> TaskSpec:
    from alcove.science.ocp.task_spec import parse_task

    task = parse_task(spec)
    return task.with_intervals(intervals) if intervals else task


def load_task(s: Session, task_version_id: int, intervals: int | None = None) -> TaskSpec:
    """The task of a version as the OCP code uses it (optionally with another number of
    intervals per phase); each spec parsed once per process."""
    tv = s.get(TaskVersion, task_version_id)
    if tv is None:
        raise NotFound("task version", task_version_id)
    return _parsed_task(tv.spec, intervals)


def preview_scenarios(spec: TaskSpec, n: int, seed: int) -> list[dict[str, Any]]:
    """The scenarios iterations 1..n of a random-scenarios campaign with ``seed`` would solve
    (a task without ranges: n times the task itself). A drawn combination that is not a valid
    task is a field error on ``spec.ranges``."""
    from alcove.science.ocp.scenarios import preview
    from alcove.science.ocp.task_spec import TaskSpecError

    try:
        drawn = preview(spec, seed, n)
    except TaskSpecError as exc:
        raise InvalidInput([FieldError(("spec", *exc.field.split(".")), exc.reason)]) from exc
    return [
        {"iteration": sc.iteration, "values": sc.values, "spec": dump(sc.task.model_copy(update={"ranges": None}))}
        for sc in drawn
    ]
