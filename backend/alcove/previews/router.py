"""Routes for editor previews, run by workers:

* ``POST /tasks/{task_id}/previews``: solve the task once with the auxiliary contact (queue ``ocp``);
* ``POST /oracles/{oracle_id}/previews``: replay the FE reference head motion through the oracle (queue ``oracle``);
* ``GET /previews/{preview_id}`` (poll until ``succeeded`` or ``failed``), ``GET /previews``.

Both POSTs answer 202 with the pending preview (its job is recorded before it is sent: while
the broker is down it waits, ``status_detail`` says "waiting for the job queue", and it is sent
when the broker is back). The body may carry an unsaved edit
(``spec`` of the task, ``params`` of the oracle) so an editor can preview before saving;
it is validated like a save (422 naming the field). Previews are private to the user who
asked (others get 404); at most :data:`~alcove.previews.service.MAX_ACTIVE_PER_USER` may be
pending at once (429 with ``Retry-After``)."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Any, Literal

from fastapi import APIRouter, Body, Query, status
from pydantic import BaseModel, ConfigDict, Field
from sqlalchemy.orm import Session

from alcove.api.deps import SessionDep
from alcove.api.params import MAX_ID, ObjectId
from alcove.models import Preview, PreviewStatus
from alcove.previews import service
from alcove.users.auth import CurrentUser

router = APIRouter(tags=["previews"])

RATE_LIMITED: dict[int | str, dict[str, Any]] = {
    429: {
        "description": f"too many previews pending (at most {service.MAX_ACTIVE_PER_USER}): retry later",
        "content": {"application/json": {"schema": {"type": "object", "properties": {"detail": {"type": "string"}}}}},
    }
}


class _In(BaseModel):
    # strict: "1" is not a number and 1 or "true" not a boolean, as the schema says (JSON numbers still fill floats)
    model_config = ConfigDict(extra="forbid", strict=True)


class TaskPreviewIn(_In):
    version: int | None = Field(None, ge=1, le=MAX_ID, description="task version (default: the latest)")
    spec: dict[str, Any] | None = Field(
        None, description="an unsaved edit of the task's spec to preview instead of the saved one"
    )
    intervals: int | None = Field(
        None,
        ge=1,
        le=service.MAX_PREVIEW_INTERVALS,
        description=(
            "DMOCC intervals in every phase for this solve "
            f"(default: each phase's own, at most {service.MAX_PREVIEW_INTERVALS})"
        ),
    )


class OraclePreviewIn(_In):
    version: int | None = Field(None, ge=1, le=MAX_ID, description="oracle version (default: the latest)")
    params: dict[str, Any] | None = Field(
        None, description="an unsaved edit of the oracle's parameters to preview instead of the saved ones"
    )
    dt: float = Field(
        0.0025,
        ge=0.001,
        le=0.05,
        description="sampling step of the sample trajectory [s] (the FE reference motion, 1 s)",
    )


class TaskPreviewResult(BaseModel):
    """The solution on the OCP grid and the solver's summary."""

    t: list[float]
    q: list[list[float | None]]
    qd: list[list[float | None]]
    tau: list[list[float | None]] = Field(description="joint torque at the nodes [N m]")
    wrench: list[list[float | None]] | None = Field(
        None,
        description="(n, 6): the auxiliary contact's wrench on the head at the nodes, fx fy fz [N] and mx my mz "
        "[N m] about the head frame origin, in the headrest frame; null in previews made before it was recorded",
    )
    status: str
    converged: bool
    cost: float | None
    iterations: int
    constraint_violation: float | None
    wall_time_s: float
    intervals: int = Field(description="intervals over the whole task")
    intervals_per_phase: list[int] | None = Field(None, description="the grid solved on: intervals in each phase")
    grid: str | None = Field(None, description="the grid in words (the task's own, capped, or as asked)")


class SampleTrajectory(BaseModel):
    t: list[float]
    q: list[list[float | None]]
    qd: list[list[float | None]]


class OraclePreviewResult(BaseModel):
    """The sample motion, the oracle's force and moment on the head (headrest frame; null
    when the run failed) and its diagnostics."""

    ok: bool
    failure_reason: str | None
    wall_time_s: float
    trajectory: SampleTrajectory
    t: list[float] | None
    fx: list[float | None] | None
    fy: list[float | None] | None
    fz: list[float | None] | None
    mx: list[float | None] | None
    my: list[float | None] | None
    mz: list[float | None] | None
    peak_force_n: float | None
    diagnostics: dict[str, Any]


class PreviewOut(BaseModel):
    id: int
    kind: Literal["task", "oracle"]
    status: PreviewStatus
    task_version_id: int | None
    oracle_version_id: int | None
    draft: bool = Field(description="an unsaved edit was previewed")
    options: dict[str, Any]
    created_at: datetime
    started_at: datetime | None
    finished_at: datetime | None
    worker_name: str | None
    error: str | None = Field(description="why it failed (bad input found by the worker, solver or oracle error)")
    status_detail: str | None = Field(
        None,
        description=(
            "what a pending preview waits for: 'waiting for the job queue: ...' while the broker is not reachable "
            "(its job is kept and sent as soon as the broker is back), or 'waiting for a worker on queue ...'"
        ),
    )
    result: TaskPreviewResult | OraclePreviewResult | None = Field(
        None, description="set when succeeded (null in the list)"
    )


def preview_out(row: Preview, with_result: bool = True, detail: str | None = None) -> PreviewOut:
    result: Any = None
    if with_result and row.result is not None:
        result = (
            TaskPreviewResult.model_validate(row.result)
            if row.kind == "task"
            else OraclePreviewResult.model_validate(row.result)
        )
    return PreviewOut(
        id=row.id,
        kind=row.kind,
        status=row.status,
        task_version_id=row.task_version_id,
        oracle_version_id=row.oracle_version_id,
        draft=row.draft,
        options=row.options,
        created_at=row.created_at,
        started_at=row.started_at,
        finished_at=row.finished_at,
        worker_name=row.worker_name,
        error=row.error,
        status_detail=detail,
        result=result,
    )


def _out(session: Session, row: Preview) -> PreviewOut:
    return preview_out(row, detail=service.status_details(session, [row]).get(row.id))


@router.post(
    "/tasks/{task_id:integer}/previews",
    response_model=PreviewOut,
    status_code=status.HTTP_202_ACCEPTED,
    operation_id="create_task_preview",
    responses=RATE_LIMITED,
)
def create_task_preview(
    task_id: ObjectId, user: CurrentUser, session: SessionDep, body: Annotated[TaskPreviewIn | None, Body()] = None
) -> PreviewOut:
    """Solve the task once with the auxiliary contact, on a worker (queue ``ocp``); poll
    ``GET /previews/{id}`` for t, q, qd, tau and the solver's status, cost, iterations."""
    body = body or TaskPreviewIn()
    row = service.create_task_preview(
        session, user, task_id, version=body.version, spec=body.spec, intervals=body.intervals
    )
    session.commit()
    service.send(row.id)
    return _out(session, row)


@router.post(
    "/oracles/{oracle_id:integer}/previews",
    response_model=PreviewOut,
    status_code=status.HTTP_202_ACCEPTED,
    operation_id="create_oracle_preview",
    responses=RATE_LIMITED,
)
def create_oracle_preview(
    oracle_id: ObjectId, user: CurrentUser, session: SessionDep, body: Annotated[OraclePreviewIn | None, Body()] = None
) -> PreviewOut:
    """Replay a sample trajectory (the FE reference head motion) through the oracle, on a
    worker (queue ``oracle``); poll ``GET /previews/{id}`` for t, fx..mz and diagnostics."""
    body = body or OraclePreviewIn()
    row = service.create_oracle_preview(session, user, oracle_id, version=body.version, params=body.params, dt=body.dt)
    session.commit()
    service.send(row.id)
    return _out(session, row)


@router.get("/previews/{preview_id:integer}", response_model=PreviewOut, operation_id="get_preview")
def get_preview(preview_id: ObjectId, user: CurrentUser, session: SessionDep) -> PreviewOut:
    """One of your previews: status pending | running | succeeded | failed, result, error."""
    return _out(session, service.get(session, user, preview_id))


@router.get("/previews", response_model=list[PreviewOut], operation_id="list_previews")
def list_previews(
    user: CurrentUser, session: SessionDep, limit: Annotated[int, Query(ge=1, le=service.KEEP_PER_USER)] = 20
) -> list[PreviewOut]:
    """Your recent previews, newest first (without their results)."""
    rows = service.list_for(session, user, limit)
    details = service.status_details(session, rows)
    return [preview_out(r, with_result=False, detail=details.get(r.id)) for r in rows]
