"""Celery job wrappers. Thin: parse the message, call the domain code in ``alcove``.

Names follow ``alcove.<queue>.<what>`` (see :func:`alcove.jobs.queue_for`), so the API
can send a job by name without importing this module (or torch, or casadi).
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

from alcove.jobs import SMOKE_JOB
from alcove_worker.celery_app import app

if TYPE_CHECKING:
    from alcove.campaigns.run.reconciler import ReconcilerThread

log = logging.getLogger(__name__)


@app.task(name=SMOKE_JOB, bind=True)
def smoke(self: Any, token: str, sent_at: float | None = None) -> int:
    """Write one ``smoke_checks`` row in one transaction (idempotent per token)."""
    from alcove.jobs.smoke import run_smoke

    return run_smoke(token, worker_name=self.request.hostname or "unknown", sent_at=sent_at)


# ----------------------------------------------------------------------------- campaign steps
# One job per step type; the message is (campaign_id, iteration, step, attempt[, slot]). The job
# claims its step row first, so a duplicate delivery is a no-op (see alcove.campaigns.run.protocol).

from celery import signals  # noqa: E402

from alcove.jobs.campaign import RECONCILE_JOB, STEP_JOBS  # noqa: E402


def _run_step(job: Any, campaign_id: int, iteration: int, step: str, attempt: int, slot: int) -> dict[str, Any]:
    from alcove.campaigns.run.protocol import run_step

    return run_step(
        int(campaign_id),
        int(iteration),
        str(step),
        int(attempt),
        worker_name=job.request.hostname or "unknown",
        slot=int(slot),
    )


@app.task(name=STEP_JOBS["preliminary"], bind=True, acks_late=True)
def preliminary_step(
    self: Any, campaign_id: int, iteration: int, step: str, attempt: int, slot: int = 0
) -> dict[str, Any]:
    return _run_step(self, campaign_id, iteration, step, attempt, slot)


@app.task(name=STEP_JOBS["train"], bind=True, acks_late=True)
def train_step(self: Any, campaign_id: int, iteration: int, step: str, attempt: int, slot: int = 0) -> dict[str, Any]:
    return _run_step(self, campaign_id, iteration, step, attempt, slot)


@app.task(name=STEP_JOBS["ocp"], bind=True, acks_late=True)
def ocp_step(self: Any, campaign_id: int, iteration: int, step: str, attempt: int, slot: int = 0) -> dict[str, Any]:
    return _run_step(self, campaign_id, iteration, step, attempt, slot)


@app.task(name=STEP_JOBS["oracle"], bind=True, acks_late=True)
def oracle_step(self: Any, campaign_id: int, iteration: int, step: str, attempt: int, slot: int = 0) -> dict[str, Any]:
    return _run_step(self, campaign_id, iteration, step, attempt, slot)


@app.task(name=STEP_JOBS["evaluate"], bind=True, acks_late=True)
def evaluate_step(
    self: Any, campaign_id: int, iteration: int, step: str, attempt: int, slot: int = 0
) -> dict[str, Any]:
    return _run_step(self, campaign_id, iteration, step, attempt, slot)


@app.task(name=STEP_JOBS["append"], bind=True, acks_late=True)
def append_step(self: Any, campaign_id: int, iteration: int, step: str, attempt: int, slot: int = 0) -> dict[str, Any]:
    return _run_step(self, campaign_id, iteration, step, attempt, slot)


# ----------------------------------------------------------------------------- validation suite
# A held-out motion replayed by the oracle (message: the motion id; the job claims its row
# first, so a duplicate is a no-op), and the evaluation of the waiting model versions once
# a suite is complete (idempotent: one row per model version).

from alcove.oracles.validation import EVALUATE_JOB, MOTION_JOB  # noqa: E402


@app.task(name=MOTION_JOB, bind=True, acks_late=True)
def validation_motion(self: Any, motion_id: int) -> str:
    from alcove.oracles.validation import run_motion

    return run_motion(int(motion_id), worker_name=self.request.hostname or "unknown")


@app.task(name=EVALUATE_JOB, bind=True, acks_late=True)
def validation_evaluate(self: Any, suite_id: int) -> int:
    """The waiting model versions' errors on the complete suite, then its best-possible line (once)."""
    from alcove.surrogates.reference_line import compute_reference_line
    from alcove.surrogates.validation import evaluate_suite

    written = evaluate_suite(int(suite_id))
    compute_reference_line(int(suite_id))
    return written


# ----------------------------------------------------------------------------- editor previews
# The message is the preview id; the job claims the row first (a duplicate is a no-op).

from alcove.previews.service import ORACLE_PREVIEW_JOB, TASK_PREVIEW_JOB  # noqa: E402


@app.task(name=TASK_PREVIEW_JOB, bind=True, acks_late=True)
def task_preview(self: Any, preview_id: int) -> str:
    """Solve a task once with the auxiliary contact (queue ocp)."""
    from alcove.previews.worker import run_preview

    return run_preview(int(preview_id), worker_name=self.request.hostname or "unknown")


@app.task(name=ORACLE_PREVIEW_JOB, bind=True, acks_late=True)
def oracle_preview(self: Any, preview_id: int) -> str:
    """Replay the sample trajectory through an oracle (queue oracle)."""
    from alcove.previews.worker import run_preview

    return run_preview(int(preview_id), worker_name=self.request.hostname or "unknown")


# ----------------------------------------------------------------------------- artifact builds
# The message is the build id; the job claims the build with a free build slot first (a
# duplicate is a no-op). With every slot taken (ALCOVE_ARTIFACT_BUILDS) it runs again shortly.

from alcove.surrogates.artifact_builds import ARTIFACT_BUILD_JOB  # noqa: E402


@app.task(name=ARTIFACT_BUILD_JOB, bind=True, acks_late=True, max_retries=None)
def artifact_build(self: Any, build_id: int) -> str:
    """Build the model artifact zips a download waits for (queue artifacts)."""
    from alcove.surrogates.artifact_build_worker import BUSY, BUSY_RETRY_S, run_build

    outcome = run_build(int(build_id), worker_name=self.request.hostname or "unknown")
    if outcome == BUSY:
        raise self.retry(countdown=BUSY_RETRY_S)
    return outcome


@app.task(name=RECONCILE_JOB, bind=True)
def reconcile(self: Any) -> int:
    """One reconciliation pass (also runs periodically inside every worker)."""
    from alcove.campaigns.run.reconciler import reconcile_and_enqueue

    return len(reconcile_and_enqueue())


_reconciler: ReconcilerThread | None = None


@signals.worker_ready.connect
def _start_reconciler(sender: Any = None, **_: Any) -> None:
    """Reconcile at worker start (steps of a worker that died), then every
    ``ALCOVE_RECONCILE_SECONDS`` (2 s: a dead worker's step runs again within seconds)."""
    global _reconciler
    from alcove.campaigns.run.reconciler import ReconcilerThread
    from alcove.settings import get_settings

    _reconciler = ReconcilerThread(interval=get_settings().reconcile_seconds)
    _reconciler.start()


@signals.task_failure.connect
def _step_process_lost(sender: Any = None, exception: BaseException | None = None, args: Any = None, **_: Any) -> None:
    """In the worker's main process: the pool process running a step died (SIGKILL, out of
    memory). The main process still beats, so the heartbeat does not tell; this does."""
    from billiard.exceptions import WorkerLostError

    if not isinstance(exception, WorkerLostError) or sender is None or sender.name not in STEP_JOBS.values():
        return
    from alcove.campaigns.run.reconciler import release_lost_step

    try:
        campaign_id, iteration, step, attempt, *slot = args
        release_lost_step(
            int(campaign_id), int(iteration), str(step), int(attempt), sender.request.hostname or "", *map(int, slot)
        )
    except Exception:  # the lease still expires
        log.exception("could not release the step of a lost pool process")


@signals.task_failure.connect
def _artifact_build_process_lost(
    sender: Any = None, exception: BaseException | None = None, args: Any = None, **_: Any
) -> None:
    """In the worker's main process: the pool process running an artifact build died. The build
    fails with the reason and frees its slot now (else only once it is quiet for the build timeout)."""
    from billiard.exceptions import WorkerLostError

    if not isinstance(exception, WorkerLostError) or sender is None or sender.name != ARTIFACT_BUILD_JOB:
        return
    from alcove.surrogates.artifact_build_worker import release_lost_build

    try:
        release_lost_build(int(args[0]), sender.request.hostname or "")
    except Exception:  # the build's quiet time still fails it
        log.exception("could not release the artifact build of a lost pool process")


@signals.worker_shutdown.connect
def _stop_reconciler(**_: Any) -> None:
    if _reconciler is not None:
        _reconciler.stop()
