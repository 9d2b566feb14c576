"""Fair share of the workers: the running-campaigns limit of a campaign's owner
(:mod:`alcove.users.limits`).

A campaign that starts, resumes or retries a step while its owner already runs as many campaigns
as their limit allows is not sent to the broker: its steps wait as ``pending`` rows, the campaign
stays ``queued`` with a ``wait_reason`` saying why. :func:`admit_waiting` sends the oldest waiting
campaigns of an owner as soon as they have room: after every step a worker completes (a campaign
that ended frees its place) and in every reconciler pass (a lost admission, a raised limit). Each
decision holds the owner's row lock, so two decisions for one owner never both take the last place;
an admitted campaign's jobs are recorded in the job outbox in the admitting transaction, so none is
lost and none is sent twice (a step is claimed once, :func:`alcove.campaigns.repository.claim_step`).
"""

from __future__ import annotations

import logging

import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove.campaigns import repository as repo
from alcove.campaigns.machine import slots
from alcove.jobs.campaign import StepJob
from alcove.models import Campaign, CampaignStatus, StepStatus
from alcove.users import repository as users_repo
from alcove.users.limits import limits_of_id

log = logging.getLogger(__name__)

#: the statuses of a campaign that holds (or is about to hold) workers, unless it waits
ACTIVE = frozenset(
    s.value for s in (CampaignStatus.queued, CampaignStatus.running, CampaignStatus.pausing, CampaignStatus.cancelling)
)


def running_campaigns(s: Session, owner_id: int, *, besides: int | None = None) -> int:
    """The owner's campaigns that count against their limit: active and not waiting."""
    q = sa.select(sa.func.count()).where(
        Campaign.owner_id == owner_id, Campaign.status.in_(ACTIVE), Campaign.wait_reason.is_(None)
    )
    if besides is not None:
        q = q.where(Campaign.id != besides)
    return int(s.scalar(q) or 0)


def wait_reason(running: int, limit: int) -> str:
    return (
        f"waiting for a free place: {running} of your campaigns are running and your limit is {limit} "
        "(max_running_campaigns); it starts when one of them ends"
    )


def hold_over_limit(s: Session, c: Campaign, jobs: list[StepJob]) -> list[StepJob]:
    """The jobs of campaign ``c``, which is about to run again, to send now: all of them, or none
    when its owner has no room (then its steps wait as pending rows and ``c`` waits, queued)."""
    limit = limits_of_id(s, c.owner_id).max_running_campaigns
    if limit is None:
        c.wait_reason = None
        return jobs
    users_repo.lock_user(s, c.owner_id)
    running = running_campaigns(s, c.owner_id, besides=c.id)
    if running < limit:
        c.wait_reason = None
        return jobs
    for job in jobs:
        row = repo.get_step(s, c.id, job.iteration, job.step.value, job.slot)
        if row is not None:
            row.status, row.queued_at = StepStatus.pending.value, None
    c.status = CampaignStatus.queued.value
    c.wait_reason = wait_reason(running, limit)
    repo.add_event(s, c.id, "waiting", c.wait_reason, data={"running": running, "limit": limit})
    s.flush()
    return []


def waiting_owners(s: Session) -> list[int]:
    q = sa.select(Campaign.owner_id).where(Campaign.wait_reason.is_not(None)).distinct().order_by(Campaign.owner_id)
    return list(s.scalars(q))


def _waiting(s: Session, owner_id: int, n: int) -> list[Campaign]:
    """The owner's ``n`` longest-waiting campaigns not being changed right now (rows locked by
    another transaction are left for the next pass)."""
    q = (
        sa.select(Campaign)
        .where(
            Campaign.owner_id == owner_id,
            Campaign.status == CampaignStatus.queued.value,
            Campaign.wait_reason.is_not(None),
        )
        .order_by(Campaign.id)
        .limit(n)
    )
    if s.get_bind().dialect.name == "postgresql":
        q = q.with_for_update(skip_locked=True)
    return list(s.scalars(q))


def admit_waiting(s: Session, owner_id: int) -> list[StepJob]:
    """Admit the owner's waiting campaigns their limit has room for; the jobs to send after commit."""
    from alcove.campaigns.machine.step_rows import ensure_step, step_job

    if not s.scalar(sa.select(sa.exists().where(Campaign.owner_id == owner_id, Campaign.wait_reason.is_not(None)))):
        return []
    users_repo.lock_user(s, owner_id)
    limit = limits_of_id(s, owner_id).max_running_campaigns
    room = None if limit is None else limit - running_campaigns(s, owner_id)
    waiting = _waiting(s, owner_id, 1_000_000 if room is None else max(room, 0))
    jobs: list[StepJob] = []
    for c in waiting:
        c.wait_reason = None
        refs = slots.waiting_steps(s, c)
        for ref in refs:
            jobs.append(step_job(c, ref, ensure_step(s, c, ref, StepStatus.queued)))
        repo.add_event(s, c.id, "admitted", "a place is free: its jobs are sent", data={"limit": limit})
        if not refs:
            log.warning("campaign %s waited without a pending step; it runs nothing", c.id)
    if limit is not None and waiting:
        # the others' reasons name the current count
        still = running_campaigns(s, owner_id)
        for c in _waiting(s, owner_id, 1_000_000):
            c.wait_reason = wait_reason(still, limit)
    s.flush()
    return jobs


def admit_all(s: Session) -> list[StepJob]:
    """:func:`admit_waiting` for every owner with a waiting campaign (a reconciler pass)."""
    jobs: list[StepJob] = []
    for owner_id in waiting_owners(s):
        jobs += admit_waiting(s, owner_id)
    return jobs


def admit_owner_of(s: Session, campaign_id: int) -> list[StepJob]:
    """:func:`admit_waiting` for the owner of ``campaign_id`` (after one of its steps ended)."""
    owner_id = s.scalar(sa.select(Campaign.owner_id).where(Campaign.id == campaign_id))
    return admit_waiting(s, owner_id) if owner_id is not None else []
