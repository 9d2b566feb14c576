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

from pydantic import BaseModel, ConfigDict

from alcove.jobs import queue_for, send_job
from alcove.models import StepName

if TYPE_CHECKING:
    from celery import Celery
    from sqlalchemy.orm import Session

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


class StepJob(BaseModel):
    """A step message to send after commit: run ``step`` of ``iteration`` (attempt n, slot j)."""

    model_config = ConfigDict(frozen=True)

    campaign_id: int
    iteration: int
    step: StepName
    attempt: int
    slot: int = 0


def step_queue(step: str) -> str:
    return queue_for(STEP_JOBS[step])


def step_message_id(campaign_id: int, iteration: int, step: str, attempt: int, slot: int = 0) -> str:
    """Deterministic message id: a re-send of the same attempt is recognisable in logs."""
    return f"c{campaign_id}-k{iteration}-{step}" + (f"-s{slot}" if slot else "") + f"-a{attempt}"


def _args(j: StepJob) -> tuple[Any, ...]:
    """The message: (campaign id, iteration, step, attempt[, slot]) (slot only when not 0)."""
    return (j.campaign_id, j.iteration, j.step.value, j.attempt, *((j.slot,) if j.slot else ()))


def enqueue(jobs: Iterable[StepJob], app: Celery | None = None) -> list[str]:
    """Send step jobs directly, without the outbox (tests: an extra or duplicate message). The
    application records its jobs with :func:`stage` and sends them with :func:`send_committed`."""
    ids = []
    for j in jobs:
        step = j.step.value
        ids.append(
            send_job(
                STEP_JOBS[step],
                *_args(j),
                task_id=f"{step_message_id(*_args(j))}-{_nonce()}",
                app=app,
            )
        )
    return ids


def stage(session: Session, jobs: Iterable[StepJob]) -> list[int]:
    """Record step jobs in the outbox, in the caller's transaction (the one that made them
    necessary); returns the outbox ids for :func:`send_committed` after the commit."""
    from alcove.jobs import outbox

    ids = []
    for j in jobs:
        step = j.step.value
        key = step_message_id(*_args(j))
        row = outbox.record(
            session,
            STEP_JOBS[step],
            _args(j),
            subject=f"campaign/{j.campaign_id}/k{j.iteration}/{step}" + (f"/{j.slot}" if j.slot else ""),
            message_id=f"{key}-{_nonce()}",
        )
        ids.append(row.id)
    return ids


def send_committed(staged: list[int]) -> None:
    """Send the jobs :func:`stage` recorded, after the commit. A failed send loses nothing:
    the outbox relay sends them when the broker answers."""
    from alcove.jobs import outbox

    outbox.send_now(staged)


def _nonce() -> str:
    import uuid

    return uuid.uuid4().hex[:8]
