"""All campaign queries. Functions take a ``Session`` and never commit."""

from __future__ import annotations

from collections.abc import Sequence
from datetime import datetime, timedelta
from typing import Any, TypeVarTuple

import sqlalchemy as sa
from sqlalchemy.orm import Session, selectinload

from alcove.errors import NotFound
from alcove.models import (
    Campaign,
    CampaignConfigVersion,
    CampaignEvent,
    Iteration,
    IterationMetrics,
    IterationStatus,
    IterationStep,
    OracleRun,
    StepName,
    StepStatus,
    User,
    WorkerHeartbeat,
    utcnow,
)
from alcove.users.access import visible_clause

Ts = TypeVarTuple("Ts")


def get_campaign(s: Session, campaign_id: int, *, lock: bool = False) -> Campaign:
    q = sa.select(Campaign).where(Campaign.id == campaign_id)
    if lock and s.get_bind().dialect.name == "postgresql":
        q = q.with_for_update()
    c = s.scalar(q)
    if c is None:
        raise NotFound("campaign", campaign_id)
    return c


def list_campaigns(s: Session, owner_id: int | None = None) -> list[Campaign]:
    q = sa.select(Campaign).order_by(Campaign.id.desc())
    if owner_id is not None:
        q = q.where(Campaign.owner_id == owner_id)
    return list(s.scalars(q))


def config_version(s: Session, campaign: Campaign, version: int | None = None) -> CampaignConfigVersion:
    v = campaign.config_version if version is None else version
    row = s.scalar(
        sa.select(CampaignConfigVersion).where(
            CampaignConfigVersion.campaign_id == campaign.id, CampaignConfigVersion.version == v
        )
    )
    if row is None:
        raise NotFound("config version", message=f"campaign {campaign.id} has no config version {v}")
    return row


def get_iteration(s: Session, campaign_id: int, index: int) -> Iteration | None:
    return s.scalar(sa.select(Iteration).where(Iteration.campaign_id == campaign_id, Iteration.index == index))


def get_iteration_with_steps(s: Session, campaign_id: int, index: int) -> Iteration | None:
    return s.scalar(
        sa.select(Iteration)
        .options(selectinload(Iteration.steps).selectinload(IterationStep.batch_jobs))
        .where(Iteration.campaign_id == campaign_id, Iteration.index == index)
    )


def list_iterations(s: Session, campaign_id: int, after: int | None = None) -> list[Iteration]:
    q = (
        sa.select(Iteration)
        .options(selectinload(Iteration.steps).selectinload(IterationStep.batch_jobs))
        .where(Iteration.campaign_id == campaign_id)
        .order_by(Iteration.index)
    )
    if after is not None:
        q = q.where(Iteration.index > after)
    return list(s.scalars(q))


def get_step(s: Session, campaign_id: int, index: int, step: str, slot: int = 0) -> IterationStep | None:
    return s.scalar(
        sa.select(IterationStep)
        .join(Iteration, Iteration.id == IterationStep.iteration_id)
        .where(
            IterationStep.campaign_id == campaign_id,
            Iteration.index == index,
            IterationStep.step == step,
            IterationStep.slot == slot,
        )
    )


def slot_steps(s: Session, iteration_id: int, steps: Sequence[str]) -> list[IterationStep]:
    """The iteration's rows of ``steps`` (all slots), by step and slot."""
    q = sa.select(IterationStep).where(IterationStep.iteration_id == iteration_id, IterationStep.step.in_(list(steps)))
    return list(s.scalars(q.order_by(IterationStep.step, IterationStep.slot)))


def active_oracle_steps(s: Session, campaign_id: int) -> int:
    """The campaign's oracle jobs queued or running (what its concurrency cap counts)."""
    q = sa.select(sa.func.count()).where(
        IterationStep.campaign_id == campaign_id,
        IterationStep.step == StepName.oracle.value,
        IterationStep.status.in_([StepStatus.queued.value, StepStatus.running.value]),
    )
    return int(s.scalar(q) or 0)


def steps_of_campaign(
    s: Session, campaign_id: int, statuses: Sequence[str] | None = None
) -> list[tuple[int, IterationStep]]:
    q = (
        sa.select(Iteration.index, IterationStep)
        .join(Iteration, Iteration.id == IterationStep.iteration_id)
        .where(IterationStep.campaign_id == campaign_id)
        .order_by(Iteration.index, IterationStep.id)
    )
    if statuses is not None:
        q = q.where(IterationStep.status.in_(list(statuses)))
    return [(i, st) for i, st in s.execute(q)]


def claim_step(s: Session, step_id: int, attempt: int, token: str, worker: str, lease_seconds: float) -> bool:
    """``queued -> running`` for exactly one job: the one whose message carries the next
    attempt number. A duplicate or stale delivery matches no row and does nothing."""
    now = utcnow()
    res = s.execute(
        sa.update(IterationStep)
        .where(
            IterationStep.id == step_id,
            IterationStep.status == StepStatus.queued.value,
            IterationStep.attempts == attempt - 1,
        )
        .values(
            status=StepStatus.running.value,
            attempts=attempt,
            claim_token=token,
            worker_name=worker,
            started_at=now,
            heartbeat_at=now,
            lease_until=now + timedelta(seconds=lease_seconds),
            error=None,
        )
        .execution_options(synchronize_session=False)
    )
    assert isinstance(res, sa.CursorResult)  # an UPDATE's result is a CursorResult (Session.execute is typed Result)
    return res.rowcount == 1


def extend_lease(s: Session, step_id: int, token: str, lease_seconds: float) -> tuple[bool, bool]:
    """Heartbeat of a running step. Returns (still ours, cancel requested)."""
    now = utcnow()
    res = s.execute(
        sa.update(IterationStep)
        .where(
            IterationStep.id == step_id,
            IterationStep.claim_token == token,
            IterationStep.status == StepStatus.running.value,
        )
        .values(heartbeat_at=now, lease_until=now + timedelta(seconds=lease_seconds))
        .execution_options(synchronize_session=False)
    )
    cancel = s.scalar(
        sa.select(Campaign.cancel_requested)
        .join(IterationStep, IterationStep.campaign_id == Campaign.id)
        .where(IterationStep.id == step_id)
    )
    assert isinstance(res, sa.CursorResult)  # an UPDATE's result is a CursorResult (Session.execute is typed Result)
    return res.rowcount == 1, bool(cancel)


def pause_requested_of(s: Session, step_id: int) -> bool:
    """Whether the campaign of a step is pausing."""
    q = sa.select(Campaign.pause_requested).join(IterationStep, IterationStep.campaign_id == Campaign.id)
    return bool(s.scalar(q.where(IterationStep.id == step_id)))


def owned_running_step(s: Session, step_id: int, token: str) -> IterationStep | None:
    """The step row if this job still holds it (a reconciler may have taken it over)."""
    return s.scalar(
        sa.select(IterationStep).where(
            IterationStep.id == step_id,
            IterationStep.claim_token == token,
            IterationStep.status == StepStatus.running.value,
        )
    )


def _skip_locked(s: Session, q: sa.Select[*Ts]) -> sa.Select[*Ts]:
    """On PostgreSQL, concurrent reconcilers (one per worker) each take different rows."""
    if s.get_bind().dialect.name == "postgresql":
        return q.with_for_update(skip_locked=True, of=IterationStep)
    return q


def abandoned_running_steps(
    s: Session, now: datetime, dead_before: datetime | None = None, restart_margin_s: float = 2.0
) -> list[tuple[int, IterationStep, str]]:
    """Running steps nobody works on any more, with why: the lease expired (``lease``), or
    (with ``dead_before``) the worker that claimed them stopped beating before
    ``dead_before``, shut down, or was started again under the same name after it claimed
    them (``dead``): its heartbeat's ``started_at``, set by the new process's first beat, is
    more than ``restart_margin_s`` (a heartbeat interval: the first beat follows the worker's
    start by less) after the step's, so the process that ran the step is gone. A worker that is
    alive keeps beating from its main process however long its step computes, so its steps are
    never taken from it."""
    hb = WorkerHeartbeat
    gone = sa.false() if dead_before is None else sa.or_(hb.last_seen_at < dead_before, hb.stopped_at.is_not(None))
    restarted = sa.false() if dead_before is None else IterationStep.started_at < hb.started_at
    q = (
        sa.select(
            Iteration.index,
            IterationStep,
            sa.case((gone, "dead"), (restarted, "restarted"), else_="lease"),
            hb.started_at,
        )
        .join(Iteration, Iteration.id == IterationStep.iteration_id)
        .outerjoin(hb, hb.name == IterationStep.worker_name)
        .where(
            IterationStep.status == StepStatus.running.value, sa.or_(IterationStep.lease_until < now, gone, restarted)
        )
    )
    out = []
    margin = timedelta(seconds=restart_margin_s)
    for i, st, why, worker_started in s.execute(_skip_locked(s, q)):
        if why == "restarted":
            if st.lease_until is not None and st.lease_until < now:
                why = "lease"
            elif st.started_at is None or worker_started is None or st.started_at > worker_started - margin:
                continue  # claimed around the worker's own start: its first beat came after the claim
            else:
                why = "dead"
        out.append((i, st, why))
    return out


def stale_queued_steps(s: Session, before: datetime) -> list[tuple[int, IterationStep]]:
    q = (
        sa.select(Iteration.index, IterationStep)
        .join(Iteration, Iteration.id == IterationStep.iteration_id)
        .where(IterationStep.status == StepStatus.queued.value, IterationStep.queued_at < before)
    )
    return [(i, st) for i, st in s.execute(_skip_locked(s, q))]


def metrics_series(s: Session, campaign_id: int, after: int | None = None) -> list[IterationMetrics]:
    q = (
        sa.select(IterationMetrics)
        .where(IterationMetrics.campaign_id == campaign_id)
        .order_by(IterationMetrics.iteration_index)
    )
    if after is not None:
        q = q.where(IterationMetrics.iteration_index > after)
    return list(s.scalars(q))


def rmse_history(s: Session, campaign_id: int) -> list[tuple[int, float | None, float | None]]:
    """(iteration, force RMSE, moment RMSE) in order: what the stopping rules need, no ORM rows."""
    q = (
        sa.select(IterationMetrics.iteration_index, IterationMetrics.force_rmse, IterationMetrics.moment_rmse)
        .where(IterationMetrics.campaign_id == campaign_id)
        .order_by(IterationMetrics.iteration_index)
    )
    return [(int(k), f, m) for k, f, m in s.execute(q)]


def failed_streak(s: Session, campaign_id: int, index: int) -> int:
    """How many iterations up to ``index`` (included, counting back) failed in a row: an iteration failed
    when it holds an error (the current one's is set before its status, in its append's transaction)."""
    q = (
        sa.select(Iteration.error)
        .where(Iteration.campaign_id == campaign_id, Iteration.index >= 1, Iteration.index <= index)
        .order_by(Iteration.index.desc())
    )
    streak = 0
    for error in s.scalars(q):
        if error is None:
            break
        streak += 1
    return streak


def oracle_calls(s: Session, campaign_id: int) -> int:
    """The campaign's oracle runs: every attempt, also failed ones and those of failed iterations."""
    return int(s.scalar(sa.select(sa.func.count(OracleRun.id)).where(OracleRun.campaign_id == campaign_id)) or 0)


def latest_metrics(s: Session, campaign_id: int) -> IterationMetrics | None:
    return s.scalar(
        sa.select(IterationMetrics)
        .where(IterationMetrics.campaign_id == campaign_id)
        .order_by(IterationMetrics.iteration_index.desc())
        .limit(1)
    )


def metrics_of(s: Session, campaign_id: int, index: int) -> IterationMetrics | None:
    return s.scalar(
        sa.select(IterationMetrics).where(
            IterationMetrics.campaign_id == campaign_id, IterationMetrics.iteration_index == index
        )
    )


def finished_iteration_times(s: Session, campaign_id: int) -> list[tuple[int, str, datetime | None, datetime | None]]:
    q = (
        sa.select(Iteration.index, Iteration.status, Iteration.started_at, Iteration.finished_at)
        .where(Iteration.campaign_id == campaign_id, Iteration.index > 0)
        .order_by(Iteration.index)
    )
    return [(index, status, started, finished) for index, status, started, finished in s.execute(q)]


def events(
    s: Session, campaign_id: int, after: int = 0, limit: int = 1000, *, through: int | None = None
) -> list[CampaignEvent]:
    """The campaign's events with ``after < id`` (``<= through``), oldest first."""
    q = (
        sa.select(CampaignEvent)
        .where(CampaignEvent.campaign_id == campaign_id, CampaignEvent.id > after)
        .order_by(CampaignEvent.id)
        .limit(limit)
    )
    if through is not None:
        q = q.where(CampaignEvent.id <= through)
    return list(s.scalars(q))


def last_event_id(s: Session) -> int:
    return s.scalar(sa.select(sa.func.max(CampaignEvent.id))) or 0


def events_since(s: Session, cursor: int, missing: list[int], limit: int = 1000) -> list[CampaignEvent]:
    """Events of every campaign after ``cursor``, and those of the ``missing`` ids below it
    that have been committed since (live updates)."""
    after = CampaignEvent.id > cursor
    q = sa.select(CampaignEvent).where(sa.or_(after, CampaignEvent.id.in_(missing)) if missing else after)
    return list(s.scalars(q.order_by(CampaignEvent.id).limit(limit)))


def visible_events(s: Session, user: User, after: int, through: int, limit: int) -> list[CampaignEvent]:
    """Events ``after < id <= through`` of the campaigns ``user`` may see, oldest first."""
    q = (
        sa.select(CampaignEvent)
        .join(Campaign, Campaign.id == CampaignEvent.campaign_id)
        .where(CampaignEvent.id > after, CampaignEvent.id <= through, visible_clause(Campaign, user))
        .order_by(CampaignEvent.id)
        .limit(limit)
    )
    return list(s.scalars(q))


def visible_campaign_ids(s: Session, user: User, ids: list[int]) -> set[int]:
    """Which of ``ids`` are campaigns ``user`` may see."""
    return set(s.scalars(sa.select(Campaign.id).where(Campaign.id.in_(ids), visible_clause(Campaign, user))))


def add_event(
    s: Session,
    campaign_id: int,
    kind: str,
    message: str = "",
    *,
    iteration: int | None = None,
    step: str | None = None,
    data: dict[str, Any] | None = None,
) -> None:
    s.add(
        CampaignEvent(
            campaign_id=campaign_id, kind=kind, message=message, iteration_index=iteration, step=step, data=data or {}
        )
    )


def last_config_version(s: Session, campaign_id: int) -> int:
    """The number of the campaign's latest config version (0: none yet)."""
    q = sa.select(sa.func.max(CampaignConfigVersion.version)).where(CampaignConfigVersion.campaign_id == campaign_id)
    return s.scalar(q) or 0


def config_versions(s: Session, campaign_id: int) -> list[CampaignConfigVersion]:
    q = sa.select(CampaignConfigVersion).where(CampaignConfigVersion.campaign_id == campaign_id)
    return list(s.scalars(q.order_by(CampaignConfigVersion.version)))


def unfinished_iterations(s: Session, campaign_id: int) -> list[Iteration]:
    """The campaign's iterations still pending or running."""
    unfinished = [IterationStatus.pending.value, IterationStatus.running.value]
    q = sa.select(Iteration).where(Iteration.campaign_id == campaign_id, Iteration.status.in_(unfinished))
    return list(s.scalars(q))
