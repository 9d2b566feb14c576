"""The candidate rows of batch iterations (``iteration_candidates``): queries that take
a ``Session`` and never commit."""

from __future__ import annotations

from typing import Any

import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove.models import Iteration, IterationCandidate


def has_candidates(s: Session, campaign_id: int, index: int) -> bool:
    """Whether iteration ``index`` stores candidate rows (a batch iteration)."""
    q = (
        sa.select(sa.func.count())
        .select_from(IterationCandidate)
        .join(Iteration, Iteration.id == IterationCandidate.iteration_id)
        .where(Iteration.campaign_id == campaign_id, Iteration.index == index)
    )
    return bool(s.scalar(q))


def family_motion_indices(s: Session, campaign_id: int, before: int) -> list[int]:
    """The press family's sequence indices the campaign's iterations before ``before`` used."""
    rows = s.scalars(
        sa.select(IterationCandidate.scenario)
        .join(Iteration, Iteration.id == IterationCandidate.iteration_id)
        .where(Iteration.campaign_id == campaign_id, Iteration.index < before)
    )
    return [int(sc["motion_index"]) for sc in rows if sc is not None and "motion_index" in sc]


def candidate_of_slot(s: Session, iteration_id: int, slot: int) -> IterationCandidate | None:
    """The candidate row of ocp slot ``slot``, if stored."""
    return s.scalar(
        sa.select(IterationCandidate).where(
            IterationCandidate.iteration_id == iteration_id, IterationCandidate.slot == slot
        )
    )


def put_candidate(s: Session, iteration_id: int, slot: int, **values: Any) -> IterationCandidate:
    """The candidate row of ocp slot ``slot`` (created, or updated by a later attempt)."""
    row = candidate_of_slot(s, iteration_id, slot)
    if row is None:
        row = IterationCandidate(iteration_id=iteration_id, slot=slot)
        s.add(row)
    for k, v in values.items():
        setattr(row, k, v)
    s.flush()
    return row


def picked_candidate(s: Session, iteration_id: int, pick: int) -> IterationCandidate | None:
    return s.scalar(
        sa.select(IterationCandidate).where(
            IterationCandidate.iteration_id == iteration_id, IterationCandidate.pick == pick
        )
    )


def candidates(s: Session, iteration_id: int) -> list[IterationCandidate]:
    q = sa.select(IterationCandidate).where(IterationCandidate.iteration_id == iteration_id)
    return list(s.scalars(q.order_by(IterationCandidate.slot)))


def set_candidate_rmse(
    s: Session,
    iteration_id: int,
    dataset_id: int,
    force_rmse: float | None,
    moment_rmse: float | None,
    curves_sha256: str | None = None,
) -> None:
    for row in candidates(s, iteration_id):
        if row.dataset_id == dataset_id:
            row.force_rmse, row.moment_rmse = force_rmse, moment_rmse
            row.curves_sha256 = curves_sha256
