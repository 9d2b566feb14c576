"""What the campaign shows of its held-out validation suite: the suite's state and each model
version's generalisation error next to the in-loop metrics. The suite itself is the oracles
domain's (:mod:`alcove.oracles.validation`), the evaluation the surrogates domain's
(:mod:`alcove.surrogates.validation`)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove.campaigns.schemas import MetricsRead, ValidationSuiteRead
from alcove.models import Campaign, MotionStatus, ValidationMetrics, ValidationMotion, ValidationSuite


def suite_spec(settings: Any) -> Any:
    """The suite a campaign's run settings ask for (``validation_motions``, ``validation_seed``)."""
    from alcove.science.validation_suite import SuiteSpec

    return SuiteSpec(motions=settings.validation_motions, seed=settings.validation_seed)


def validation_by_model(s: Session, model_version_ids: Sequence[int]) -> dict[int, ValidationMetrics]:
    ids = [i for i in model_version_ids if i is not None]
    if not ids:
        return {}
    rows = s.scalars(sa.select(ValidationMetrics).where(ValidationMetrics.model_version_id.in_(ids)))
    return {r.model_version_id: r for r in rows}


def with_validation(s: Session, rows: list[MetricsRead]) -> list[MetricsRead]:
    """The metrics rows with their model version's generalisation error (where evaluated)."""
    found = validation_by_model(s, [r.model_version_id for r in rows if r.model_version_id is not None])
    out = []
    for r in rows:
        v = found.get(r.model_version_id) if r.model_version_id is not None else None
        if v is None:
            out.append(r)
            continue
        out.append(
            r.model_copy(
                update={
                    "validation_force_rmse": v.force_rmse,
                    "validation_moment_rmse": v.moment_rmse,
                    "validation_components": dict(v.components),
                }
            )
        )
    return out


def suite_read(s: Session, campaign: Campaign) -> ValidationSuiteRead | None:
    if campaign.validation_suite_id is None:
        return None
    suite = s.get(ValidationSuite, campaign.validation_suite_id)
    if suite is None:
        return None
    done = s.scalar(
        sa.select(sa.func.count()).where(
            ValidationMotion.suite_id == suite.id, ValidationMotion.status == MotionStatus.succeeded.value
        )
    )
    shared = s.scalar(sa.select(sa.func.count()).where(Campaign.validation_suite_id == suite.id))
    return ValidationSuiteRead(
        id=suite.id,
        status=suite.status,
        n_motions=suite.n_motions,
        motions_done=int(done or 0),
        replay_wall_time_s=suite.replay_wall_time_s,
        shared_by=int(shared or 0),
        error=suite.error,
    )
