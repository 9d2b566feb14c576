"""The iteration and step rows a decision creates: a step row (and its iteration's, the first
time) in the status the decision gives it, and the job message that runs it. Used where a
decision is applied (:mod:`alcove.campaigns.machine.apply`) and where a waiting campaign is
admitted (:mod:`alcove.campaigns.machine.admission`)."""

from __future__ import annotations

from sqlalchemy.orm import Session

from alcove.campaigns import repository as repo
from alcove.campaigns.config import current_config
from alcove.campaigns.machine.state_machine import StepRef
from alcove.jobs.campaign import StepJob, step_queue
from alcove.models import Campaign, Iteration, IterationStatus, IterationStep, StepName, StepStatus, utcnow

#: the policy field that bounds a step's attempts
ATTEMPTS_FIELD = {
    StepName.preliminary: "append_max_attempts",
    StepName.train: "train_max_attempts",
    StepName.ocp: "ocp_max_attempts",
    StepName.oracle: "oracle_max_attempts",
    StepName.evaluate: "evaluate_max_attempts",
    StepName.append: "append_max_attempts",
}


def ensure_iteration(s: Session, c: Campaign, index: int) -> Iteration:
    it = repo.get_iteration(s, c.id, index)
    if it is None:
        cv = repo.config_version(s, c)
        it = Iteration(campaign_id=c.id, index=index, config_version_id=cv.id, status=IterationStatus.pending.value)
        s.add(it)
        s.flush()
    return it


def ensure_step(s: Session, c: Campaign, ref: StepRef, status: StepStatus) -> IterationStep:
    it = ensure_iteration(s, c, ref.iteration)
    row = repo.get_step(s, c.id, ref.iteration, ref.step.value, ref.slot)
    if row is None:
        policies = current_config(s, c).policies
        row = IterationStep(
            campaign_id=c.id,
            iteration_id=it.id,
            step=ref.step.value,
            slot=ref.slot,
            queue=step_queue(ref.step.value),
            config_version_id=it.config_version_id,
            max_attempts=getattr(policies, ATTEMPTS_FIELD[ref.step]),
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


def step_job(c: Campaign, ref: StepRef, row: IterationStep) -> StepJob:
    return StepJob(campaign_id=c.id, iteration=ref.iteration, step=ref.step, attempt=row.attempts + 1, slot=ref.slot)
