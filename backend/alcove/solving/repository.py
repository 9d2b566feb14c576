"""Queries of stored OCP solutions. Never commits."""

from __future__ import annotations

import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove.lineage import resolve_iteration
from alcove.models import Iteration, OcpSolution

#: How far back a campaign looks for a converged solution to start from.
LOOKBACK = 21


def latest_of_iteration(s: Session, iteration_id: int, slot: int = 0) -> OcpSolution | None:
    """The iteration's latest solve attempt (converged or not) of ocp slot ``slot``."""
    q = sa.select(OcpSolution).where(OcpSolution.iteration_id == iteration_id, OcpSolution.slot == slot)
    return s.scalar(q.order_by(OcpSolution.attempt.desc()).limit(1))


def previous_converged(s: Session, campaign_id: int, index: int) -> OcpSolution | None:
    """The latest converged solution of an iteration before ``index`` (of this campaign or,
    before a fork point, its source's), looking back at most :data:`LOOKBACK` iterations."""
    for j in range(index - 1, max(index - 1 - LOOKBACK, 0), -1):
        cid, jj = resolve_iteration(s, campaign_id, j)
        row = s.scalar(
            sa.select(OcpSolution)
            .join(Iteration, Iteration.id == OcpSolution.iteration_id)
            .where(Iteration.campaign_id == cid, Iteration.index == jj, OcpSolution.success.is_(True))
            .order_by(OcpSolution.slot, OcpSolution.attempt.desc())  # a batch: its first converged slot
            .limit(1)
        )
        if row is not None:
            return row
    return None
