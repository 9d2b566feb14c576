"""Campaign rules. Every function takes a ``Session``, never commits, and returns domain
objects plus, where the change makes work necessary, the :class:`StepJob` list that the
caller sends with :func:`alcove.jobs.campaign.enqueue` AFTER committing::

    with session_scope() as s:
        campaign, jobs = service.start(s, campaign_id)
    enqueue(jobs)

The state machine (:mod:`alcove.campaigns.state_machine`) decides; this module loads the
state, applies the decision to the rows (campaign, iterations, steps, events) and turns
``decision.enqueue`` into messages.
"""

from __future__ import annotations

import io
import json
import zipfile
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np
import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove.campaigns import repository as repo
from alcove.campaigns.repository import NotFound
from alcove.campaigns.schemas import (
    CampaignConfig,
    CampaignConfigUpdate,
    CampaignCreate,
    CampaignDetail,
    CampaignRead,
    EventRead,
    ForkRequest,
    IterationCurves,
    IterationRead,
    IterationTrajectory,
    MetricsRead,
    ModelVersionRead,
    OcpSolverSummary,
    PoolVersionRead,
    StepJob,
    StepRead,
    TrajectoryPhase,
)
from alcove.campaigns.state_machine import (
    Cancel,
    Decision,
    InvalidTransition,
    Outcome,
    Pause,
    Resume,
    RetryStep,
    Start,
    State,
    StepFinished,
    StepRef,
    transition,
)
from alcove.db.arrays import get_arrays
from alcove.jobs.campaign import step_queue
from alcove.models import (
    Campaign,
    CampaignConfigVersion,
    CampaignStatus,
    Iteration,
    IterationStatus,
    IterationStep,
    OracleVersion,
    StepName,
    StepStatus,
    SurrogateConfigVersion,
    TaskVersion,
    utcnow,
)
from alcove.pool import service as pool_service
from alcove.pool.service import upload_preliminary_dataset

__all__ = [
    "InvalidTransition",
    "NotFound",
    "cancel",
    "complete_step",
    "create_campaign",
    "current_config",
    "export_campaign",
    "fork",
    "get_detail",
    "iteration_curves",
    "list_events",
    "list_iterations",
    "list_jobs",
    "list_model_versions",
    "list_pool_versions",
    "metrics_series",
    "model_artifact_bytes",
    "pause",
    "pool_version_table",
    "resume",
    "retry_step",
    "start",
    "update_config",
    "upload_preliminary_dataset",
]

_ATTEMPTS_FIELD = {
    StepName.preliminary: "append_max_attempts",
    StepName.train: "train_max_attempts",
    StepName.ocp: "ocp_max_attempts",
    StepName.oracle: "oracle_max_attempts",
    StepName.evaluate: "evaluate_max_attempts",
    StepName.append: "append_max_attempts",
}


# ----------------------------------------------------------------------------- config


def config_from_version(row: CampaignConfigVersion) -> CampaignConfig:
    return CampaignConfig.model_validate(
        {
            "preliminary": row.preliminary_config,
            "stopping": row.stopping_rules,
            "policies": row.policies,
            "settings": row.settings,
        }
    )


def current_config(s: Session, campaign: Campaign) -> CampaignConfig:
    return config_from_version(repo.config_version(s, campaign))


def _add_config_version(
    s: Session,
    campaign: Campaign,
    cfg: CampaignConfig,
    surrogate_config_version_id: int,
    user_id: int | None,
    note: str,
) -> CampaignConfigVersion:
    version = (
        s.scalar(
            sa.select(sa.func.max(CampaignConfigVersion.version)).where(
                CampaignConfigVersion.campaign_id == campaign.id
            )
        )
        or 0
    ) + 1
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


def _check_definitions(
    s: Session, task_version_id: int, oracle_version_id: int, surrogate_config_version_id: int
) -> None:
    for model, ident, field in (
        (TaskVersion, task_version_id, "task_version_id"),
        (OracleVersion, oracle_version_id, "oracle_version_id"),
        (SurrogateConfigVersion, surrogate_config_version_id, "surrogate_config_version_id"),
    ):
        if s.get(model, ident) is None:
            raise NotFound(field, f"no {model.__tablename__[:-1].replace('_', ' ')} {ident}")


def _lock_definitions(s: Session, campaign: Campaign) -> None:
    now = utcnow()
    for model, ident in (
        (TaskVersion, campaign.task_version_id),
        (OracleVersion, campaign.oracle_version_id),
        (SurrogateConfigVersion, campaign.surrogate_config_version_id),
    ):
        row = s.get(model, ident)
        if row is not None and row.locked_at is None:
            row.locked_at = now


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
    if cfg.preliminary.dataset_ids:
        from alcove.pool.repository import datasets

        datasets(s, cfg.preliminary.dataset_ids)  # raises NotFound naming the id
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
    _add_config_version(s, c, cfg, data.surrogate_config_version_id, owner_id, "created")
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
    row = _add_config_version(s, c, new, scv, user_id, update.note or "edited")
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


# ----------------------------------------------------------------------------- steps and decisions


def _state(c: Campaign) -> State:
    return State(CampaignStatus(c.status), pause_requested=c.pause_requested, cancel_requested=c.cancel_requested)


def _ensure_iteration(s: Session, c: Campaign, index: int) -> Iteration:
    it = repo.get_iteration(s, c.id, index)
    if it is None:
        cv = repo.config_version(s, c)
        it = Iteration(campaign_id=c.id, index=index, config_version_id=cv.id, status=IterationStatus.pending.value)
        s.add(it)
        s.flush()
    return it


def _ensure_step(s: Session, c: Campaign, ref: StepRef, status: StepStatus) -> IterationStep:
    it = _ensure_iteration(s, c, ref.iteration)
    row = repo.get_step(s, c.id, ref.iteration, ref.step.value)
    if row is None:
        policies = current_config(s, c).policies
        row = IterationStep(
            campaign_id=c.id,
            iteration_id=it.id,
            step=ref.step.value,
            queue=step_queue(ref.step.value),
            config_version_id=it.config_version_id,
            max_attempts=getattr(policies, _ATTEMPTS_FIELD[ref.step]),
            status=status.value,
            result={},
        )
        s.add(row)
    row.status = status.value
    if status is StepStatus.queued:
        row.queued_at = utcnow()
        row.claim_token = None
        row.lease_until = None
        if it.status == IterationStatus.pending.value:
            it.status = IterationStatus.running.value
            it.started_at = utcnow()
    it.current_step = ref.step.value
    c.current_iteration = ref.iteration
    c.current_step = ref.step.value
    s.flush()
    return row


def _job(c: Campaign, ref: StepRef, row: IterationStep) -> StepJob:
    return StepJob(campaign_id=c.id, iteration=ref.iteration, step=ref.step, attempt=row.attempts + 1)


def apply_decision(s: Session, c: Campaign, d: Decision, *, note: str = "") -> list[StepJob]:
    """Write a decision to the rows and return the jobs to send after commit."""
    old = c.status
    c.status = d.status.value
    c.pause_requested = d.pause_requested if d.status in (CampaignStatus.pausing, CampaignStatus.paused) else False
    if d.cancel_requested:
        c.cancel_requested = True
    if d.stop_reason is not None:
        c.stop_reason = d.stop_reason
    if d.error is not None:
        c.error = d.error
    for ref in d.skip:
        row = _ensure_step(s, c, ref, StepStatus.skipped)
        row.finished_at = utcnow()
    jobs = []
    if d.pending is not None:
        _ensure_step(s, c, d.pending, StepStatus.pending)
    for ref in d.enqueue:
        row = _ensure_step(s, c, ref, StepStatus.queued)
        jobs.append(_job(c, ref, row))
    if d.status is CampaignStatus.running and c.started_at is None:
        c.started_at = utcnow()
    if d.is_terminal:
        c.finished_at = utcnow()
        _close_open_steps(s, c, d.status)
    if old != c.status:
        repo.add_event(
            s,
            c.id,
            "status",
            note or f"{old} -> {c.status}",
            data={"from": old, "to": c.status, "stop_reason": d.stop_reason},
        )
    s.flush()
    return jobs


def _close_open_steps(s: Session, c: Campaign, status: CampaignStatus) -> None:
    """At a terminal state: pending/queued steps are cancelled; unfinished iterations end."""
    now = utcnow()
    for _, row in repo.steps_of_campaign(s, c.id, [StepStatus.pending.value, StepStatus.queued.value]):
        row.status = StepStatus.cancelled.value
        row.finished_at = now
    its = s.scalars(
        sa.select(Iteration).where(
            Iteration.campaign_id == c.id,
            Iteration.status.in_([IterationStatus.pending.value, IterationStatus.running.value]),
        )
    )
    for it in its:
        it.status = IterationStatus.failed.value if status is CampaignStatus.failed else IterationStatus.cancelled.value
        it.finished_at = now
        if status is CampaignStatus.failed and c.error and not it.error:
            it.error = c.error


def first_step(c: Campaign) -> StepRef:
    if c.source_campaign_id is not None and c.source_iteration is not None:
        return StepRef(c.source_iteration + 1, StepName.train)
    return StepRef(0, StepName.preliminary)


def start(s: Session, campaign_id: int) -> tuple[Campaign, list[StepJob]]:
    c = repo.get_campaign(s, campaign_id, lock=True)
    d = transition(_state(c), Start(first_step(c)))
    _lock_definitions(s, c)
    c.started_at = c.started_at or utcnow()
    return c, apply_decision(s, c, d, note="started")


def pause(s: Session, campaign_id: int) -> tuple[Campaign, list[StepJob]]:
    """Pause after the running step (a queued step not yet claimed does not start)."""
    c = repo.get_campaign(s, campaign_id, lock=True)
    d = transition(_state(c), Pause())
    if d.status is CampaignStatus.pausing and not repo.steps_of_campaign(
        s, c.id, [StepStatus.running.value, StepStatus.queued.value]
    ):
        d = Decision(CampaignStatus.paused)
    return c, apply_decision(s, c, d, note="pause requested")


def _waiting_step(s: Session, c: Campaign) -> StepRef | None:
    rows = repo.steps_of_campaign(s, c.id, [StepStatus.pending.value])
    if not rows:
        return None
    k, row = rows[-1]
    return StepRef(k, StepName(row.step))


def resume(s: Session, campaign_id: int) -> tuple[Campaign, list[StepJob]]:
    c = repo.get_campaign(s, campaign_id, lock=True)
    nxt = _waiting_step(s, c)
    if c.status == CampaignStatus.paused.value and nxt is None:
        raise InvalidTransition(c.status, "resume", "no step is waiting")
    return c, apply_decision(s, c, transition(_state(c), Resume(nxt)), note="resumed")


def cancel(s: Session, campaign_id: int) -> tuple[Campaign, list[StepJob]]:
    """Cooperative: a running job sees ``cancel_requested`` at its next check and stops."""
    c = repo.get_campaign(s, campaign_id, lock=True)
    running = bool(repo.steps_of_campaign(s, c.id, [StepStatus.running.value]))
    return c, apply_decision(s, c, transition(_state(c), Cancel(step_running=running)), note="cancel requested")


def retry_step(
    s: Session, campaign_id: int, iteration: int | None = None, step: str | None = None
) -> tuple[Campaign, list[StepJob]]:
    """Run a failed step again (default: the step that failed the campaign), with fresh attempts."""
    c = repo.get_campaign(s, campaign_id, lock=True)
    failed = repo.steps_of_campaign(s, c.id, [StepStatus.failed.value])
    if iteration is not None and step is not None:
        failed = [(k, r) for k, r in failed if k == iteration and r.step == step]
    if not failed:
        raise NotFound(
            "step",
            "no failed step to retry" if iteration is None else f"step {step} of iteration {iteration} has not failed",
        )
    k, row = failed[-1]
    ref = StepRef(k, StepName(row.step))
    d = transition(_state(c), RetryStep(ref))
    row.max_attempts = row.attempts + getattr(current_config(s, c).policies, _ATTEMPTS_FIELD[ref.step])
    row.error = None
    row.config_version_id = repo.config_version(s, c).id  # a retry runs with the current settings (e.g. after an edit)
    it = repo.get_iteration(s, c.id, k)
    if it is not None:
        it.status, it.finished_at, it.error = IterationStatus.running.value, None, None
    c.error, c.stop_reason, c.finished_at = None, None, None
    return c, apply_decision(s, c, d, note=f"retry {ref}")


def fork(s: Session, campaign_id: int, req: ForkRequest, owner_id: int) -> tuple[Campaign, list[StepJob]]:
    """A new campaign continuing from iteration ``req.iteration`` of this one: it reuses that
    pool version (and model) and runs iterations ``req.iteration + 1, ...`` with its own settings."""
    src = repo.get_campaign(s, campaign_id)
    if repo.pool_version(s, src, req.iteration) is None:
        raise NotFound("iteration", f"campaign {campaign_id} has no pool version {req.iteration} to fork from")
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


# ----------------------------------------------------------------------------- completing a step (used by the flows)


def complete_step(
    s: Session,
    c: Campaign,
    ref: StepRef,
    row: IterationStep,
    outcome: Outcome,
    *,
    result: dict[str, Any] | None = None,
    error: str | None = None,
    stop_reason: str | None = None,
    wall_time_s: float | None = None,
) -> list[StepJob]:
    """Record a finished step and apply what the state machine decides (same transaction)."""
    now = utcnow()
    row.status = {
        Outcome.succeeded: StepStatus.succeeded,
        Outcome.iteration_failed: StepStatus.failed,
        Outcome.failed: StepStatus.failed,
        Outcome.cancelled: StepStatus.cancelled,
    }[outcome].value
    row.finished_at = now
    row.lease_until = None
    row.wall_time_s = wall_time_s
    row.error = error
    if result:
        row.result = {**(row.result or {}), **result}
    it = repo.get_iteration(s, c.id, ref.iteration)
    assert it is not None
    if outcome is Outcome.iteration_failed:
        it.error = error or f"{ref.step.value} failed"
    if ref.step in (StepName.append, StepName.preliminary) and outcome is Outcome.succeeded:
        it.status = IterationStatus.failed.value if it.error else IterationStatus.succeeded.value
        it.finished_at = now
        it.current_step = None
    repo.add_event(
        s,
        c.id,
        f"step_{row.status}",
        error or "",
        iteration=ref.iteration,
        step=ref.step.value,
        data={
            "attempt": row.attempts,
            "wall_time_s": wall_time_s,
            **({"stop_reason": stop_reason} if stop_reason else {}),
        },
    )
    d = transition(_state(c), StepFinished(ref, outcome, stop_reason, error))
    return apply_decision(s, c, d)


# ----------------------------------------------------------------------------- reads


def _metrics_read(m: Any) -> MetricsRead:
    return MetricsRead.model_validate(m)


def get_detail(s: Session, campaign_id: int) -> CampaignDetail:
    c = repo.get_campaign(s, campaign_id)
    cfg = current_config(s, c)
    it = repo.get_iteration_with_steps(s, c.id, c.current_iteration)
    latest = repo.latest_metrics(s, c.id)
    times = repo.finished_iteration_times(s, c.id)
    done = [
        (k, st, a, b)
        for k, st, a, b in times
        if st in (IterationStatus.succeeded.value, IterationStatus.failed.value) and a and b
    ]
    recent = [(b - a).total_seconds() for _, _, a, b in done[-20:]]
    mean = float(np.mean(recent)) if recent else None
    eta = None
    if mean is not None and cfg.stopping.max_iterations is not None and not c.is_terminal:
        last_done = done[-1][0] if done else (c.source_iteration or 0)
        eta = max(cfg.stopping.max_iterations - last_done, 0) * mean
    return CampaignDetail(
        campaign=CampaignRead.model_validate(c),
        config=cfg,
        current=IterationRead.model_validate(it) if it is not None else None,
        latest_metrics=_metrics_read(latest) if latest is not None else None,
        iterations_finished=sum(1 for d in done if d[1] == IterationStatus.succeeded.value),
        iterations_failed=sum(1 for d in done if d[1] == IterationStatus.failed.value),
        mean_iteration_s=mean,
        eta_s=eta,
    )


def get_campaign(s: Session, campaign_id: int) -> CampaignRead:
    return CampaignRead.model_validate(repo.get_campaign(s, campaign_id))


def list_campaigns(s: Session, owner_id: int | None = None) -> list[CampaignRead]:
    return [CampaignRead.model_validate(c) for c in repo.list_campaigns(s, owner_id)]


def metrics_series(
    s: Session, campaign_id: int, after: int | None = None, *, inherited: bool = False
) -> list[MetricsRead]:
    """Per-iteration metrics; ``after=k`` returns only iterations > k (cheap polling). With
    ``inherited``, a fork's series starts with its sources' iterations up to the fork point
    (flagged ``inherited``), as its pool and model lineage does."""
    c = repo.get_campaign(s, campaign_id)
    rows = [_metrics_read(m) for m in repo.metrics_series(s, campaign_id, after)]
    if not inherited:
        return rows
    before: list[MetricsRead] = []
    source, through = c.source_campaign_id, c.source_iteration
    while source is not None and through is not None:
        src = repo.get_campaign(s, source)
        own = [m for m in repo.metrics_series(s, src.id, after) if m.iteration_index <= through]
        before = [_metrics_read(m).model_copy(update={"inherited": True}) for m in own] + before
        source, through = src.source_campaign_id, min(through, src.source_iteration or 0)
    return before + rows


def list_iterations(s: Session, campaign_id: int, after: int | None = None) -> list[IterationRead]:
    return [IterationRead.model_validate(i) for i in repo.list_iterations(s, campaign_id, after)]


def list_events(s: Session, campaign_id: int, after: int = 0) -> list[EventRead]:
    return [EventRead.model_validate(e) for e in repo.events(s, campaign_id, after)]


def iteration_curves(s: Session, campaign_id: int, iteration: int) -> IterationCurves:
    m = repo.metrics_of(s, campaign_id, iteration)
    if m is None or m.curves_sha256 is None:
        raise NotFound("iteration", f"campaign {campaign_id} has no evaluated iteration {iteration}")
    a = get_arrays(s, m.curves_sha256)
    tau = a["tau"] if "tau" in a else _replayed_tau(s, m.iteration_id, a["t"])
    return IterationCurves(
        iteration_index=iteration,
        t=a["t"].tolist(),
        q=a["q"].tolist(),
        qd=a["qd"].tolist(),
        tau=None if tau is None else tau.tolist(),
        f_true=a["f_true"].tolist(),
        f_pred=a["f_pred"].tolist(),
    )


def iteration_trajectory(s: Session, campaign_id: int, iteration: int) -> IterationTrajectory:
    """Iteration k's whole OCP solution (its latest attempt, converged or not) over every
    phase of the task, with the phase boundaries, the part the oracle replayed and the
    solver summary. An iteration up to a fork's source iteration reads the source's."""
    c = repo.get_campaign(s, campaign_id)
    cid, k = repo.resolve_source(s, c, iteration)  # type: ignore[misc]
    it = repo.get_iteration(s, cid, k)
    sol = repo.latest_ocp_solution(s, it.id) if it is not None else None
    if sol is None or sol.trajectory_sha256 is None:
        raise NotFound(
            "iteration",
            f"campaign {campaign_id} has no OCP solution for iteration {iteration} (iteration 0 has none; a later one has none until its OCP step ran)",
        )
    owner = c if cid == c.id else s.get(Campaign, cid)
    spec = s.get(TaskVersion, owner.task_version_id).spec
    cv = s.get(CampaignConfigVersion, it.config_version_id) if it.config_version_id else None
    settings = (config_from_version(cv) if cv is not None else current_config(s, owner)).settings
    a = get_arrays(s, sol.trajectory_sha256)
    t = np.asarray(a["t"], float)
    q = np.asarray(a["q"], float).reshape(len(t), -1)
    start = float(t[0]) if len(t) else 0.0
    phases, t0 = [], start
    n_replayed = min(settings.replay_phases, len(spec["phases"]))
    for m, ph in enumerate(spec["phases"]):
        d = float(ph["duration"])
        phases.append(
            TrajectoryPhase(
                index=m, name=ph.get("name") or "", duration=d, t_start=t0, t_end=t0 + d, replayed=m < n_replayed
            )
        )
        t0 += d
    return IterationTrajectory(
        iteration_index=iteration,
        t=t.tolist(),
        q=q.tolist(),
        qd=np.asarray(a["qd"], float).reshape(q.shape).tolist(),
        tau=np.asarray(a["tau"], float).reshape(q.shape).tolist(),
        duration=t0 - start,
        phases=phases,
        replay_phases=n_replayed,
        replay_t_end=phases[n_replayed - 1].t_end,
        replay_dt=settings.replay_dt,
        solver=OcpSolverSummary(
            status=sol.solver_status,
            converged=bool(sol.success),
            iterations=sol.n_iterations,
            cost=sol.cost,
            wall_time_s=sol.wall_time_s,
            attempt=sol.attempt,
            initial_guess=sol.initial_guess,
            message=sol.message or "",
        ),
    )


def _replayed_tau(s: Session, iteration_id: int, t: np.ndarray) -> np.ndarray | None:
    """The joint torque of the motion the oracle replayed in this iteration, on the grid
    ``t`` of the curves (linear, as the replay itself interpolates torque)."""
    from alcove.models import OracleRun

    sha = s.scalar(
        sa.select(OracleRun.input_sha256)
        .where(OracleRun.iteration_id == iteration_id, OracleRun.status == "ok")
        .order_by(OracleRun.id.desc())
        .limit(1)
    )
    if sha is None:
        return None
    r = get_arrays(s, sha)
    if r.get("tau") is None:
        return None
    tau = np.asarray(r["tau"], float).reshape(len(r["t"]), -1)
    return np.stack([np.interp(t, r["t"], tau[:, j]) for j in range(tau.shape[1])], -1)


def list_jobs(s: Session, campaign_id: int, statuses: list[str] | None = None) -> list[dict[str, Any]]:
    """Every step row (the unit of Celery work) with its iteration index."""
    repo.get_campaign(s, campaign_id)
    return [
        {"iteration": k, **StepRead.model_validate(r).model_dump()}
        for k, r in repo.steps_of_campaign(s, campaign_id, statuses)
    ]


def list_pool_versions(s: Session, campaign_id: int) -> list[PoolVersionRead]:
    repo.get_campaign(s, campaign_id)
    return [PoolVersionRead.model_validate(p) for p in repo.own_pool_versions(s, campaign_id)]


def pool_version_table(s: Session, campaign_id: int, version: int, fmt: str = "csv") -> bytes:
    c = repo.get_campaign(s, campaign_id)
    pv = repo.pool_version(s, c, version)
    if pv is None:
        raise NotFound("version", f"campaign {campaign_id} has no pool version {version}")
    return pool_service.pool_version_table(s, pv, fmt)


def list_model_versions(s: Session, campaign_id: int) -> list[ModelVersionRead]:
    repo.get_campaign(s, campaign_id)
    return [ModelVersionRead.model_validate(m) for m in repo.own_model_versions(s, campaign_id)]


def model_artifact_bytes(s: Session, campaign_id: int, version: int) -> bytes:
    """Zip of the model artifact (surrogate.json + TorchScript force.pt / moment.pt)."""
    from alcove.surrogates.service import model_artifact_bytes as artifact

    c = repo.get_campaign(s, campaign_id)
    mv = repo.model_version(s, c, version)
    if mv is None:
        raise NotFound("version", f"campaign {campaign_id} has no model version {version}")
    return artifact(s, mv)


def export_campaign(
    s: Session, campaign_id: int, folder: str | Path | None = None, *, pool_format: str = "parquet", models: bool = True
) -> bytes | Path:
    """Everything a campaign produced: ``campaign.json`` (settings, status, lineage),
    ``metrics.csv``/``metrics.json``, ``iterations.json``, ``pool/version-KKKK.<fmt>``,
    ``models/model-KKKK.zip``, ``curves/iteration-KKKK.npz``. Written into ``folder`` (returned),
    or as zip bytes when ``folder`` is None."""
    c = repo.get_campaign(s, campaign_id)
    files: dict[str, bytes] = {}
    detail = get_detail(s, campaign_id)
    files["campaign.json"] = json.dumps(
        {
            "campaign": detail.campaign.model_dump(mode="json"),
            "config": detail.config.model_dump(mode="json"),
            "config_versions": [
                {
                    "version": v.version,
                    "note": v.note,
                    "created_at": v.created_at.isoformat(),
                    **config_from_version(v).model_dump(mode="json"),
                }
                for v in s.scalars(
                    sa.select(CampaignConfigVersion)
                    .where(CampaignConfigVersion.campaign_id == c.id)
                    .order_by(CampaignConfigVersion.version)
                )
            ],
            "pool_versions": [p.model_dump(mode="json") for p in list_pool_versions(s, c.id)],
            "model_versions": [m.model_dump(mode="json") for m in list_model_versions(s, c.id)],
        },
        indent=1,
    ).encode()
    series = metrics_series(s, c.id)
    files["metrics.json"] = json.dumps([m.model_dump(mode="json") for m in series], indent=1).encode()
    cols = [
        "iteration_index",
        "force_rmse",
        "moment_rmse",
        "force_max_error",
        "moment_max_error",
        "ocp_success",
        "ocp_status",
        "ocp_iterations",
        "ocp_cost",
        "ocp_wall_time_s",
        "oracle_wall_time_s",
        "train_wall_time_s",
        "n_pool_samples",
        "model_version_id",
        "dataset_id",
    ]
    lines = [",".join(cols)] + [
        ",".join("" if getattr(m, k) is None else str(getattr(m, k)) for k in cols) for m in series
    ]
    files["metrics.csv"] = ("\n".join(lines) + "\n").encode()
    files["iterations.json"] = json.dumps(
        [i.model_dump(mode="json") for i in list_iterations(s, c.id)], indent=1
    ).encode()
    for pv in repo.own_pool_versions(s, c.id):
        files[f"pool/version-{pv.version:04d}.{pool_format}"] = pool_service.pool_version_table(s, pv, pool_format)
    if models:
        from alcove.surrogates.service import model_artifact_bytes as artifact

        for mv in repo.own_model_versions(s, c.id):
            files[f"models/model-{mv.version:04d}.zip"] = artifact(s, mv)
    for m in repo.metrics_series(s, c.id):
        if m.curves_sha256:
            from alcove.db.arrays import get_bytes

            files[f"curves/iteration-{m.iteration_index:04d}.npz"] = get_bytes(s, m.curves_sha256)
    if folder is None:
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
            for name, data in files.items():
                zf.writestr(f"campaign-{c.id}/{name}", data)
        return buf.getvalue()
    root = Path(folder)
    for name, data in files.items():
        p = root / name
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data)
    return root


def running_since(row: IterationStep) -> datetime | None:
    return row.started_at if row.status == StepStatus.running.value else None
