"""Pydantic schemas of pool versions."""

from __future__ import annotations

from datetime import datetime

from pydantic import BaseModel, ConfigDict


class _Read(BaseModel):
    model_config = ConfigDict(from_attributes=True)


class PoolVersionRead(_Read):
    id: int
    campaign_id: int
    version: int
    parent_id: int | None
    n_datasets: int
    n_samples: int
    content_hash: str
    created_at: datetime


__all__ = ["PoolVersionRead"]
