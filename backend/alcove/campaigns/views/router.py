"""Routes ``/campaigns/{id}/...`` for what a campaign produced: the metrics series, the
iterations, an iteration's curves and whole OCP trajectory, the jobs, the events and the
export. The polled routes read with one lean query on a pooled connection, answer from the
serialized-bytes cache and give ETags (:mod:`alcove.api.caching`)."""

from __future__ import annotations

from typing import Annotated, Literal

from fastapi import APIRouter, Path, Query, Request, Response
from pydantic import TypeAdapter
from starlette.concurrency import run_in_threadpool

from alcove.api.caching import NOT_MODIFIED, TtlCache, cached_json, read
from alcove.api.deps import SessionDep
from alcove.api.downloads import binary, download
from alcove.api.params import MAX_ID, IterationIndex, ObjectId
from alcove.campaigns.views import detail, export, picks, queries
from alcove.campaigns.views.pick_schemas import IterationCandidates
from alcove.campaigns.views.quality_schemas import ValidationSeries
from alcove.campaigns.views.schemas import (
    EventRead,
    IterationCurves,
    IterationRead,
    IterationTrajectory,
    JobOut,
    MetricsRead,
)
from alcove.campaigns.views.validation import validation_series
from alcove.db import get_sessionmaker
from alcove.errors import NotFound
from alcove.models import ArtifactBuild, Campaign, StepStatus
from alcove.surrogates import artifact_builds
from alcove.surrogates.router import BUILD_RESPONSES, build_accepted
from alcove.users.access import get_for
from alcove.users.auth import CurrentUser

router = APIRouter(prefix="/campaigns", tags=["campaigns"])

METRICS_LIST = TypeAdapter(list[MetricsRead])
ITERATION_LIST = TypeAdapter(list[IterationRead])

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


After = Annotated[
    int | None, Query(ge=-1, le=MAX_ID, description="only iterations with index > after (poll incrementally)")
]


@router.get(
    "/{campaign_id:integer}/metrics",
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
            description=(
                "include each row's `extra` (software versions, per-component RMSE, step timings); null otherwise"
            )
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
        revision = await run_in_threadpool(read, queries.metrics_revision, campaign_id, user.id)
        if revision is not None:
            REVISIONS.put(("metrics", campaign_id, user.id), revision, REVISION_TTL_S)
    if revision is None:
        raise NotFound("campaign", campaign_id)
    key = ("metrics", campaign_id, after, extra, inherited, *revision)

    def build() -> bytes:
        with get_sessionmaker()() as session:
            rows = detail.metrics_series(session, campaign_id, after, inherited=inherited)
        if not extra:
            rows = [m.model_copy(update={"extra": None}) for m in rows]
        return METRICS_LIST.dump_json(rows)

    return await cached_json(request, key, build)


@router.get(
    "/{campaign_id:integer}/iterations", response_model=list[IterationRead], operation_id="list_campaign_iterations"
)
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
        rows = detail.list_iterations(session, campaign_id, after)
    else:
        compact = queries.compact_iterations(session, campaign_id, after)
        rows = [IterationRead.model_validate({**r, "steps": None}) for r in compact]
    return Response(ITERATION_LIST.dump_json(rows), media_type="application/json")


@router.get(
    "/{campaign_id:integer}/iterations/{iteration:integer}/curves",
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
        sha = await run_in_threadpool(read, queries.curves_sha, campaign_id, iteration, user.id)
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
            return detail.iteration_curves(session, campaign_id, iteration).model_dump_json().encode()

    return await cached_json(request, key, build)


@router.get(
    "/{campaign_id:integer}/iterations/{iteration:integer}/trajectory",
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
        sid = await run_in_threadpool(read, queries.trajectory_solution, campaign_id, iteration, user.id)
        if sid is not None:  # only found solutions are remembered: a running iteration's 404 is not
            REVISIONS.put(("trajectory", campaign_id, iteration, user.id), sid, REVISION_TTL_S)
    if sid is None:

        def why() -> None:  # the slow path only for the 404's message
            with get_sessionmaker()() as session:
                get_for(session, Campaign, campaign_id, user)
            raise NotFound("iteration", message=detail.no_solution_message(campaign_id, iteration))

        await run_in_threadpool(why)
    key = (
        "trajectory",
        campaign_id,
        iteration,
        sid,
    )  # a solution row is written once, a new attempt is a new row: never stale

    def build() -> bytes:
        with get_sessionmaker()() as session:
            return detail.iteration_trajectory(session, campaign_id, iteration).model_dump_json().encode()

    return await cached_json(request, key, build)


Slot = Annotated[int, Path(ge=0, le=63, description="the candidate's ocp slot (0 to 63)")]
PickIndex = Annotated[int, Path(ge=0, le=63, description="pick order: 0 = the first pick (0 to 63)")]


@router.get(
    "/{campaign_id:integer}/iterations/{iteration:integer}/candidates",
    response_model=IterationCandidates,
    operation_id="get_iteration_candidates",
)
def get_iteration_candidates(
    campaign_id: ObjectId, iteration: IterationIndex, user: CurrentUser, session: SessionDep
) -> IterationCandidates:
    """Iteration k's candidate scenarios (ocp slots), each with its score, its rank, whether it
    was picked and why (from the acquisition rule and the iteration's settings: top score, next
    by the minimum distance, too close to a pick, not in the top q, below the stopping threshold,
    not converged), its OCP solution (``.../candidates/{slot}/trajectory``) and whether the
    pick's curves are stored (``.../picks/{pick}/curves``). Empty for strategy ``paper``."""
    get_for(session, Campaign, campaign_id, user)
    return picks.iteration_candidates(session, campaign_id, iteration)


@router.get(
    "/{campaign_id:integer}/iterations/{iteration:integer}/candidates/{slot:integer}/trajectory",
    response_model=IterationTrajectory,
    operation_id="get_candidate_trajectory",
)
def get_candidate_trajectory(
    campaign_id: ObjectId, iteration: IterationIndex, slot: Slot, user: CurrentUser, session: SessionDep
) -> IterationTrajectory:
    """Candidate ``slot``'s whole OCP solution (its latest attempt) over the scenario it solved,
    as ``.../trajectory`` gives the first slot's."""
    get_for(session, Campaign, campaign_id, user)
    return detail.iteration_trajectory(session, campaign_id, iteration, slot=slot)


@router.get(
    "/{campaign_id:integer}/iterations/{iteration:integer}/picks/{pick:integer}/curves",
    response_model=IterationCurves,
    operation_id="get_pick_curves",
)
def get_pick_curves(
    campaign_id: ObjectId, iteration: IterationIndex, pick: PickIndex, user: CurrentUser, session: SessionDep
) -> IterationCurves:
    """Pick ``pick`` of iteration k: model k's prediction (ensemble mean, and its standard
    deviation for K > 1) and the oracle's forces along that picked trajectory (t, q, qd on the
    oracle's grid; columns fx fy fz mx my mz). Pick 0's are the iteration's curves."""
    get_for(session, Campaign, campaign_id, user)
    return picks.pick_curves(session, campaign_id, iteration, pick)


@router.get("/{campaign_id:integer}/jobs", response_model=list[JobOut], operation_id="list_campaign_jobs")
def list_campaign_jobs(
    campaign_id: ObjectId,
    user: CurrentUser,
    session: SessionDep,
    status_: Annotated[list[StepStatus] | None, Query(alias="status", max_length=10, description="only these")] = None,
) -> list[JobOut]:
    """Every step (the unit of worker work): status, worker, attempts, timings, error."""
    get_for(session, Campaign, campaign_id, user)
    statuses = [s.value for s in status_] if status_ is not None else None
    return [JobOut(**row) for row in detail.list_jobs(session, campaign_id, statuses)]


@router.get(
    "/{campaign_id:integer}/validation", response_model=ValidationSeries, operation_id="get_campaign_validation"
)
def get_campaign_validation(campaign_id: ObjectId, user: CurrentUser, session: SessionDep) -> ValidationSeries:
    """The held-out validation suite (status, motions replayed, campaigns sharing it) and the
    generalisation error of each of the campaign's model versions on all its motions (force and
    moment RMSE in the vector definition, per component, per motion)."""
    return validation_series(session, get_for(session, Campaign, campaign_id, user))


@router.get("/{campaign_id:integer}/events", response_model=list[EventRead], operation_id="list_campaign_events")
def list_campaign_events(
    campaign_id: ObjectId,
    user: CurrentUser,
    session: SessionDep,
    after: Annotated[int, Query(ge=0, le=MAX_ID, description="only events with id > after")] = 0,
) -> list[EventRead]:
    get_for(session, Campaign, campaign_id, user)
    return detail.list_events(session, campaign_id, after)


@router.get(
    "/{campaign_id:integer}/export",
    operation_id="export_campaign",
    response_class=Response,
    responses={200: binary("application/zip"), **BUILD_RESPONSES},
)
def export_campaign(
    campaign_id: ObjectId,
    user: CurrentUser,
    session: SessionDep,
    pool_format: Literal["parquet", "csv"] = "parquet",
    models: bool = True,
) -> Response:
    """Everything the campaign produced as one zip: settings and config versions, metrics
    (CSV + JSON), iterations, pool versions, model artifacts, curves. With models, the model
    zips a worker has not built yet are built first (queue ``artifacts``): the answer is then
    202 with the build to poll, and this download answers 200 once it is ready."""
    get_for(session, Campaign, campaign_id, user)
    if models:
        versions = export.exported_model_versions(session, campaign_id)
        path = f"/api/v1/campaigns/{campaign_id}/export?pool_format={pool_format}&models=true"
        got = artifact_builds.stored_or_build(session, user, campaign_id, versions, path)
        if isinstance(got, ArtifactBuild):
            return build_accepted(session, got)
    data = export.export_zip(session, campaign_id, pool_format=pool_format, models=models)
    return download(data, f"campaign-{campaign_id}.zip", "application/zip")
