"""A decision written to the campaign's rows: its status and flags, the step rows the decision
creates (queued, pending or skipped) or closes, its events; and the completion of a step, which
asks the state machine what follows.

The state machine (:mod:`alcove.campaigns.machine.state_machine`) decides; :func:`apply_decision`
writes the decision to the rows (campaign, iterations, steps, events) and returns the
:class:`StepJob` list to send after the caller commits. Never commits.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy.orm import Session

from alcove.campaigns import repository as repo
from alcove.campaigns.machine import admission
from alcove.campaigns.machine.slots import slots_after
from alcove.campaigns.machine.state_machine import Decision, Outcome, State, StepFinished, StepRef, transition
from alcove.campaigns.machine.step_rows import ensure_step, step_job
from alcove.jobs.campaign import StepJob
from alcove.models import Campaign, CampaignStatus, IterationStatus, IterationStep, StepName, StepStatus, utcnow


def state_of(c: Campaign) -> State:
    return State(CampaignStatus(c.status), pause_requested=c.pause_requested, cancel_requested=c.cancel_requested)


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
        row = ensure_step(s, c, ref, StepStatus.skipped)
        row.finished_at = utcnow()
    jobs = []
    for ref in (d.pending, *d.wait) if d.pending is not None else d.wait:
        ensure_step(s, c, ref, StepStatus.pending)
    for ref in d.enqueue:
        row = ensure_step(s, c, ref, StepStatus.queued)
        jobs.append(step_job(c, ref, row))
    if c.status not in admission.ACTIVE:
        c.wait_reason = None
    elif jobs and (old not in admission.ACTIVE or c.wait_reason is not None):
        # the campaign starts to run (again): its owner's running-campaigns limit may make it wait
        jobs = admission.hold_over_limit(s, c, jobs)
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
    """At a terminal state: pending/queued steps are cancelled, and so are the running parallel
    slots of the iteration (their jobs lose their claim and stop at their next check);
    unfinished iterations end."""
    now = utcnow()
    for _, row in repo.steps_of_campaign(
        s, c.id, [StepStatus.pending.value, StepStatus.queued.value, StepStatus.running.value]
    ):
        row.status = StepStatus.cancelled.value
        row.finished_at = now
        row.claim_token = None
        row.lease_until = None
    for it in repo.unfinished_iterations(s, c.id):
        it.status = IterationStatus.failed.value if status is CampaignStatus.failed else IterationStatus.cancelled.value
        it.finished_at = now
        if status is CampaignStatus.failed and c.error and not it.error:
            it.error = c.error


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
    slots = slots_after(s, c, it, ref, outcome)
    no_data = slots.open == 0 and slots.oracle_ok == 0 and not slots.picks
    if outcome is Outcome.iteration_failed and (no_data or ref.step not in (StepName.ocp, StepName.oracle)):
        # the iteration has no data (a batch with some picks replayed still succeeds; the
        # failed picks say why on their steps)
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
            **({"slot": ref.slot} if ref.slot else {}),
            "wall_time_s": wall_time_s,
            **({"stop_reason": stop_reason} if stop_reason else {}),
        },
    )
    d = transition(state_of(c), StepFinished(ref, outcome, stop_reason, error, slots))
    return apply_decision(s, c, d)
