"""Campaign step jobs: names, queues and sending (no import of the science code).

One job per step type, routed by name (``alcove.<queue>.<what>``): ``train`` ->
``train``, ``ocp`` -> ``ocp``, ``oracle`` -> ``oracle``, ``preliminary``/``evaluate``/
``append``/``reconcile`` -> ``default``. A message carries only the campaign id, the
iteration k, the step name and the attempt number; the database holds everything else.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

from alcove.jobs import queue_for, send_job

if TYPE_CHECKING:
    from celery import Celery

log = logging.getLogger(__name__)

STEP_JOBS: dict[str, str] = {
    "preliminary": "alcove.default.preliminary",
    "train": "alcove.train.step",
    "ocp": "alcove.ocp.step",
    "oracle": "alcove.oracle.step",
    "evaluate": "alcove.default.evaluate",
    "append": "alcove.default.append",
}
RECONCILE_JOB = "alcove.default.reconcile"


def step_queue(step: str) -> str:
    return queue_for(STEP_JOBS[step])


def step_message_id(campaign_id: int, iteration: int, step: str, attempt: int) -> str:
    """Deterministic message id: a re-send of the same attempt is recognisable in logs."""
    return f"c{campaign_id}-k{iteration}-{step}-a{attempt}"


def enqueue(jobs: Iterable[Any], app: Celery | None = None) -> list[str]:
    """Send step jobs (objects with campaign_id, iteration, step, attempt). Call after commit."""
    ids = []
    for j in jobs:
        step = getattr(j.step, "value", j.step)
        ids.append(
            send_job(
                STEP_JOBS[step],
                j.campaign_id,
                j.iteration,
                step,
                j.attempt,
                task_id=f"{step_message_id(j.campaign_id, j.iteration, step, j.attempt)}-{_nonce()}",
                app=app,
            )
        )
    return ids


def send_committed(jobs: Iterable[Any]) -> None:
    """Send the jobs a committed change made necessary. A failed send loses nothing: the
    steps are queued in the database and the reconciler re-sends queued steps nobody claimed."""
    jobs = list(jobs)
    if not jobs:
        return
    try:
        enqueue(jobs)
    except Exception:
        log.exception("sending %d job(s) failed; the reconciler will re-send them", len(jobs))


def _nonce() -> str:
    import uuid

    return uuid.uuid4().hex[:8]
