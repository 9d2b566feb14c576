"""Routes ``/tasks``: versioned task definitions, presets, JSON Schema, validation."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Path, Response, status

from alcove import versioning
from alcove.api.deps import SessionDep
from alcove.api.params import Limit, ObjectId, Offset, VersionNumber
from alcove.models import TaskDefinition, User
from alcove.science.ocp.task_spec import TaskSpec
from alcove.tasks import repository as repo
from alcove.tasks import service
from alcove.tasks.schemas import (
    ModelPresetOut,
    ScenarioOut,
    ScenarioPreviewIn,
    ScenarioPreviewOut,
    TaskDraft,
    TaskIn,
    TaskOut,
    TaskPresetOut,
    TaskUpdate,
    TaskVersionOut,
)
from alcove.users.auth import CurrentUser
from alcove.versioning.schemas import CheckReport, CopyPreset, FieldErrorOut

router = APIRouter(prefix="/tasks", tags=["tasks"])
PresetKey = Annotated[str, Path(min_length=1, max_length=100)]


def task_out(
    session: SessionDep, definition: TaskDefinition, version: Any, user: User, owner_email: str | None = None
) -> TaskOut:
    spec = TaskSpec.model_validate(version.spec)
    return TaskOut(
        **versioning.definition_meta(session, repo.KIND, definition, version, user, owner_email),
        spec=version.spec,
        n_phases=len(spec.phases),
        duration_s=spec.duration,
        intervals=spec.intervals,
    )


def version_out(session: SessionDep, version: Any) -> TaskVersionOut:
    return TaskVersionOut(
        **versioning.version_meta(session, repo.KIND, version),
        spec=version.spec,
    )


@router.get("", response_model=list[TaskOut], operation_id="list_tasks")
def list_tasks(
    user: CurrentUser, session: SessionDep, include_archived: bool = False, limit: Limit = 100, offset: Offset = 0
) -> list[TaskOut]:
    """Your task definitions and those shared with you (latest versions), newest first."""
    rows = repo.list_visible(session, user, include_archived=include_archived, limit=limit, offset=offset)
    return [task_out(session, d, v, user, email) for d, v, email in rows]


@router.post("", response_model=TaskOut, status_code=status.HTTP_201_CREATED, operation_id="create_task")
def create_task(body: TaskIn, user: CurrentUser, session: SessionDep) -> TaskOut:
    definition, version = service.create(
        session, user, name=body.name, description=body.description, spec=body.spec, note=body.note
    )
    session.commit()
    return task_out(session, definition, version, user, user.email)


@router.get("/presets", response_model=list[TaskPresetOut], operation_id="list_task_presets")
def list_task_presets(user: CurrentUser) -> list[TaskPresetOut]:
    """Built-in tasks (e.g. ``head-headrest-2phase``, the paper's proof of concept)."""
    return [TaskPresetOut(**p) for p in service.presets()]


@router.get("/model-presets", response_model=list[ModelPresetOut], operation_id="list_model_presets")
def list_model_presets(user: CurrentUser) -> list[ModelPresetOut]:
    """The model presets (``model.preset``) with all their parameters: the 1-DOF head-neck model and
    the n-DOF chains, each as the ``model`` of a task spec."""
    return [ModelPresetOut(**p) for p in service.model_presets()]


@router.post(
    "/presets/{key}/copy", response_model=TaskOut, status_code=status.HTTP_201_CREATED, operation_id="copy_task_preset"
)
def copy_task_preset(key: PresetKey, user: CurrentUser, session: SessionDep, body: CopyPreset | None = None) -> TaskOut:
    """Create your own editable task from a preset."""
    definition, version = service.copy_preset(session, user, key, body.name if body else None)
    session.commit()
    return task_out(session, definition, version, user, user.email)


@router.get("/schema", response_model=dict[str, Any], operation_id="get_task_schema")
def get_task_schema(user: CurrentUser) -> dict[str, Any]:
    """JSON Schema of a task's ``spec`` (for rendering the form)."""
    return service.json_schema()


@router.post("/check", response_model=CheckReport, operation_id="check_task")
def check_task(body: TaskDraft, user: CurrentUser) -> CheckReport:
    """Check a draft without saving: field-level errors (paths like ``spec.phases.1.duration``)."""
    valid, errors, normalized = service.check_draft(body.spec)
    return CheckReport(valid=valid, errors=[FieldErrorOut.of(e) for e in errors], normalized=normalized)


@router.get("/{task_id:integer}", response_model=TaskOut, operation_id="get_task")
def get_task(task_id: ObjectId, user: CurrentUser, session: SessionDep) -> TaskOut:
    definition = repo.get_task(session, task_id, user)
    return task_out(session, definition, repo.latest_version(session, definition), user)


@router.put("/{task_id:integer}", response_model=TaskOut, operation_id="update_task")
def update_task(task_id: ObjectId, body: TaskUpdate, user: CurrentUser, session: SessionDep) -> TaskOut:
    """Rename or edit. A changed ``spec`` edits the latest version while no campaign uses it,
    and otherwise creates a new version (used versions never change)."""
    definition, version, _ = service.update(
        session, user, task_id, name=body.name, description=body.description, spec=body.spec, note=body.note
    )
    session.commit()
    return task_out(session, definition, version, user)


@router.delete("/{task_id:integer}", status_code=status.HTTP_204_NO_CONTENT, operation_id="delete_task")
def delete_task(task_id: ObjectId, user: CurrentUser, session: SessionDep) -> Response:
    """Delete; a task used by a campaign is archived instead (hidden, kept for its campaigns)."""
    service.delete(session, user, task_id)
    session.commit()
    return Response(status_code=status.HTTP_204_NO_CONTENT)


@router.get("/{task_id:integer}/versions", response_model=list[TaskVersionOut], operation_id="list_task_versions")
def list_task_versions(task_id: ObjectId, user: CurrentUser, session: SessionDep) -> list[TaskVersionOut]:
    definition = repo.get_task(session, task_id, user)
    return [version_out(session, v) for v in repo.versions(session, definition)]


@router.get(
    "/{task_id:integer}/versions/{version:integer}", response_model=TaskVersionOut, operation_id="get_task_version"
)
def get_task_version(
    task_id: ObjectId, version: VersionNumber, user: CurrentUser, session: SessionDep
) -> TaskVersionOut:
    definition = repo.get_task(session, task_id, user)
    return version_out(session, repo.get_version(session, definition, version))


@router.post(
    "/{task_id:integer}/scenarios/preview", response_model=ScenarioPreviewOut, operation_id="preview_task_scenarios"
)
def preview_task_scenarios(
    task_id: ObjectId, body: ScenarioPreviewIn, user: CurrentUser, session: SessionDep
) -> ScenarioPreviewOut:
    """A few scenarios drawn from the task's ranges (or a draft ``spec``'s): those iterations
    1..n of a ``random-scenarios`` campaign with ``seed`` would solve. Nothing is saved."""
    definition = repo.get_task(session, task_id, user)
    raw = body.spec if body.spec is not None else repo.latest_version(session, definition).spec
    spec = service.require_valid(raw)
    scenarios = service.preview_scenarios(spec, body.n, body.seed)
    return ScenarioPreviewOut(
        seed=body.seed,
        ranges=[r.model_dump() for r in spec.ranges or []],
        scenarios=[ScenarioOut(**d) for d in scenarios],
    )
