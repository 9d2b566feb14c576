"""Queries of model versions. Never commits."""

from __future__ import annotations

import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove.lineage import resolve_iteration
from alcove.models import ModelVersion


def get_model_version(s: Session, model_version_id: int) -> ModelVersion | None:
    return s.get(ModelVersion, model_version_id)


def own_versions(s: Session, campaign_id: int) -> list[ModelVersion]:
    return list(
        s.scalars(sa.select(ModelVersion).where(ModelVersion.campaign_id == campaign_id).order_by(ModelVersion.version))
    )


def version_of(s: Session, campaign_id: int, version: int) -> ModelVersion | None:
    """Model version ``version`` of a campaign (a fork's early versions are its source's)."""
    cid, v = resolve_iteration(s, campaign_id, version)
    return s.scalar(sa.select(ModelVersion).where(ModelVersion.campaign_id == cid, ModelVersion.version == v))
