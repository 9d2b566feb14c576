"""Re-enqueue steps whose worker died or whose message was lost.

* A ``running`` step whose worker is dead goes back to ``queued`` and a message for
  attempt n+1 is sent: its worker stopped beating for ``ALCOVE_WORKER_DEAD_SECONDS``
  (10 s; workers beat every 2 s from their main process, however long a step computes, so
  a slow worker keeps its step), or its lease expired (``ALCOVE_JOB_LEASE_SECONDS``, 120 s:
  the step's own process died while its worker's main process lives on, or a worker that
  never beat); when it has used all its attempts the step fails and
  the campaign's policy applies. The old job, should it still be alive, loses its claim
  token and its results are discarded.
* A ``queued`` step whose message is older than ``stale_queued_s`` (lost with a broker
  restart, or taken from the filesystem broker by a worker that then died) is sent again
  with the same attempt number: if the first message still exists, whichever arrives
  second is a no-op.
* A campaign waiting for a place of its owner's running-campaigns limit is sent when one has
  come free (:mod:`alcove.campaigns.machine.admission`).

Runs at worker start, periodically in every worker (:class:`ReconcilerThread`) and at API
start (call :func:`reconcile_and_enqueue`).
"""

from __future__ import annotations

import logging
import threading
from datetime import timedelta

from sqlalchemy.orm import Session

from alcove.campaigns import repository as repo
from alcove.campaigns.config import current_config
from alcove.campaigns.machine import admission
from alcove.campaigns.machine.apply import complete_step
from alcove.campaigns.machine.state_machine import Outcome, StepRef
from alcove.jobs.campaign import StepJob
from alcove.models import Campaign, StepName, StepStatus, utcnow
from alcove.settings import get_settings

log = logging.getLogger(__name__)


def reconcile(s: Session, *, stale_queued_s: float, dead_worker_s: float | None = None) -> list[StepJob]:
    """Fix the rows (in the caller's transaction) and return the jobs to send after commit.
    ``dead_worker_s``: a worker whose heartbeat is older than this is dead and its running
    steps are taken back at once (None: only when their lease expires)."""
    now = utcnow()
    jobs: list[StepJob] = []
    dead_before = None if dead_worker_s is None else now - timedelta(seconds=dead_worker_s)
    # a worker's first beat follows its start by less than a heartbeat interval
    margin = float(get_settings().worker_heartbeat_seconds)
    for k, row, why in repo.abandoned_running_steps(s, now, dead_before, restart_margin_s=margin):
        c = repo.get_campaign(s, row.campaign_id, lock=True)
        ref = StepRef(k, StepName(row.step), row.slot)
        if c.is_terminal:
            row.status, row.finished_at, row.claim_token = StepStatus.cancelled.value, now, None
            continue
        message = (
            f"worker {row.worker_name} stopped beating (dead) during attempt {row.attempts}"
            if why == "dead"
            else f"lease expired on worker {row.worker_name} (attempt {row.attempts})"
        )
        if row.attempts >= row.max_attempts:
            row.claim_token = None
            outcome = Outcome.cancelled if c.cancel_requested else _policy(s, c, ref)
            jobs += complete_step(s, c, ref, row, outcome, error=message)
            continue
        row.status, row.claim_token, row.lease_until, row.queued_at, row.error = (
            StepStatus.queued.value,
            None,
            None,
            now,
            message,
        )
        repo.add_event(
            s,
            c.id,
            "step_requeued",
            message,
            iteration=k,
            step=row.step,
            data={"attempt": row.attempts, "why": why, "slot": row.slot},
        )
        jobs.append(StepJob(campaign_id=c.id, iteration=k, step=ref.step, attempt=row.attempts + 1, slot=row.slot))
    for k, row in repo.stale_queued_steps(s, now - timedelta(seconds=stale_queued_s)):
        c = repo.get_campaign(s, row.campaign_id)
        if c.is_terminal:
            row.status, row.finished_at = StepStatus.cancelled.value, now
            continue
        row.queued_at = now
        repo.add_event(
            s,
            c.id,
            "step_resent",
            "message not picked up; sent again",
            iteration=k,
            step=row.step,
            data={"attempt": row.attempts + 1},
        )
        jobs.append(
            StepJob(campaign_id=c.id, iteration=k, step=StepName(row.step), attempt=row.attempts + 1, slot=row.slot)
        )
    # campaigns waiting for a place of their owner's running-campaigns limit that has come free
    jobs += admission.admit_all(s)
    return jobs


def _policy(s: Session, c: Campaign, ref: StepRef) -> Outcome:
    from alcove.campaigns.run.protocol import policy_outcome

    return policy_outcome(current_config(s, c), ref)


def reconcile_and_enqueue(stale_queued_s: float | None = None) -> list[StepJob]:
    """One reconciliation pass in its own transaction (the jobs it makes are recorded in the
    outbox in the same transaction), then send them."""
    from alcove.db import run_transaction
    from alcove.jobs.campaign import send_committed, stage
    from alcove.settings import get_settings

    settings = get_settings()
    stale = stale_queued_s if stale_queued_s is not None else float(settings.job_lease_seconds)

    def work(s: Session) -> tuple[list[StepJob], list[int]]:
        jobs = reconcile(s, stale_queued_s=stale, dead_worker_s=settings.worker_dead_seconds)
        return jobs, stage(s, jobs)

    jobs, staged = run_transaction(work)
    if jobs:
        log.warning(
            "reconciler re-enqueued %d step(s): %s",
            len(jobs),
            ", ".join(f"c{j.campaign_id}:{j.iteration}/{j.step.value}#{j.attempt}" for j in jobs),
        )
        send_committed(staged)
    _reconcile_validation(stale)
    return jobs


def _reconcile_validation(stale_s: float) -> None:
    """Validation-suite motions whose message was lost or whose worker died: send them again."""
    from datetime import timedelta

    from alcove.db import run_transaction
    from alcove.oracles.validation import reconcile_motions

    ids = run_transaction(lambda s: reconcile_motions(s, timedelta(seconds=stale_s)))
    if ids:
        log.warning("reconciler re-sent %d validation motion(s): %s", len(ids), ids)


def release_lost_step(
    campaign_id: int, iteration: int, step: str, attempt: int, worker_name: str, slot: int = 0
) -> bool:
    """The pool process running this attempt died (its worker's main process saw it exit
    and lives on, still beating): expire the step's lease so that the next reconciler pass
    (seconds) gives it to another job. Only while the step is still this attempt's, on this
    worker. Returns whether it did."""
    from alcove.db import run_transaction

    def work(s: Session) -> bool:
        row = repo.get_step(s, campaign_id, iteration, step, slot)
        if row is None or row.status != StepStatus.running.value:
            return False
        if row.attempts != attempt or row.worker_name != worker_name:
            return False
        row.lease_until = utcnow()
        return True

    released = run_transaction(work)
    if released:
        log.warning("the process of step c%d:%d/%s#%d died on %s", campaign_id, iteration, step, attempt, worker_name)
    return released


class ReconcilerThread(threading.Thread):
    """Periodic :func:`reconcile_and_enqueue` (every ``interval`` s) in a worker's main process."""

    def __init__(self, interval: float) -> None:
        super().__init__(name="alcove-reconciler", daemon=True)
        self.interval = interval
        self._stop_event = threading.Event()

    def run(self) -> None:
        while True:
            try:
                reconcile_and_enqueue()
            except Exception:
                log.exception("reconciler pass failed")
            if self._stop_event.wait(self.interval):
                return

    def stop(self) -> None:
        self._stop_event.set()
