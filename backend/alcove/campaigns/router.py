"""Routes ``/campaigns``: the list, creating a campaign, its detail, and its lifecycle (edit,
start, pause, resume, cancel, retry, fork). The route opens the transaction, calls the
service (:mod:`alcove.campaigns.service`), commits, then sends the jobs the commit made
necessary. What a campaign produced is served by :mod:`alcove.campaigns.views.router`,
its live events by :mod:`alcove.campaigns.views.live`."""

from __future__ import annotations

from collections.abc import Callable
from typing import Annotated, Any, Literal

from fastapi import APIRouter, Body, Query, Request, Response, status
from sqlalchemy.orm import Session
from starlette.concurrency import run_in_threadpool

from alcove.api.caching import NOT_MODIFIED, cached_json, read
from alcove.api.deps import SessionDep
from alcove.api.params import MAX_ID, Limit, ObjectId, Offset
from alcove.campaigns import draft
from alcove.campaigns import references as refs
from alcove.campaigns import service as campaigns
from alcove.campaigns.presets import surrogate_config_version_for
from alcove.campaigns.schemas import CampaignConfigUpdate, CampaignCreate, CampaignCreateIn, ForkRequest, RetryIn
from alcove.campaigns.views import queries
from alcove.campaigns.views.detail import campaign_out
from alcove.campaigns.views.schemas import CampaignOut, CampaignSummary
from alcove.db import get_sessionmaker
from alcove.errors import InvalidInput, NotFound
from alcove.jobs.campaign import StepJob, send_committed, stage
from alcove.models import Campaign, CampaignStatus
from alcove.users.access import get_for
from alcove.users.auth import CurrentUser
from alcove.versioning.schemas import CheckReport, FieldErrorOut

router = APIRouter(prefix="/campaigns", tags=["campaigns"])


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
    rows = queries.summaries(session, user, status=status_, owner=owner, task_id=task_id, limit=limit, offset=offset)
    timing = queries.iteration_timing(session, [r[0].id for r in rows])
    out = []
    for c, email, tv, tname, ov, oname, k_latest, frmse, mrmse in rows:
        max_iterations = (c.stopping_rules or {}).get("max_iterations")
        mean, eta = _eta(c, max_iterations, *timing.get(c.id, (None, None)))
        out.append(
            CampaignSummary(
                id=c.id,
                name=c.name,
                status=c.status,
                wait_reason=c.wait_reason,
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


def _eta(
    c: Campaign, max_iterations: int | None, last_done: int | None, times: list[float] | None
) -> tuple[float | None, float | None]:
    if not times:
        return None, None
    mean = sum(times) / len(times)
    if max_iterations is None or c.is_terminal:
        return mean, None
    return mean, max(max_iterations - (last_done if last_done is not None else (c.source_iteration or 0)), 0) * mean


@router.post("/check", response_model=CheckReport, operation_id="check_campaign")
def check_campaign(
    body: Annotated[dict[str, Any], Body(description="a new campaign's request, as POST /campaigns takes it")],
    user: CurrentUser,
    session: SessionDep,
) -> CheckReport:
    """Check a new campaign's request without creating it: every problem at once (the schema's,
    the definitions it names, the rules across them), each at its field (paths like
    ``settings.batch``)."""
    parsed, errors = draft.check_request(session, user, body)
    return CheckReport(
        valid=parsed is not None and not errors,
        errors=[FieldErrorOut.of(e) for e in errors],
        normalized=parsed.model_dump(mode="json") if parsed is not None and not errors else None,
    )


@router.post("", response_model=CampaignOut, status_code=status.HTTP_201_CREATED, operation_id="create_campaign")
def create_campaign(body: CampaignCreateIn, user: CurrentUser, session: SessionDep) -> CampaignOut:
    """Create a campaign; a request the schema accepts is refused with every problem of the
    definitions it names and of the rules across them at once."""
    versions = draft.versions_of(session, user, body)
    task_version_id, oracle_version_id = versions.task_version_id, versions.oracle_version_id
    scv_id = versions.surrogate_config_version_id or surrogate_config_version_for(session, user.id, None)
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
    staged = stage(session, jobs)
    session.commit()
    send_committed(staged)
    return campaign_out(session, campaign, user)


@router.get("/{campaign_id:integer}", response_model=CampaignOut, operation_id="get_campaign", responses=NOT_MODIFIED)
async def get_campaign(campaign_id: ObjectId, user: CurrentUser, request: Request) -> Response:
    """Status, current iteration and step, latest metrics, ETA. Polled: answers carry an
    ``ETag``; send it back as ``If-None-Match`` and an unchanged campaign is a bodiless 304."""
    # read on every request (no reuse window): a pause or a finished step shows at once
    revision = await run_in_threadpool(read, queries.detail_revision, campaign_id, user.id)
    if revision is None:
        raise NotFound("campaign", campaign_id)
    key = ("detail", campaign_id, *revision)

    def build() -> bytes:
        with get_sessionmaker()() as session:
            return campaign_out(session, get_for(session, Campaign, campaign_id, user), user).model_dump_json().encode()

    return await cached_json(request, key, build)


@router.patch("/{campaign_id:integer}/config", response_model=CampaignOut, operation_id="update_campaign_config")
def update_campaign_config(
    campaign_id: ObjectId, body: CampaignConfigUpdate, user: CurrentUser, session: SessionDep
) -> CampaignOut:
    """Edit settings: records a new config version, used by iterations created from now on."""
    campaign = get_for(session, Campaign, campaign_id, user, need="edit")
    refs.check_version_ids(session, user, body, ["surrogate_config_version_id"])
    campaigns.update_config(session, campaign.id, body, user.id)
    session.commit()
    return campaign_out(session, campaign, user)


def _run_transition(
    session: SessionDep,
    user: CurrentUser,
    campaign_id: int,
    change: Callable[[Session, int], tuple[Campaign, list[StepJob]]],
) -> CampaignOut:
    """A lifecycle change of a campaign the user may edit: the change, the commit, then its jobs."""
    campaign = get_for(session, Campaign, campaign_id, user, need="edit")
    campaign, jobs = change(session, campaign.id)
    staged = stage(session, jobs)
    session.commit()
    send_committed(staged)
    return campaign_out(session, campaign, user)


@router.post(
    "/{campaign_id:integer}/start",
    response_model=CampaignOut,
    operation_id="start_campaign",
    summary="Start a draft campaign: the preliminary step (or, for a fork, the first training) is queued",
)
def start_campaign(campaign_id: ObjectId, user: CurrentUser, session: SessionDep) -> CampaignOut:
    """Start a draft campaign: the preliminary step (or, for a fork, the first training) is queued."""
    return _run_transition(session, user, campaign_id, campaigns.start)


@router.post(
    "/{campaign_id:integer}/pause",
    response_model=CampaignOut,
    operation_id="pause_campaign",
    summary="Pause after the running step finishes",
)
def pause_campaign(campaign_id: ObjectId, user: CurrentUser, session: SessionDep) -> CampaignOut:
    """Pause after the running step finishes."""
    return _run_transition(session, user, campaign_id, campaigns.pause)


@router.post(
    "/{campaign_id:integer}/resume",
    response_model=CampaignOut,
    operation_id="resume_campaign",
    summary="Resume a paused campaign",
)
def resume_campaign(campaign_id: ObjectId, user: CurrentUser, session: SessionDep) -> CampaignOut:
    """Resume a paused campaign."""
    return _run_transition(session, user, campaign_id, campaigns.resume)


@router.post(
    "/{campaign_id:integer}/cancel",
    response_model=CampaignOut,
    operation_id="cancel_campaign",
    summary="Cancel: queued steps are dropped, a running job stops at its next check",
)
def cancel_campaign(campaign_id: ObjectId, user: CurrentUser, session: SessionDep) -> CampaignOut:
    """Cancel: queued steps are dropped, a running job stops at its next check."""
    return _run_transition(session, user, campaign_id, campaigns.cancel)


@router.post("/{campaign_id:integer}/retry", response_model=CampaignOut, operation_id="retry_campaign_step")
def retry_campaign_step(
    campaign_id: ObjectId, user: CurrentUser, session: SessionDep, body: Annotated[RetryIn | None, Body()] = None
) -> CampaignOut:
    """Run a failed step again (default: the step that failed the campaign); 409 when nothing has failed."""
    campaign = get_for(session, Campaign, campaign_id, user, need="edit")
    body = body or RetryIn()
    if (body.iteration is None) != (body.step is None):
        raise InvalidInput.one("step" if body.step is None else "iteration", "give both iteration and step, or neither")
    step = body.step.value if body.step else None
    campaign, jobs = campaigns.retry_step(session, campaign.id, body.iteration, step)
    staged = stage(session, jobs)
    session.commit()
    send_committed(staged)
    return campaign_out(session, campaign, user)


@router.post(
    "/{campaign_id:integer}/fork",
    response_model=CampaignOut,
    status_code=status.HTTP_201_CREATED,
    operation_id="fork_campaign",
)
def fork_campaign(campaign_id: ObjectId, body: ForkRequest, user: CurrentUser, session: SessionDep) -> CampaignOut:
    """A new campaign of yours continuing from iteration k of this one (its pool and model),
    with changed settings."""
    source = get_for(session, Campaign, campaign_id, user)
    refs.check_version_ids(session, user, body, list(refs.VERSION_FIELDS))
    if body.iteration > MAX_ID:
        raise InvalidInput.one("iteration", "too large")
    campaign, jobs = campaigns.fork(session, source.id, body, user.id)
    staged = stage(session, jobs)
    session.commit()
    send_committed(staged)
    return campaign_out(session, campaign, user)
