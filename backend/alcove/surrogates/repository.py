"""Queries of model versions. Never commits."""

from __future__ import annotations

import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove.models import ModelVersion


def get_model_version(s: Session, model_version_id: int) -> ModelVersion | None:
    return s.get(ModelVersion, model_version_id)


def by_campaign(s: Session, campaign_id: int) -> list[ModelVersion]:
    return list(
        s.scalars(sa.select(ModelVersion).where(ModelVersion.campaign_id == campaign_id).order_by(ModelVersion.version))
    )
