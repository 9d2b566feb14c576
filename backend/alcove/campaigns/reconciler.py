"""Re-enqueue steps whose worker died or whose message was lost.

* A ``running`` step whose lease expired (the worker was killed: SIGKILL, OOM, machine
  lost; its lease keeper stopped extending ``lease_until``) goes back to ``queued`` and a
  message for attempt n+1 is sent; when it has used all its attempts the step fails and
  the campaign's policy applies. The old job, should it still be alive, loses its claim
  token and its results are discarded.
* A ``queued`` step whose message is older than ``stale_queued_s`` (lost with a broker
  restart, or taken from the filesystem broker by a worker that then died) is sent again
  with the same attempt number: if the first message still exists, whichever arrives
  second is a no-op.

Runs at worker start, periodically in every worker (:class:`ReconcilerThread`) and at API
start (call :func:`reconcile_and_enqueue`).
"""

from __future__ import annotations

import logging
import threading
from datetime import timedelta

from sqlalchemy.orm import Session

from alcove.campaigns import repository as repo
from alcove.campaigns import transitions
from alcove.campaigns.schemas import StepJob
from alcove.campaigns.state_machine import Outcome, StepRef
from alcove.models import Campaign, StepName, StepStatus, utcnow

log = logging.getLogger(__name__)


def reconcile(s: Session, *, stale_queued_s: float) -> list[StepJob]:
    """Fix the rows (in the caller's transaction) and return the jobs to send after commit."""
    now = utcnow()
    jobs: list[StepJob] = []
    for k, row in repo.expired_running_steps(s, now):
        c = repo.get_campaign(s, row.campaign_id, lock=True)
        ref = StepRef(k, StepName(row.step))
        if c.is_terminal:
            row.status, row.finished_at, row.claim_token = StepStatus.cancelled.value, now, None
            continue
        message = f"lease expired on worker {row.worker_name} (attempt {row.attempts})"
        if row.attempts >= row.max_attempts:
            row.claim_token = None
            outcome = Outcome.cancelled if c.cancel_requested else _policy(s, c, ref)
            jobs += transitions.complete_step(s, c, ref, row, outcome, error=message)
            continue
        row.status, row.claim_token, row.lease_until, row.queued_at, row.error = (
            StepStatus.queued.value,
            None,
            None,
            now,
            message,
        )
        repo.add_event(s, c.id, "step_requeued", message, iteration=k, step=row.step, data={"attempt": row.attempts})
        jobs.append(StepJob(campaign_id=c.id, iteration=k, step=ref.step, attempt=row.attempts + 1))
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
        jobs.append(StepJob(campaign_id=c.id, iteration=k, step=StepName(row.step), attempt=row.attempts + 1))
    return jobs


def _policy(s: Session, c: Campaign, ref: StepRef) -> Outcome:
    from alcove.campaigns.protocol import policy_outcome

    return policy_outcome(transitions.current_config(s, c), ref)


def reconcile_and_enqueue(stale_queued_s: float | None = None) -> list[StepJob]:
    """One reconciliation pass in its own transaction, then send the jobs."""
    from alcove.db import transaction
    from alcove.jobs.campaign import enqueue
    from alcove.settings import get_settings

    stale = stale_queued_s if stale_queued_s is not None else float(get_settings().job_lease_seconds)
    jobs = transaction(lambda s: reconcile(s, stale_queued_s=stale))
    if jobs:
        log.warning(
            "reconciler re-enqueued %d step(s): %s",
            len(jobs),
            ", ".join(f"c{j.campaign_id}:{j.iteration}/{j.step.value}#{j.attempt}" for j in jobs),
        )
        enqueue(jobs)
    _reconcile_validation(stale)
    return jobs


def _reconcile_validation(stale_s: float) -> None:
    """Validation-suite motions whose message was lost or whose worker died: send them again."""
    from datetime import timedelta

    from alcove.db import transaction
    from alcove.oracles.validation import reconcile_motions, send_motions

    ids = transaction(lambda s: reconcile_motions(s, timedelta(seconds=stale_s)))
    if ids:
        log.warning("reconciler re-sent %d validation motion(s): %s", len(ids), ids)
        send_motions(ids)


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
