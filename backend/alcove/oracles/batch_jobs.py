"""The batch jobs of an oracle step, kept in ``oracle_batch_jobs``.

:class:`StepBatchJobs` is the book (:class:`~alcove.science.oracles.command.batch.BatchJobBook`)
a command oracle with a batch launcher keeps its job in: every state change is written at once
in a short transaction of its own, so that a worker started again after a crash finds the job
(``earlier``) and attaches to it. The job counts as collected only in the transaction that
stores the step's result (:meth:`StepBatchJobs.mark_collected`): a worker that dies between
the job's end and that commit leaves it ``completed``, and the next attempt collects it.
"""

from __future__ import annotations

from collections.abc import Sequence
from datetime import UTC, datetime
from typing import Any

import sqlalchemy as sa
from sqlalchemy.orm import Session
from sqlalchemy.orm.attributes import set_committed_value

from alcove.db import run_transaction
from alcove.models import IterationStep, utcnow
from alcove.models.base import BatchJobState
from alcove.models.data import OracleBatchJob
from alcove.science.oracles.command.batch import BatchJob

#: states in which a job may still give the call's result: a later attempt attaches to it
ATTACHABLE = (BatchJobState.queued.value, BatchJobState.running.value, BatchJobState.completed.value)


def _when(seconds: float | None) -> datetime | None:
    return None if seconds is None else datetime.fromtimestamp(seconds, UTC)


def _seconds(when: datetime | None) -> float | None:
    return None if when is None else when.timestamp()


def as_batch_job(row: OracleBatchJob) -> BatchJob:
    return BatchJob(
        scheduler=row.scheduler,
        job_id=row.job_id,
        workdir=row.workdir,
        state=row.state,
        reason=row.reason,
        submitted_at=_seconds(row.submitted_at),
        started_at=_seconds(row.started_at),
        ended_at=_seconds(row.ended_at),
        exit_code=row.exit_code,
    )


class StepBatchJobs:
    """The book of one attempt of an oracle step (``step_id``)."""

    def __init__(self, step_id: int, campaign_id: int, attempt: int, worker: str) -> None:
        self.step_id, self.campaign_id, self.attempt, self.worker = step_id, campaign_id, attempt, worker
        self.row_id: int | None = None

    def earlier(self) -> BatchJob | None:
        def find(s: Session) -> BatchJob | None:
            row = s.scalars(
                sa.select(OracleBatchJob)
                .where(OracleBatchJob.step_id == self.step_id, OracleBatchJob.state.in_(ATTACHABLE))
                .order_by(OracleBatchJob.id.desc())
                .limit(1)
            ).first()
            if row is None:
                return None
            row.worker_name = self.worker
            self.row_id = row.id
            return as_batch_job(row)

        return run_transaction(find)

    def record(self, job: BatchJob) -> None:
        values: dict[str, Any] = {
            "scheduler": job.scheduler,
            "job_id": job.job_id,
            "workdir": job.workdir,
            "state": job.state,
            "reason": job.reason,
            "exit_code": job.exit_code,
            "submitted_at": _when(job.submitted_at),
            "started_at": _when(job.started_at),
            "ended_at": _when(job.ended_at),
            "worker_name": self.worker,
        }

        def write(s: Session) -> int:
            if self.row_id is None:
                row = OracleBatchJob(step_id=self.step_id, campaign_id=self.campaign_id, attempt=self.attempt, **values)
                s.add(row)
                s.flush()
                return row.id
            s.execute(sa.update(OracleBatchJob).where(OracleBatchJob.id == self.row_id).values(**values))
            return self.row_id

        self.row_id = run_transaction(write)

    def mark_collected(self, s: Session) -> None:
        """In the transaction that stores the call's result: its job has given it."""
        if self.row_id is not None:
            s.execute(
                sa.update(OracleBatchJob)
                .where(OracleBatchJob.id == self.row_id, OracleBatchJob.state == BatchJobState.completed.value)
                .values(state=BatchJobState.collected.value, collected_at=utcnow())
            )


def with_batch_jobs(s: Session, steps: Sequence[IterationStep]) -> None:
    """Load the batch jobs of ``steps`` (their oracle calls' scheduler jobs) in one query."""
    by_step: dict[int, list[OracleBatchJob]] = {st.id: [] for st in steps}
    if by_step:
        rows = s.scalars(
            sa.select(OracleBatchJob).where(OracleBatchJob.step_id.in_(list(by_step))).order_by(OracleBatchJob.id)
        )
        for job in rows:
            by_step[job.step_id].append(job)
    for st in steps:
        set_committed_value(st, "batch_jobs", by_step[st.id])


def jobs_of_campaign(s: Session, campaign_id: int) -> list[OracleBatchJob]:
    """Every batch job of a campaign's oracle calls, oldest first."""
    return list(
        s.scalars(
            sa.select(OracleBatchJob).where(OracleBatchJob.campaign_id == campaign_id).order_by(OracleBatchJob.id)
        )
    )


__all__ = ["ATTACHABLE", "StepBatchJobs", "as_batch_job", "jobs_of_campaign", "with_batch_jobs"]
