"""Queries of datasets and pool versions. Never commits."""

from __future__ import annotations

import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove.models import Dataset, PoolVersion, PoolVersionMember


def get_pool_version(s: Session, pool_version_id: int) -> PoolVersion | None:
    return s.get(PoolVersion, pool_version_id)


def members(s: Session, pool_version_id: int) -> list[tuple[PoolVersionMember, Dataset]]:
    q = (
        sa.select(PoolVersionMember, Dataset)
        .join(Dataset, Dataset.id == PoolVersionMember.dataset_id)
        .where(PoolVersionMember.pool_version_id == pool_version_id)
        .order_by(PoolVersionMember.position)
    )
    return [(m, d) for m, d in s.execute(q)]


def datasets(s: Session, ids: list[int]) -> list[Dataset]:
    rows = {d.id: d for d in s.scalars(sa.select(Dataset).where(Dataset.id.in_(ids)))}
    missing = [i for i in ids if i not in rows]
    if missing:
        from alcove.campaigns.repository import NotFound

        raise NotFound("dataset_ids", f"no dataset {missing[0]}")
    return [rows[i] for i in ids]
