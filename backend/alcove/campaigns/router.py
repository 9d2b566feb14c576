"""Routes ``/campaigns/...``: lifecycle, metrics, iterations, jobs, events and the export, on
the campaign engine's services (:mod:`alcove.campaigns.service`). The route opens the
transaction, calls the service, commits, then sends the jobs the commit made necessary.
Pool versions are served by :mod:`alcove.pool.router`, model versions by
:mod:`alcove.surrogates.router`."""

from __future__ import annotations

import io
import logging
import zipfile
from datetime import datetime
from typing import Annotated, Any, Literal

import sqlalchemy as sa
from fastapi import APIRouter, Body, Query, Request, Response, status
from pydantic import BaseModel, ConfigDict, Field, TypeAdapter
from sqlalchemy.orm import Session, aliased
from starlette.concurrency import run_in_threadpool

from alcove.api.auth import CurrentUser
from alcove.api.caching import NOT_MODIFIED, TtlCache, cached_json, read
from alcove.api.deps import SessionDep
from alcove.api.downloads import BINARY, download
from alcove.api.params import MAX_ID, IterationIndex, Limit, ObjectId, Offset
from alcove.campaigns import repository as repo
from alcove.campaigns import service as campaigns
from alcove.campaigns.schemas import (
    CampaignConfigUpdate,
    CampaignDetail,
    EventRead,
    ForkRequest,
    IterationCurves,
    IterationRead,
    IterationTrajectory,
    MetricsRead,
    Policies,
    PreliminaryConfig,
    RunSettings,
    StepRead,
    StoppingRules,
)
from alcove.db import get_sessionmaker
from alcove.errors import Conflict, InvalidInput, NotFound
from alcove.models import (
    Campaign,
    CampaignEvent,
    CampaignStatus,
    Dataset,
    Iteration,
    IterationMetrics,
    IterationStatus,
    IterationStep,
    OcpSolution,
    OracleDefinition,
    OracleVersion,
    Share,
    SharePermission,
    StepName,
    SurrogateConfig,
    SurrogateConfigVersion,
    TaskDefinition,
    TaskVersion,
    User,
)
from alcove.users.access import can_edit, get_for, visible_clause

log = logging.getLogger(__name__)

router = APIRouter(prefix="/campaigns", tags=["campaigns"])


# ----------------------------------------------------------------------------- bodies


class _In(BaseModel):
    model_config = ConfigDict(extra="forbid")


class CampaignCreateIn(_In):
    """A campaign of one of your (or shared) tasks and oracles. Versions default to the latest;
    the surrogate config defaults to the paper's."""

    name: str = Field(min_length=1, max_length=200)
    description: str = Field("", max_length=20_000)
    task_id: int = Field(ge=1, le=MAX_ID)
    task_version: int | None = Field(None, ge=1, le=MAX_ID)
    oracle_id: int = Field(ge=1, le=MAX_ID)
    oracle_version: int | None = Field(None, ge=1, le=MAX_ID)
    surrogate_config_id: int | None = Field(None, ge=1, le=MAX_ID)
    surrogate_config_version: int | None = Field(None, ge=1, le=MAX_ID)
    seed: int = Field(0, ge=0, lt=2**62)
    preliminary: PreliminaryConfig = Field(default_factory=PreliminaryConfig)
    stopping: StoppingRules = Field(default_factory=StoppingRules)
    policies: Policies = Field(default_factory=Policies)
    settings: RunSettings = Field(default_factory=RunSettings)
    start: bool = Field(False, description="start right away")


class RetryIn(_In):
    iteration: int | None = Field(None, ge=0, le=MAX_ID)
    step: StepName | None = None


class CampaignSummary(BaseModel):
    id: int
    name: str
    status: CampaignStatus
    owner_id: int
    owner: str
    task_id: int
    task: str
    task_version: int
    oracle_id: int
    oracle: str
    oracle_type: str
    oracle_version: int
    current_iteration: int
    current_step: str | None
    max_iterations: int | None
    latest_iteration: int | None = Field(None, description="index of the latest iteration with metrics")
    force_rmse: float | None = Field(description="latest iteration's force RMSE [N]")
    moment_rmse: float | None = Field(description="latest iteration's moment RMSE [N m]")
    mean_iteration_s: float | None = Field(None, description="mean wall time of the last 20 finished iterations [s]")
    eta_s: float | None = Field(
        None,
        description="remaining iterations (max_iterations rule) x mean iteration time [s]; null when finished or unknown",
    )
    source_campaign_id: int | None
    source_iteration: int | None
    created_at: datetime
    started_at: datetime | None
    finished_at: datetime | None


class CampaignOut(CampaignDetail):
    id: int = Field(description="the campaign's id (= campaign.id)")
    owner: str
    can_edit: bool
    task_id: int
    task_version: int
    oracle_id: int
    oracle_version: int


class JobOut(StepRead):
    iteration: int


# ----------------------------------------------------------------------------- helpers


METRICS_LIST = TypeAdapter(list[MetricsRead])
ITERATION_LIST = TypeAdapter(list[IterationRead])


def _send(jobs: list[Any]) -> None:
    """Send jobs after commit. A failed send is not lost: the steps are queued in the
    database and the reconciler re-sends queued steps nobody claimed."""
    if not jobs:
        return
    from alcove.jobs.campaign import enqueue

    try:
        enqueue(jobs)
    except Exception:
        log.exception("sending %d job(s) failed; the reconciler will re-send them", len(jobs))


def _version_id(
    session: Session,
    user: User,
    definition_model: type,
    version_model: type,
    parent_key: str,
    definition_id: int,
    number: int | None,
    field: str,
) -> int:
    try:
        d = get_for(session, definition_model, definition_id, user)
    except NotFound:
        raise InvalidInput.one(field, f"no such {field.removesuffix('_id')} (or not shared with you)") from None
    n = number or d.latest_version
    vid = session.scalar(
        sa.select(version_model.id).where(getattr(version_model, parent_key) == d.id, version_model.version == n)
    )
    if vid is None:
        raise InvalidInput.one(field.removesuffix("_id") + "_version", f"version {n} does not exist")
    return vid


def _check_version_ids(session: Session, user: User, body: Any, fields: dict[str, tuple[type, type, str]]) -> None:
    """Version ids given directly (config update, fork) must belong to visible definitions."""
    for field, (version_model, definition_model, parent_key) in fields.items():
        vid = getattr(body, field, None)
        if vid is None:
            continue
        row = session.get(version_model, vid) if 1 <= vid <= MAX_ID else None
        try:
            if row is None:
                raise NotFound(field, vid)
            get_for(session, definition_model, getattr(row, parent_key), user)
        except NotFound:
            raise InvalidInput.one(field, f"no such version {vid} (or not shared with you)") from None


VERSION_FIELDS = {
    "task_version_id": (TaskVersion, TaskDefinition, "definition_id"),
    "oracle_version_id": (OracleVersion, OracleDefinition, "definition_id"),
    "surrogate_config_version_id": (SurrogateConfigVersion, SurrogateConfig, "config_id"),
}


def _check_datasets(session: Session, user: User, ids: list[int] | None) -> None:
    if not ids:
        return
    owned = set(session.scalars(sa.select(Dataset.id).where(Dataset.id.in_(ids), Dataset.owner_id == user.id)))
    for i, ident in enumerate(ids):
        if ident not in owned:
            raise InvalidInput.one(f"preliminary.dataset_ids.{i}", f"no uploaded dataset {ident} of yours")


def _campaign_out(session: Session, campaign: Campaign, user: User) -> CampaignOut:
    detail = campaigns.get_detail(session, campaign.id)
    tv = session.get(TaskVersion, campaign.task_version_id)
    ov = session.get(OracleVersion, campaign.oracle_version_id)
    owner = session.get(User, campaign.owner_id)
    return CampaignOut(
        **detail.model_dump(),
        id=campaign.id,
        owner=owner.email if owner else "",
        can_edit=can_edit(session, campaign, user),
        task_id=tv.definition_id,
        task_version=tv.version,
        oracle_id=ov.definition_id,
        oracle_version=ov.version,
    )


# ----------------------------------------------------------------------------- campaigns


@router.get("", response_model=list[CampaignSummary], operation_id="list_campaigns")
def list_campaigns(
    user: CurrentUser,
    session: SessionDep,
    status_: Annotated[CampaignStatus | None, Query(alias="status")] = None,
    owner: Literal["any", "me", "shared"] = "any",
    task_id: Annotated[int | None, Query(ge=1, le=MAX_ID)] = None,
    limit: Limit = 100,
    offset: Offset = 0,
) -> list[CampaignSummary]:
    """Campaigns you own or that are shared with you, newest first, with their latest RMSE."""
    latest = (
        sa.select(IterationMetrics.campaign_id, sa.func.max(IterationMetrics.iteration_index).label("k"))
        .group_by(IterationMetrics.campaign_id)
        .subquery()
    )
    q = (
        sa.select(
            Campaign,
            User.email,
            TaskVersion,
            TaskDefinition.name,
            OracleVersion,
            OracleDefinition.name,
            latest.c.k,
            IterationMetrics.force_rmse,
            IterationMetrics.moment_rmse,
        )
        .join(User, User.id == Campaign.owner_id)
        .join(TaskVersion, TaskVersion.id == Campaign.task_version_id)
        .join(TaskDefinition, TaskDefinition.id == TaskVersion.definition_id)
        .join(OracleVersion, OracleVersion.id == Campaign.oracle_version_id)
        .join(OracleDefinition, OracleDefinition.id == OracleVersion.definition_id)
        .outerjoin(latest, latest.c.campaign_id == Campaign.id)
        .outerjoin(
            IterationMetrics,
            sa.and_(IterationMetrics.campaign_id == Campaign.id, IterationMetrics.iteration_index == latest.c.k),
        )
        .where(visible_clause(Campaign, user))
        .order_by(Campaign.id.desc())
        .limit(limit)
        .offset(offset)
    )
    if status_ is not None:
        q = q.where(Campaign.status == status_.value)
    if owner == "me":
        q = q.where(Campaign.owner_id == user.id)
    elif owner == "shared":
        q = q.where(Campaign.owner_id != user.id)
    if task_id is not None:
        q = q.where(TaskVersion.definition_id == task_id)
    rows = session.execute(q).all()
    timing = _iteration_timing(session, [r[0].id for r in rows])
    out = []
    for c, email, tv, tname, ov, oname, k_latest, frmse, mrmse in rows:
        max_iterations = (c.stopping_rules or {}).get("max_iterations")
        mean, eta = _eta(c, max_iterations, *timing.get(c.id, (None, None)))
        out.append(
            CampaignSummary(
                id=c.id,
                name=c.name,
                status=c.status,
                owner_id=c.owner_id,
                owner=email,
                task_id=tv.definition_id,
                task=tname,
                task_version=tv.version,
                oracle_id=ov.definition_id,
                oracle=oname,
                oracle_type=ov.oracle_type,
                oracle_version=ov.version,
                current_iteration=c.current_iteration,
                current_step=c.current_step,
                max_iterations=max_iterations,
                latest_iteration=k_latest,
                force_rmse=frmse,
                moment_rmse=mrmse,
                mean_iteration_s=mean,
                eta_s=eta,
                source_campaign_id=c.source_campaign_id,
                source_iteration=c.source_iteration,
                created_at=c.created_at,
                started_at=c.started_at,
                finished_at=c.finished_at,
            )
        )
    return out


def _iteration_timing(session: Session, campaign_ids: list[int]) -> dict[int, tuple[int, list[float]]]:
    """For each campaign: the index of its last finished iteration and the wall times of its
    last 20 finished iterations (one query for the whole page; the same rule as the detail's ETA)."""
    if not campaign_ids:
        return {}
    finished = (IterationStatus.succeeded.value, IterationStatus.failed.value)
    ranked = (
        sa.select(
            Iteration.campaign_id,
            Iteration.index,
            Iteration.started_at,
            Iteration.finished_at,
            sa.func.row_number().over(partition_by=Iteration.campaign_id, order_by=Iteration.index.desc()).label("rn"),
        )
        .where(
            Iteration.campaign_id.in_(campaign_ids),
            Iteration.index > 0,
            Iteration.status.in_(finished),
            Iteration.started_at.is_not(None),
            Iteration.finished_at.is_not(None),
        )
        .subquery()
    )
    out: dict[int, tuple[int, list[float]]] = {}
    for cid, k, a, b, _ in session.execute(
        sa.select(ranked).where(ranked.c.rn <= 20).order_by(ranked.c.campaign_id, ranked.c.rn)
    ):
        last, times = out.setdefault(cid, (k, []))
        times.append((b - a).total_seconds())
    return out


def _eta(
    c: Campaign, max_iterations: int | None, last_done: int | None, times: list[float] | None
) -> tuple[float | None, float | None]:
    if not times:
        return None, None
    mean = sum(times) / len(times)
    if max_iterations is None or c.is_terminal:
        return mean, None
    return mean, max(max_iterations - (last_done if last_done is not None else (c.source_iteration or 0)), 0) * mean


@router.post("", response_model=CampaignOut, status_code=status.HTTP_201_CREATED, operation_id="create_campaign")
def create_campaign(body: CampaignCreateIn, user: CurrentUser, session: SessionDep) -> CampaignOut:
    from alcove.campaigns.schemas import CampaignCreate

    task_version_id = _version_id(
        session, user, TaskDefinition, TaskVersion, "definition_id", body.task_id, body.task_version, "task_id"
    )
    oracle_version_id = _version_id(
        session,
        user,
        OracleDefinition,
        OracleVersion,
        "definition_id",
        body.oracle_id,
        body.oracle_version,
        "oracle_id",
    )
    if body.surrogate_config_id is not None:
        scv_id = _version_id(
            session,
            user,
            SurrogateConfig,
            SurrogateConfigVersion,
            "config_id",
            body.surrogate_config_id,
            body.surrogate_config_version,
            "surrogate_config_id",
        )
    else:
        from alcove.campaigns.presets import surrogate_config_version_for

        scv_id = surrogate_config_version_for(session, user.id, None)
    _check_datasets(session, user, body.preliminary.dataset_ids)
    data = CampaignCreate(
        name=body.name,
        description=body.description,
        task_version_id=task_version_id,
        oracle_version_id=oracle_version_id,
        surrogate_config_version_id=scv_id,
        seed=body.seed,
        preliminary=body.preliminary,
        stopping=body.stopping,
        policies=body.policies,
        settings=body.settings,
    )
    campaign = campaigns.create_campaign(session, user.id, data)
    jobs: list[Any] = []
    if body.start:
        campaign, jobs = campaigns.start(session, campaign.id)
    session.commit()
    _send(jobs)
    return _campaign_out(session, campaign, user)


@router.get("/{campaign_id}", response_model=CampaignOut, operation_id="get_campaign", responses=NOT_MODIFIED)
async def get_campaign(campaign_id: ObjectId, user: CurrentUser, request: Request) -> Response:
    """Status, current iteration and step, latest metrics, ETA. Polled: answers carry an
    ``ETag``; send it back as ``If-None-Match`` and an unchanged campaign is a bodiless 304."""
    # read on every request (no reuse window): a pause or a finished step shows at once
    revision = await run_in_threadpool(read, _detail_revision, campaign_id, user.id)
    if revision is None:
        raise NotFound("campaign", campaign_id)
    key = ("detail", campaign_id, *revision)

    def build() -> bytes:
        with get_sessionmaker()() as session:
            return (
                _campaign_out(session, get_for(session, Campaign, campaign_id, user), user).model_dump_json().encode()
            )

    return await cached_json(request, key, build)


@router.patch("/{campaign_id}/config", response_model=CampaignOut, operation_id="update_campaign_config")
def update_campaign_config(
    campaign_id: ObjectId, body: CampaignConfigUpdate, user: CurrentUser, session: SessionDep
) -> CampaignOut:
    """Edit settings: records a new config version, used by iterations created from now on."""
    campaign = get_for(session, Campaign, campaign_id, user, need="edit")
    _check_version_ids(
        session, user, body, {"surrogate_config_version_id": VERSION_FIELDS["surrogate_config_version_id"]}
    )
    campaigns.update_config(session, campaign.id, body, user.id)
    session.commit()
    return _campaign_out(session, campaign, user)


def _action(name: str, summary: str):
    fn = getattr(campaigns, name)

    def route(campaign_id: ObjectId, user: CurrentUser, session: SessionDep) -> CampaignOut:
        campaign = get_for(session, Campaign, campaign_id, user, need="edit")
        campaign, jobs = fn(session, campaign.id)
        session.commit()
        _send(jobs)
        return _campaign_out(session, campaign, user)

    route.__name__ = f"{name}_campaign"
    route.__doc__ = summary
    router.add_api_route(
        f"/{{campaign_id}}/{name}",
        route,
        methods=["POST"],
        response_model=CampaignOut,
        operation_id=f"{name}_campaign",
        summary=summary.split(".")[0],
    )


_action("start", "Start a draft campaign: the preliminary step (or, for a fork, the first training) is queued.")
_action("pause", "Pause after the running step finishes.")
_action("resume", "Resume a paused campaign.")
_action("cancel", "Cancel: queued steps are dropped, a running job stops at its next check.")


@router.post("/{campaign_id}/retry", response_model=CampaignOut, operation_id="retry_campaign_step")
def retry_campaign_step(
    campaign_id: ObjectId, user: CurrentUser, session: SessionDep, body: Annotated[RetryIn | None, Body()] = None
) -> CampaignOut:
    """Run a failed step again (default: the step that failed the campaign); 409 when nothing has failed."""
    campaign = get_for(session, Campaign, campaign_id, user, need="edit")
    body = body or RetryIn()
    if (body.iteration is None) != (body.step is None):
        raise InvalidInput.one("step" if body.step is None else "iteration", "give both iteration and step, or neither")
    from alcove.campaigns.repository import NotFound as NoSuchRow

    try:
        campaign, jobs = campaigns.retry_step(
            session, campaign.id, body.iteration, body.step.value if body.step else None
        )
    except (NotFound, NoSuchRow):
        # the campaign exists and is visible (checked above): nothing has failed
        if body.iteration is None:
            raise Conflict(
                f"nothing to retry: no step of campaign {campaign_id} has failed (campaign status: {campaign.status})"
            ) from None
        raise Conflict(
            f"nothing to retry: step {body.step.value} of iteration {body.iteration} has not failed"
        ) from None
    session.commit()
    _send(jobs)
    return _campaign_out(session, campaign, user)


@router.post(
    "/{campaign_id}/fork", response_model=CampaignOut, status_code=status.HTTP_201_CREATED, operation_id="fork_campaign"
)
def fork_campaign(campaign_id: ObjectId, body: ForkRequest, user: CurrentUser, session: SessionDep) -> CampaignOut:
    """A new campaign of yours continuing from iteration k of this one (its pool and model),
    with changed settings."""
    source = get_for(session, Campaign, campaign_id, user)
    _check_version_ids(session, user, body, VERSION_FIELDS)
    if body.iteration > MAX_ID:
        raise InvalidInput.one("iteration", "too large")
    campaign, jobs = campaigns.fork(session, source.id, body, user.id)
    session.commit()
    _send(jobs)
    return _campaign_out(session, campaign, user)


# ----------------------------------------------------------------------------- iterations, metrics, jobs, events

After = Annotated[
    int | None, Query(ge=-1, le=MAX_ID, description="only iterations with index > after (poll incrementally)")
]


@router.get(
    "/{campaign_id}/metrics",
    response_model=list[MetricsRead],
    operation_id="list_campaign_metrics",
    responses=NOT_MODIFIED,
)
async def list_campaign_metrics(
    campaign_id: ObjectId,
    user: CurrentUser,
    request: Request,
    after: After = None,
    extra: Annotated[
        bool,
        Query(
            description="include each row's `extra` (software versions, per-component RMSE, step timings); null otherwise"
        ),
    ] = False,
    inherited: Annotated[
        bool,
        Query(description="for a fork: first the rows of its sources' iterations up to the fork point (`inherited`)"),
    ] = False,
) -> Response:
    """Per-iteration metrics (force/moment RMSE, max errors, OCP and oracle figures);
    ``?after=k`` returns only iterations after k, so a dashboard polls cheaply. Compact by
    default: ``extra`` is null unless ``?extra=true``. Answers carry an ``ETag``: send it back
    as ``If-None-Match`` and an unchanged series is a bodiless 304."""
    revision = REVISIONS.get(("metrics", campaign_id, user.id))
    if revision is None:
        revision = await run_in_threadpool(read, _metrics_revision, campaign_id, user.id)
        if revision is not None:
            REVISIONS.put(("metrics", campaign_id, user.id), revision, REVISION_TTL_S)
    if revision is None:
        raise NotFound("campaign", campaign_id)
    key = ("metrics", campaign_id, after, extra, inherited, *revision)

    def build() -> bytes:
        with get_sessionmaker()() as session:
            rows = campaigns.metrics_series(session, campaign_id, after, inherited=inherited)
        if not extra:
            rows = [m.model_copy(update={"extra": None}) for m in rows]
        return METRICS_LIST.dump_json(rows)

    return await cached_json(request, key, build)


@router.get("/{campaign_id}/iterations", response_model=list[IterationRead], operation_id="list_campaign_iterations")
def list_campaign_iterations(
    campaign_id: ObjectId,
    user: CurrentUser,
    session: SessionDep,
    after: After = None,
    steps: Annotated[
        bool,
        Query(description="include each iteration's steps (status, worker, attempts, timings, result); null otherwise"),
    ] = False,
) -> Response:
    """Iterations (status, current step, error, times); ``?after=k`` for polling. Compact by
    default: ``steps`` is null unless ``?steps=true`` (or see ``/jobs``)."""
    get_for(session, Campaign, campaign_id, user)
    # not cached: an iteration's status can change without the campaign row changing
    if steps:
        rows = campaigns.list_iterations(session, campaign_id, after)
    else:
        cols = [getattr(Iteration, k) for k in _ITERATION_FIELDS]
        q = sa.select(*cols).where(Iteration.campaign_id == campaign_id).order_by(Iteration.index)
        if after is not None:
            q = q.where(Iteration.index > after)
        rows = [IterationRead.model_validate({**r._mapping, "steps": None}) for r in session.execute(q)]
    return Response(ITERATION_LIST.dump_json(rows), media_type="application/json")


_ITERATION_FIELDS = ("id", "index", "status", "current_step", "config_version_id", "error", "started_at", "finished_at")


@router.get(
    "/{campaign_id}/iterations/{iteration}/curves",
    response_model=IterationCurves,
    operation_id="get_iteration_curves",
    responses=NOT_MODIFIED,
)
async def get_iteration_curves(
    campaign_id: ObjectId, iteration: IterationIndex, user: CurrentUser, request: Request
) -> Response:
    """Iteration k's trajectory (t, q, qd, tau: the motion replayed by the oracle, on the
    oracle's time grid) with the oracle's forces and model k's prediction (columns fx fy fz
    mx my mz in the headrest frame). Immutable once there: cached, with an ``ETag``."""
    sha = REVISIONS.get(("curves", campaign_id, iteration, user.id))
    if sha is None:
        sha = await run_in_threadpool(read, _curves_sha, campaign_id, iteration, user.id)
        if sha is not None:
            REVISIONS.put(("curves", campaign_id, iteration, user.id), sha, CURVES_ACCESS_TTL_S)
    if sha is None:

        def why() -> None:  # the slow path only for the 404's message
            with get_sessionmaker()() as session:
                get_for(session, Campaign, campaign_id, user)
            raise NotFound(f"evaluated iteration {iteration} of campaign", campaign_id)

        await run_in_threadpool(why)
    key = ("curves", campaign_id, iteration, sha)  # content-addressed: never stale

    def build() -> bytes:
        with get_sessionmaker()() as session:
            return campaigns.iteration_curves(session, campaign_id, iteration).model_dump_json().encode()

    return await cached_json(request, key, build)


@router.get(
    "/{campaign_id}/iterations/{iteration}/trajectory",
    response_model=IterationTrajectory,
    operation_id="get_iteration_trajectory",
    responses=NOT_MODIFIED,
)
async def get_iteration_trajectory(
    campaign_id: ObjectId, iteration: IterationIndex, user: CurrentUser, request: Request
) -> Response:
    """Iteration k's whole OCP solution over the task: t, q, qd, tau on the OCP grid for
    every phase, the phase boundaries (names, durations), which phases the oracle replayed,
    and the solver summary (status, converged, iterations, cost, wall time) of its latest
    attempt. 404 for an iteration without an OCP solution (iteration 0, or not solved yet).
    Not part of the polled routes (the curves route stays lean); cached with an ``ETag``."""
    sid = REVISIONS.get(("trajectory", campaign_id, iteration, user.id))
    if sid is None:
        sid = await run_in_threadpool(read, _trajectory_solution, campaign_id, iteration, user.id)
        if sid is not None:  # only found solutions are remembered: a running iteration's 404 is not
            REVISIONS.put(("trajectory", campaign_id, iteration, user.id), sid, REVISION_TTL_S)
    if sid is None:

        def why() -> None:  # the slow path only for the 404's message
            with get_sessionmaker()() as session:
                get_for(session, Campaign, campaign_id, user)
            raise repo.NotFound(
                "iteration",
                f"campaign {campaign_id} has no OCP solution for iteration {iteration} (iteration 0 has none; a later one has none until its OCP step ran)",
            )

        await run_in_threadpool(why)
    key = (
        "trajectory",
        campaign_id,
        iteration,
        sid,
    )  # a solution row is written once, a new attempt is a new row: never stale

    def build() -> bytes:
        with get_sessionmaker()() as session:
            return campaigns.iteration_trajectory(session, campaign_id, iteration).model_dump_json().encode()

    return await cached_json(request, key, build)


# The two most polled routes read with one lean query on a pooled connection (no ORM
# objects, one thread hop), answer from the serialized-bytes cache, and give ETags
# (:mod:`alcove.api.caching`).


#: How long a process reuses a campaign's metrics revision (and the access check that came
#: with it) for one user: new iterations show up at most this late, and a dashboard's burst
#: of polls costs no database round trip.
REVISION_TTL_S = 0.5
#: How long a process remembers that a user may read an iteration's (immutable) curves:
#: removing a share takes effect within this time, like a revoked token.
CURVES_ACCESS_TTL_S = 5.0
REVISIONS = TtlCache()


def _visible_campaign() -> sa.ColumnElement[bool]:
    return sa.and_(
        Campaign.id == sa.bindparam("cid"),
        sa.or_(
            Campaign.owner_id == sa.bindparam("uid"),
            Campaign.id.in_(sa.select(Share.campaign_id).where(Share.user_id == sa.bindparam("uid"))),
        ),
    )


# built once: building a statement costs several times more than executing a cached one
_REVISION = sa.select(
    Campaign.updated_at,
    sa.select(sa.func.count()).where(IterationMetrics.campaign_id == Campaign.id).scalar_subquery(),
    sa.select(sa.func.max(IterationMetrics.id)).where(IterationMetrics.campaign_id == Campaign.id).scalar_subquery(),
).where(_visible_campaign())
#: The detail's revision, one index lookup each: the campaign row, the user's ``can_edit``,
#: the owner's email, the current iteration's steps (claims and heartbeats bump their
#: ``updated_at``), the last event (every other step or iteration transition writes one) and
#: the latest metrics row.
_DETAIL_REVISION = sa.select(
    Campaign.updated_at,
    sa.or_(
        Campaign.owner_id == sa.bindparam("uid"),
        sa.select(Share.permission)
        .where(Share.campaign_id == Campaign.id, Share.user_id == sa.bindparam("uid"))
        .scalar_subquery()
        == SharePermission.edit.value,
    ),
    sa.select(User.email).where(User.id == Campaign.owner_id).scalar_subquery(),
    sa.select(sa.func.max(IterationStep.updated_at))
    .join(Iteration, Iteration.id == IterationStep.iteration_id)
    .where(Iteration.campaign_id == Campaign.id, Iteration.index == Campaign.current_iteration)
    .scalar_subquery(),
    sa.select(sa.func.max(CampaignEvent.id)).where(CampaignEvent.campaign_id == Campaign.id).scalar_subquery(),
    sa.select(IterationMetrics.id)
    .where(IterationMetrics.campaign_id == Campaign.id)
    .order_by(IterationMetrics.iteration_index.desc())
    .limit(1)
    .scalar_subquery(),
).where(_visible_campaign())
_CURVES_SHA = (
    sa.select(IterationMetrics.curves_sha256)
    .join(Campaign, Campaign.id == IterationMetrics.campaign_id)
    .where(
        IterationMetrics.campaign_id == sa.bindparam("cid"),
        IterationMetrics.iteration_index == sa.bindparam("k"),
        IterationMetrics.curves_sha256.is_not(None),
        _visible_campaign(),
    )
)

#: The campaigns an iteration's outputs may live in: the visible campaign, then (recursively)
#: a fork's source while ``k`` is at most the fork's source iteration (as ``repo.resolve_source``).
_SOURCES = (
    sa.select(Campaign.id, Campaign.source_campaign_id, Campaign.source_iteration)
    .where(_visible_campaign())
    .cte("sources", recursive=True)
)
_SOURCE = aliased(Campaign)
_SOURCES = _SOURCES.union_all(
    sa.select(_SOURCE.id, _SOURCE.source_campaign_id, _SOURCE.source_iteration)
    .join(_SOURCES, _SOURCE.id == _SOURCES.c.source_campaign_id)
    .where(_SOURCES.c.source_iteration >= sa.bindparam("k"))
)
#: The latest OCP solution with a trajectory of iteration ``k`` in the campaign holding it.
_TRAJECTORY_SOLUTION = (
    sa.select(OcpSolution.id)
    .join(Iteration, Iteration.id == OcpSolution.iteration_id)
    .join(_SOURCES, _SOURCES.c.id == Iteration.campaign_id)
    .where(
        Iteration.index == sa.bindparam("k"),
        OcpSolution.trajectory_sha256.is_not(None),
        sa.or_(
            _SOURCES.c.source_campaign_id.is_(None),
            _SOURCES.c.source_iteration.is_(None),
            _SOURCES.c.source_iteration < sa.bindparam("k"),
        ),
    )
    .order_by(OcpSolution.attempt.desc())
    .limit(1)
)


def _metrics_revision(conn: sa.Connection, campaign_id: int, user_id: int) -> tuple[Any, ...] | None:
    """What makes the cached series stale: the campaign's ``updated_at``, the count and last
    id of its metrics rows (None: no such campaign visible to the user)."""
    row = conn.execute(_REVISION, {"cid": campaign_id, "uid": user_id}).first()
    return None if row is None else tuple(row)


def _detail_revision(conn: sa.Connection, campaign_id: int, user_id: int) -> tuple[Any, ...] | None:
    """What makes the cached detail stale (None: no such campaign visible to the user)."""
    row = conn.execute(_DETAIL_REVISION, {"cid": campaign_id, "uid": user_id}).first()
    return None if row is None else tuple(row)


def _curves_sha(conn: sa.Connection, campaign_id: int, iteration: int, user_id: int) -> str | None:
    return conn.execute(_CURVES_SHA, {"cid": campaign_id, "k": iteration, "uid": user_id}).scalar()


def _trajectory_solution(conn: sa.Connection, campaign_id: int, iteration: int, user_id: int) -> int | None:
    """The id of the OCP solution iteration ``iteration`` shows (None: none yet, or no such
    campaign visible to the user)."""
    return conn.execute(_TRAJECTORY_SOLUTION, {"cid": campaign_id, "k": iteration, "uid": user_id}).scalar()


@router.get("/{campaign_id}/jobs", response_model=list[JobOut], operation_id="list_campaign_jobs")
def list_campaign_jobs(
    campaign_id: ObjectId,
    user: CurrentUser,
    session: SessionDep,
    status_: Annotated[list[str] | None, Query(alias="status", max_length=10)] = None,
) -> list[JobOut]:
    """Every step (the unit of worker work): status, worker, attempts, timings, error."""
    get_for(session, Campaign, campaign_id, user)
    return [JobOut(**row) for row in campaigns.list_jobs(session, campaign_id, status_)]


@router.get("/{campaign_id}/events", response_model=list[EventRead], operation_id="list_campaign_events")
def list_campaign_events(
    campaign_id: ObjectId,
    user: CurrentUser,
    session: SessionDep,
    after: Annotated[int, Query(ge=0, le=MAX_ID, description="only events with id > after")] = 0,
) -> list[EventRead]:
    get_for(session, Campaign, campaign_id, user)
    return campaigns.list_events(session, campaign_id, after)


@router.get("/{campaign_id}/export", operation_id="export_campaign", response_class=Response, responses={200: BINARY})
def export_campaign(
    campaign_id: ObjectId,
    user: CurrentUser,
    session: SessionDep,
    pool_format: Literal["parquet", "csv"] = "parquet",
    models: bool = True,
) -> Response:
    """Everything the campaign produced as one zip: settings and config versions, metrics
    (CSV + JSON), iterations, pool versions, model artifacts, curves."""
    from alcove.campaigns import repository as crepo
    from alcove.surrogates.artifact_export import artifact_zip_paths

    get_for(session, Campaign, campaign_id, user)
    data = campaigns.export_campaign(session, campaign_id, pool_format=pool_format, models=False)
    assert isinstance(data, bytes)
    if models:
        versions = [mv for mv in crepo.own_model_versions(session, campaign_id) if mv.artifact_sha256]
        if versions:
            paths = artifact_zip_paths(versions)
            buf = io.BytesIO(data)
            with zipfile.ZipFile(buf, "a", zipfile.ZIP_DEFLATED) as zf:
                for mv in versions:
                    zf.write(paths[mv.id], f"campaign-{campaign_id}/models/model-{mv.version:04d}.zip")
            data = buf.getvalue()
    return download(data, f"campaign-{campaign_id}.zip", "application/zip")
