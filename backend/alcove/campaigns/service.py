"""A campaign's lifecycle: create, edit, start, pause, resume, cancel, retry a failed step,
fork. Every function takes a ``Session``, never commits, and returns domain objects plus,
where the change makes work necessary, the :class:`StepJob` list that the caller records
in the job outbox in the same transaction and sends AFTER committing::

    with open_transaction() as s:
        campaign, jobs = service.start(s, campaign_id)
        staged = stage(s, jobs)  # alcove.jobs.campaign
    send_committed(staged)
"""

from __future__ import annotations

from dataclasses import replace
from datetime import datetime

from sqlalchemy.orm import Session

from alcove.campaigns import repository as repo
from alcove.campaigns.config import CampaignConfig, current_config
from alcove.campaigns.draft import decided_preliminary, strategy_error, suite_error
from alcove.campaigns.machine import slots
from alcove.campaigns.machine.apply import apply_decision, state_of
from alcove.campaigns.machine.state_machine import (
    Cancel,
    Decision,
    InvalidTransition,
    Pause,
    Resume,
    RetryStep,
    Start,
    StepRef,
    transition,
)
from alcove.campaigns.machine.step_rows import ATTEMPTS_FIELD
from alcove.campaigns.schemas import CampaignConfigUpdate, CampaignCreate, ForkRequest
from alcove.campaigns.sizes import check_campaign_sizes
from alcove.errors import Conflict, InvalidInput, NotFound
from alcove.jobs.campaign import StepJob
from alcove.models import (
    Campaign,
    CampaignConfigVersion,
    CampaignStatus,
    IterationStatus,
    OracleVersion,
    StepName,
    StepStatus,
    SurrogateConfigVersion,
    TaskVersion,
    utcnow,
)
from alcove.pool import repository as pool_repo
from alcove.versioning import V

__all__ = [
    "InvalidTransition",
    "cancel",
    "create_campaign",
    "fork",
    "pause",
    "resume",
    "retry_step",
    "start",
    "update_config",
]


def _check_definitions(
    s: Session, task_version_id: int, oracle_version_id: int, surrogate_config_version_id: int
) -> None:
    for model, ident, field in (
        (TaskVersion, task_version_id, "task_version_id"),
        (OracleVersion, oracle_version_id, "oracle_version_id"),
        (SurrogateConfigVersion, surrogate_config_version_id, "surrogate_config_version_id"),
    ):
        if s.get(model, ident) is None:
            label = model.__tablename__[:-1].replace("_", " ")
            raise NotFound(label, ident, message=f"{field}: no {label} {ident}")


def _check_strategy(s: Session, cfg: CampaignConfig, surrogate_config_version_id: int) -> None:
    """The acquisition strategy must suit the surrogate (422 naming ``settings.strategy``)."""
    problem = strategy_error(s, cfg.settings, surrogate_config_version_id)
    if problem is not None:
        raise InvalidInput([problem])


def _decided(s: Session, cfg: CampaignConfig, task_version_id: int, oracle_version_id: int) -> CampaignConfig:
    """The config as the campaign stores it: the preliminary's press-family replays decided."""
    preliminary = decided_preliminary(s, cfg.settings, cfg.preliminary, task_version_id, oracle_version_id)
    return cfg.model_copy(update={"preliminary": preliminary})


def _check_suite(s: Session, cfg: CampaignConfig, task_version_id: int) -> None:
    """The validation suite's ranges and the press family's must make motions of the task's model
    (422 naming the range)."""
    problem = suite_error(s, cfg.settings, cfg.preliminary, task_version_id)
    if problem is not None:
        raise InvalidInput([problem])


def _lock_definitions(s: Session, campaign: Campaign) -> None:
    now = utcnow()
    _lock_version(s, TaskVersion, campaign.task_version_id, now)
    _lock_version(s, OracleVersion, campaign.oracle_version_id, now)
    _lock_version(s, SurrogateConfigVersion, campaign.surrogate_config_version_id, now)


def _lock_version(s: Session, model: type[V], ident: int, now: datetime) -> None:
    row = s.get(model, ident)
    if row is not None and row.locked_at is None:
        row.locked_at = now


def add_config_version(
    s: Session,
    campaign: Campaign,
    cfg: CampaignConfig,
    surrogate_config_version_id: int,
    user_id: int | None,
    note: str,
) -> CampaignConfigVersion:
    version = repo.last_config_version(s, campaign.id) + 1
    row = CampaignConfigVersion(
        campaign_id=campaign.id,
        version=version,
        surrogate_config_version_id=surrogate_config_version_id,
        preliminary_config=cfg.preliminary.model_dump(mode="json"),
        stopping_rules=cfg.stopping.model_dump(mode="json"),
        policies=cfg.policies.model_dump(mode="json"),
        settings=cfg.settings.model_dump(mode="json"),
        note=note,
        created_by_id=user_id,
    )
    s.add(row)
    campaign.config_version = version
    campaign.surrogate_config_version_id = surrogate_config_version_id
    campaign.preliminary_config = row.preliminary_config
    campaign.stopping_rules = row.stopping_rules
    campaign.policies = row.policies
    s.flush()
    return row


def create_campaign(
    s: Session,
    owner_id: int,
    data: CampaignCreate,
    *,
    source_campaign_id: int | None = None,
    source_iteration: int | None = None,
) -> Campaign:
    """A draft campaign with config version 1."""
    _check_definitions(s, data.task_version_id, data.oracle_version_id, data.surrogate_config_version_id)
    cfg = CampaignConfig.model_validate(data.model_dump(include={"preliminary", "stopping", "policies", "settings"}))
    cfg = _decided(s, cfg, data.task_version_id, data.oracle_version_id)
    if cfg.preliminary.dataset_ids:
        pool_repo.datasets(s, cfg.preliminary.dataset_ids)  # raises NotFound naming the id
    _check_strategy(s, cfg, data.surrogate_config_version_id)
    _check_suite(s, cfg, data.task_version_id)
    check_campaign_sizes(s, owner_id, cfg, data.task_version_id, data.surrogate_config_version_id)
    c = Campaign(
        owner_id=owner_id,
        name=data.name,
        description=data.description,
        task_version_id=data.task_version_id,
        oracle_version_id=data.oracle_version_id,
        surrogate_config_version_id=data.surrogate_config_version_id,
        seed=data.seed,
        source_campaign_id=source_campaign_id,
        source_iteration=source_iteration,
        status=CampaignStatus.draft.value,
        config_version=0,
    )
    s.add(c)
    s.flush()
    add_config_version(s, c, cfg, data.surrogate_config_version_id, owner_id, "created")
    repo.add_event(s, c.id, "status", "created", data={"status": "draft"})
    return c


def update_config(
    s: Session, campaign_id: int, update: CampaignConfigUpdate, user_id: int | None = None
) -> CampaignConfigVersion:
    """Record a new config version; iterations created from now on use it (and a retried
    step). A failed campaign can be edited before :func:`retry_step`."""
    c = repo.get_campaign(s, campaign_id, lock=True)
    if c.status in (CampaignStatus.completed.value, CampaignStatus.cancelled.value):
        raise InvalidTransition(c.status, "edit", "fork it instead")
    cfg = current_config(s, c)
    changes = update.model_dump(exclude_none=True, exclude={"note", "surrogate_config_version_id"})
    new = cfg.model_copy(update={k: getattr(update, k) for k in changes})
    scv = update.surrogate_config_version_id or c.surrogate_config_version_id
    if update.surrogate_config_version_id is not None:
        _check_definitions(s, c.task_version_id, c.oracle_version_id, scv)
    _check_strategy(s, new, scv)
    _check_suite(s, new, c.task_version_id)
    check_campaign_sizes(s, c.owner_id, new, c.task_version_id, scv)
    row = add_config_version(s, c, new, scv, user_id, update.note or "edited")
    if c.status != CampaignStatus.draft.value:
        _lock_definitions(s, c)
    repo.add_event(
        s,
        c.id,
        "config_changed",
        f"config version {row.version}",
        data={
            "version": row.version,
            "changed": sorted(changes)
            + (["surrogate_config_version_id"] if update.surrogate_config_version_id else []),
        },
    )
    return row


def first_step(c: Campaign) -> StepRef:
    if c.source_campaign_id is not None and c.source_iteration is not None:
        return StepRef(c.source_iteration + 1, StepName.train)
    return StepRef(0, StepName.preliminary)


def start(s: Session, campaign_id: int) -> tuple[Campaign, list[StepJob]]:
    c = repo.get_campaign(s, campaign_id, lock=True)
    d = transition(state_of(c), Start(first_step(c)))
    # the owner's limits may have changed since the campaign was created
    check_campaign_sizes(s, c.owner_id, current_config(s, c), c.task_version_id, c.surrogate_config_version_id)
    _lock_definitions(s, c)
    c.started_at = c.started_at or utcnow()
    return c, apply_decision(s, c, d, note="started")


def pause(s: Session, campaign_id: int) -> tuple[Campaign, list[StepJob]]:
    """Pause after the running step (a queued step not yet claimed does not start)."""
    c = repo.get_campaign(s, campaign_id, lock=True)
    d = transition(state_of(c), Pause())
    if d.status is CampaignStatus.pausing and not repo.steps_of_campaign(
        s, c.id, [StepStatus.running.value, StepStatus.queued.value]
    ):
        d = Decision(CampaignStatus.paused)
    return c, apply_decision(s, c, d, note="pause requested")


def resume(s: Session, campaign_id: int) -> tuple[Campaign, list[StepJob]]:
    c = repo.get_campaign(s, campaign_id, lock=True)
    waiting = tuple(slots.waiting_steps(s, c))
    if c.status == CampaignStatus.paused.value and not waiting:
        raise InvalidTransition(c.status, "resume", "no step is waiting")
    return c, apply_decision(s, c, transition(state_of(c), Resume(waiting)), note="resumed")


def cancel(s: Session, campaign_id: int) -> tuple[Campaign, list[StepJob]]:
    """Cooperative: a running job sees ``cancel_requested`` at its next check and stops."""
    c = repo.get_campaign(s, campaign_id, lock=True)
    running = bool(repo.steps_of_campaign(s, c.id, [StepStatus.running.value]))
    return c, apply_decision(s, c, transition(state_of(c), Cancel(step_running=running)), note="cancel requested")


def retry_step(
    s: Session, campaign_id: int, iteration: int | None = None, step: str | None = None
) -> tuple[Campaign, list[StepJob]]:
    """Run a failed step again (default: the step that failed the campaign), with fresh attempts."""
    c = repo.get_campaign(s, campaign_id, lock=True)
    failed = repo.steps_of_campaign(s, c.id, [StepStatus.failed.value])
    if iteration is not None and step is not None:
        failed = [(k, r) for k, r in failed if k == iteration and r.step == step]
    if not failed:
        if iteration is None:
            raise Conflict(f"nothing to retry: no step of campaign {c.id} has failed (campaign status: {c.status})")
        raise Conflict(f"nothing to retry: step {step} of iteration {iteration} has not failed")
    k, row = failed[-1]
    ref = StepRef(k, StepName(row.step), row.slot)
    d = transition(state_of(c), RetryStep(ref))
    # a batch: the parallel slots the failure cancelled run again with it (the finished ones keep their results)
    again = [row]
    if ref.step in (StepName.ocp, StepName.oracle):
        siblings = repo.slot_steps(s, row.iteration_id, [StepName.ocp.value, StepName.oracle.value])
        again += [r for r in siblings if r is not row and r.status == StepStatus.cancelled.value]
        d = replace(d, enqueue=tuple(StepRef(k, StepName(r.step), r.slot) for r in again))
    for r in again:
        r.max_attempts = r.attempts + getattr(current_config(s, c).policies, ATTEMPTS_FIELD[StepName(r.step)])
        r.error = None
        r.config_version_id = repo.config_version(s, c).id  # a retry runs with the current settings
    it = repo.get_iteration(s, c.id, k)
    if it is not None:
        it.status, it.finished_at, it.error = IterationStatus.running.value, None, None
    c.error, c.stop_reason, c.finished_at = None, None, None
    return c, apply_decision(s, c, d, note=f"retry {ref}")


def fork(s: Session, campaign_id: int, req: ForkRequest, owner_id: int) -> tuple[Campaign, list[StepJob]]:
    """A new campaign continuing from iteration ``req.iteration`` of this one: it reuses that
    pool version (and model) and runs iterations ``req.iteration + 1, ...`` with its own settings."""
    src = repo.get_campaign(s, campaign_id)
    if pool_repo.version_of(s, src.id, req.iteration) is None:
        raise NotFound("iteration", message=f"campaign {campaign_id} has no pool version {req.iteration} to fork from")
    cfg = current_config(s, src)
    data = CampaignCreate(
        name=req.name or f"{src.name} (fork at {req.iteration})",
        description=f"fork of campaign {src.id} at iteration {req.iteration}",
        task_version_id=req.task_version_id or src.task_version_id,
        oracle_version_id=req.oracle_version_id or src.oracle_version_id,
        surrogate_config_version_id=req.surrogate_config_version_id or src.surrogate_config_version_id,
        seed=src.seed if req.seed is None else req.seed,
        preliminary=cfg.preliminary,
        stopping=req.stopping or cfg.stopping,
        policies=req.policies or cfg.policies,
        settings=req.settings or cfg.settings,
    )
    new = create_campaign(s, owner_id, data, source_campaign_id=src.id, source_iteration=req.iteration)
    repo.add_event(
        s,
        src.id,
        "forked",
        f"forked as campaign {new.id} at iteration {req.iteration}",
        data={"fork_id": new.id, "iteration": req.iteration},
    )
    if req.start:
        return start(s, new.id)
    return new, []
