"""The job protocol: what a Celery job does with one step message of one iteration.

Every job runs :func:`run_step`, the same protocol for all steps:

1. **claim** (one transaction): ``UPDATE iteration_steps SET status='running', attempts=n,
   claim_token=..., lease_until=... WHERE id=... AND status='queued' AND attempts=n-1``. A
   duplicate or stale message matches no row and the job returns ``duplicate``. A
   campaign that is pausing or cancelling does not start the step.
2. **compute** outside any transaction: the step's domain computes it
   (:mod:`alcove.campaigns.run.steps` says which), while a :class:`LeaseKeeper` thread extends
   the lease and reads the cancel flag, which the computation checks cooperatively.
3. **complete** (one transaction, conditional on still holding the claim token): the
   domain writes its rows, the step is marked, the state machine decides, the next step
   row is created; the next message is sent only after this commit.

Failures: an exception is retried (step back to ``queued``, attempt n+1) until
``max_attempts``; bad input (a ``ValueError`` with a ``field``) is not retried. Then the
step's policy applies: a failed OCP or oracle marks the iteration failed and the campaign
continues with ``append`` (or stops, if configured); other steps fail the campaign. A
result failing the oracle's quality gate is quarantined with its reason, never appended.
"""

from __future__ import annotations

import logging
import threading
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

from sqlalchemy.orm import Session

from alcove.campaigns import repository as repo
from alcove.campaigns.config import CampaignConfig, config_from_version, current_config
from alcove.campaigns.machine import admission
from alcove.campaigns.machine.apply import apply_decision, complete_step
from alcove.campaigns.machine.state_machine import Decision, Outcome, StepRef
from alcove.campaigns.run.step_context import StepContext
from alcove.campaigns.run.steps import STEPS
from alcove.db import run_transaction
from alcove.jobs.campaign import StepJob, send_committed, stage
from alcove.jobs.faults import fault_for
from alcove.jobs.step_contract import (
    FailedAttempt,
    IterationRef,
    StepOutput,
    StepPaused,
    StepRun,
    UnusableResult,
    WriteRows,
    is_bad_input,
    is_cancellation,
)
from alcove.models import (
    Campaign,
    CampaignConfigVersion,
    CampaignStatus,
    Iteration,
    IterationStep,
    StepName,
    StepStatus,
    utcnow,
)

log = logging.getLogger(__name__)


class LeaseKeeper(threading.Thread):
    """Extends the step's lease every ``interval`` s and caches the campaign's cancel flag."""

    def __init__(self, step_id: int, token: str, lease_seconds: float, interval: float):
        super().__init__(name=f"alcove-lease-{step_id}", daemon=True)
        self.step_id, self.token, self.lease_seconds, self.interval = step_id, token, lease_seconds, interval
        self.cancel_requested = False
        self.pause_requested = False
        self.lost = False
        self._stop_event = threading.Event()

    def run(self) -> None:
        while not self._stop_event.wait(self.interval):
            try:
                (ours, cancel), pause = run_transaction(
                    lambda s: (
                        repo.extend_lease(s, self.step_id, self.token, self.lease_seconds),
                        repo.pause_requested_of(s, self.step_id),
                    )
                )
                self.cancel_requested = self.cancel_requested or cancel
                self.pause_requested = pause
                if not ours:
                    self.lost = True
                    self.cancel_requested = True  # someone else owns the step now: stop working on it
                    return
            except Exception:  # a missed beat is fine; the lease is longer
                log.exception("lease heartbeat of step %s failed", self.step_id)

    def stop(self) -> None:
        self._stop_event.set()


def lease_seconds() -> float:
    from alcove.settings import get_settings

    return float(get_settings().job_lease_seconds)


@dataclass
class Failure:
    """How a step's computation ended when it produced no usable output. ``outcome`` None:
    an exception (retried while attempts remain, unless ``bad_input``)."""

    outcome: Outcome | None
    message: str
    write: WriteRows | None = None
    bad_input: bool = False
    paused: bool = False  # the step gave its work back to the pausing campaign (StepPaused)


def run_step(
    campaign_id: int,
    iteration: int,
    step: str,
    attempt: int,
    *,
    worker_name: str = "local",
    send: Callable[[list[StepJob]], Any] | None = None,
    slot: int = 0,
) -> dict[str, Any]:
    """Run one step message. Returns a small status dict (for logs and tests).

    The jobs a transaction makes necessary are recorded in the job outbox in that same
    transaction and sent after its commit (:mod:`alcove.jobs.outbox`); ``send`` replaces
    that (``drive_inline``: a list in this process, no broker)."""
    durable = send is None
    t_job = time.perf_counter()
    ref = StepRef(iteration, StepName(step), slot)
    token = uuid.uuid4().hex
    lease = lease_seconds()

    status, step_id, config, jobs = run_transaction(
        _staging(lambda s: _claim(s, campaign_id, ref, attempt, token, worker_name, lease), durable)
    )
    if status != "claimed":
        _dispatch(jobs, send)
        return {"status": status, "step": str(ref), "attempt": attempt}
    assert step_id is not None and config is not None
    t_claimed = time.perf_counter()
    keeper = LeaseKeeper(step_id, token, lease, interval=max(0.5, lease / 4))
    keeper.start()
    run = StepRun(
        attempt,
        worker_name,
        lambda: keeper.cancel_requested,
        fault_for(campaign_id, ref.step.value, ref.iteration, ref.slot),
        pause_flag=lambda: keeper.pause_requested,
    )
    try:
        output, failure = _compute(StepContext(campaign_id, ref, config, run))
    finally:
        keeper.stop()
    if keeper.lost:
        return {"status": "lost", "step": str(ref), "attempt": attempt}

    t_done = time.perf_counter()
    timing = {"claim_s": t_claimed - t_job, "compute_s": output.compute_s if output else t_done - t_claimed}

    def complete(s: Session) -> list[StepJob] | None:
        row = repo.owned_running_step(s, step_id, token)
        if row is None:
            return None  # the reconciler gave the step to another job
        c = repo.get_campaign(s, campaign_id, lock=True)
        at = IterationRef(c.id, row.iteration_id, ref.iteration, ref.slot)
        wall = time.perf_counter() - t_job  # the step's wall time: up to the writing of its results
        base = {**timing, "worker": worker_name, "queue_latency_s": _latency(row)}
        if output is not None:
            result = output.write(s, at)
            base["write_s"] = time.perf_counter() - t_done
            return complete_step(
                s,
                c,
                ref,
                row,
                Outcome.succeeded,
                result={**base, **result},
                stop_reason=result.get("stop_reason"),
                wall_time_s=wall,
            )
        assert failure is not None
        if failure.write is not None:
            failure.write(s, at)
        if failure.paused:
            return _give_back(s, c, ref, row, failure.message)
        outcome = failure.outcome
        if outcome is None:  # an exception: retry while attempts remain (unless bad input)
            if row.attempts < row.max_attempts and not failure.bad_input:
                return _requeue(s, c.id, ref, row, failure.message)
            outcome = policy_outcome(config, ref)
        return complete_step(s, c, ref, row, outcome, result=base, error=failure.message, wall_time_s=wall)

    next_jobs = run_transaction(_staging(complete, durable))
    if next_jobs is None:
        return {"status": "lost", "step": str(ref), "attempt": attempt}
    _dispatch(next_jobs, send)
    # a campaign that ended frees a place of its owner's running-campaigns limit
    _dispatch(run_transaction(_staging(lambda s: admission.admit_owner_of(s, campaign_id), durable)), send)
    ended = "done" if failure is None else ("cancelled" if failure.outcome is Outcome.cancelled else "failed")
    return {
        "status": ended,
        "step": str(ref),
        "attempt": attempt,
        "next": [f"{j.iteration}/{j.step.value}[{j.slot}]#{j.attempt}" for j in next_jobs],
        **timing,
        "total_s": time.perf_counter() - t_job,
    }


class _Staged(list[StepJob]):
    """Step jobs already recorded in the outbox (``ids``), to send after the commit."""

    ids: list[int]


R = TypeVar("R")


def _staging(work: Callable[[Session], R], durable: bool) -> Callable[[Session], R]:
    """``work`` plus, when ``durable``, recording the jobs it returns (a list, or the last
    item of a tuple) in the outbox in the same transaction."""
    if not durable:
        return work

    def staged(s: Session) -> Any:
        out: Any = work(s)
        jobs = out[-1] if isinstance(out, tuple) else out
        if jobs is None:
            return out
        st = _Staged(jobs)
        st.ids = stage(s, jobs)
        return (*out[:-1], st) if isinstance(out, tuple) else st

    return staged


def _dispatch(jobs: list[StepJob], send: Callable[[list[StepJob]], Any] | None) -> None:
    if send is not None:
        if jobs:
            send(jobs)
    elif isinstance(jobs, _Staged):
        send_committed(jobs.ids)


def _compute(ctx: StepContext) -> tuple[StepOutput | None, Failure | None]:
    """The step's computation by its domain, every way it can end."""
    t0 = time.perf_counter()
    try:
        output = STEPS[ctx.ref.step](ctx)
    except UnusableResult as err:
        return None, Failure(policy_outcome(ctx.config, ctx.ref), err.reason, err.write)
    except StepPaused as err:
        return None, Failure(None, str(err), paused=True)
    except FailedAttempt as err:
        if is_cancellation(err.cause):
            return None, Failure(Outcome.cancelled, str(err.cause))
        log.error("step %s of campaign %s failed (attempt %d): %s", ctx.ref, ctx.campaign_id, ctx.run.attempt, err)
        return None, Failure(None, str(err), err.write, is_bad_input(err.cause))
    except Exception as err:  # every failure is recorded on the step
        if is_cancellation(err):
            return None, Failure(Outcome.cancelled, str(err))
        log.exception("step %s of campaign %s failed (attempt %d)", ctx.ref, ctx.campaign_id, ctx.run.attempt)
        return None, Failure(None, f"{type(err).__name__}: {err}", bad_input=is_bad_input(err))
    output.compute_s = output.compute_s or (time.perf_counter() - t0)
    return output, None


def _claim(
    s: Session, campaign_id: int, ref: StepRef, attempt: int, token: str, worker: str, lease: float
) -> tuple[str, int | None, CampaignConfig | None, list[StepJob]]:
    row = repo.get_step(s, campaign_id, ref.iteration, ref.step.value, ref.slot)
    if row is None:
        return "missing", None, None, []
    if row.status != StepStatus.queued.value or row.attempts != attempt - 1:
        return "duplicate", None, None, []
    c = repo.get_campaign(s, campaign_id, lock=True)
    if c.is_terminal:
        row.status, row.finished_at = StepStatus.cancelled.value, utcnow()
        return "cancelled", None, None, []
    if c.cancel_requested:
        jobs = complete_step(s, c, ref, row, Outcome.cancelled, error="cancelled before it started")
        return "cancelled", None, None, jobs
    if c.pause_requested or c.status in (CampaignStatus.pausing.value, CampaignStatus.paused.value):
        row.status = StepStatus.pending.value
        s.flush()
        if repo.steps_of_campaign(s, c.id, [StepStatus.running.value, StepStatus.queued.value]):
            return "paused", None, None, []  # parallel slots still busy: the last one pauses the campaign
        apply_decision(s, c, Decision(CampaignStatus.paused), note="paused before the next step")
        return "paused", None, None, []
    if not repo.claim_step(s, row.id, attempt, token, worker, lease):
        return "duplicate", None, None, []
    if c.status == CampaignStatus.queued.value:
        apply_decision(s, c, Decision(CampaignStatus.running), note="first step claimed")
    it = s.get(Iteration, row.iteration_id)
    assert it is not None
    cv = s.get(CampaignConfigVersion, row.config_version_id or it.config_version_id)
    config = config_from_version(cv) if cv is not None else current_config(s, c)
    repo.add_event(
        s,
        campaign_id,
        "step_started",
        worker,
        iteration=ref.iteration,
        step=ref.step.value,
        data={"attempt": attempt, **({"slot": ref.slot} if ref.slot else {})},
    )
    return "claimed", row.id, config, []


def _give_back(s: Session, c: Campaign, ref: StepRef, row: IterationStep, message: str) -> list[StepJob]:
    """A step that gave its work back to its pausing campaign: pending again (the resume sends
    it), and the campaign paused once no other step of it is queued or running."""
    row.status = StepStatus.pending.value
    row.error = message
    row.claim_token = None
    row.lease_until = None
    repo.add_event(s, c.id, "step_paused", message, iteration=ref.iteration, step=ref.step.value)
    s.flush()
    if not repo.steps_of_campaign(s, c.id, [StepStatus.running.value, StepStatus.queued.value]):
        apply_decision(s, c, Decision(CampaignStatus.paused), note="paused: " + message)
    return []


def _requeue(s: Session, campaign_id: int, ref: StepRef, row: IterationStep, message: str) -> list[StepJob]:
    row.status = StepStatus.queued.value
    row.error = message
    row.claim_token = None
    row.lease_until = None
    row.queued_at = utcnow()
    repo.add_event(
        s,
        campaign_id,
        "step_retry",
        message,
        iteration=ref.iteration,
        step=ref.step.value,
        data={"attempt": row.attempts},
    )
    return [
        StepJob(
            campaign_id=campaign_id, iteration=ref.iteration, step=ref.step, attempt=row.attempts + 1, slot=ref.slot
        )
    ]


def _latency(row: IterationStep) -> float | None:
    if row.queued_at and row.started_at:
        return max((row.started_at - row.queued_at).total_seconds(), 0.0)
    return None


def policy_outcome(config: CampaignConfig, ref: StepRef) -> Outcome:
    """What a failed step means for the campaign under its policies."""
    p = config.policies
    if ref.step is StepName.ocp:
        return Outcome.iteration_failed if p.ocp_on_failure == "continue" else Outcome.failed
    if ref.step is StepName.oracle:
        return Outcome.iteration_failed if p.oracle_on_failure == "continue" else Outcome.failed
    return Outcome.failed


def drive_inline(campaign_id: int, jobs: list[StepJob], *, max_steps: int = 100_000) -> int:
    """Run step jobs in this process until none is left (no Celery): same protocol, same
    rows; used by service tests and the orchestration-overhead benchmark."""
    queue = list(jobs)
    n = 0
    while queue and n < max_steps:
        j = queue.pop(0)
        run_step(
            j.campaign_id, j.iteration, j.step.value, j.attempt, worker_name="inline", send=queue.extend, slot=j.slot
        )
        n += 1
    return n
