"""Queries of datasets and pool versions. Never commits."""

from __future__ import annotations

from typing import Any

import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove.errors import NotFound
from alcove.lineage import resolve_iteration
from alcove.models import Dataset, OracleRun, PoolVersion, PoolVersionMember
from alcove.models.data import HeadrestPlacement


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
        raise NotFound("dataset", missing[0])
    return [rows[i] for i in ids]


def member_summaries(s: Session, pool_version_id: int) -> list[tuple[int, str, int]]:
    """(dataset id, content key, n_samples) of the members in order: no ORM objects (cheap
    for pools of hundreds of datasets). The content key is :func:`content_key`."""
    q = (
        sa.select(Dataset.id, Dataset.content_sha256, Dataset.n_samples, Dataset.meta)
        .join(PoolVersionMember, PoolVersionMember.dataset_id == Dataset.id)
        .where(PoolVersionMember.pool_version_id == pool_version_id)
        .order_by(PoolVersionMember.position)
    )
    return [(int(i), content_key(str(h), meta), int(n)) for i, h, n, meta in s.execute(q)]


def content_key(sha256: str, meta: dict[str, Any] | None) -> str:
    """What a dataset contributes to its pool version's content hash: its arrays' hash and, for a
    scenario's moved headrest, the offset and the recorded tilt (the features are computed against
    them, so equal arrays with different headrests are different training data). Datasets without
    an offset or tilt keep the bare array hash, so the hashes of pools stored before offsets
    existed do not change."""
    headrest = HeadrestPlacement.from_meta(meta)
    offset, tilt = headrest.offset, headrest.tilt
    key = sha256 if offset is None or offset == 0.0 else f"{sha256}@headrest_offset={offset!r}"
    # a recorded tilt (a scenario that drew model.tilt) always counts: there is no tilt that means "as before"
    return key if tilt is None else f"{key}@headrest_tilt={tilt!r}"


def added_members(s: Session, pool_version_id: int) -> list[Dataset]:
    """The datasets a version added to its parent, in order."""
    q = (
        sa.select(Dataset)
        .join(PoolVersionMember, PoolVersionMember.dataset_id == Dataset.id)
        .where(PoolVersionMember.pool_version_id == pool_version_id, PoolVersionMember.added_in_this_version.is_(True))
        .order_by(PoolVersionMember.position)
    )
    return list(s.scalars(q))


def uploaded_datasets(s: Session, owner_id: int, limit: int, offset: int) -> list[Dataset]:
    """The owner's uploaded data sets, newest first."""
    q = (
        sa.select(Dataset)
        .where(Dataset.owner_id == owner_id, Dataset.origin == "upload")
        .order_by(Dataset.id.desc())
        .limit(limit)
        .offset(offset)
    )
    return list(s.scalars(q))


def version_of(s: Session, campaign_id: int, version: int) -> PoolVersion | None:
    """Pool version ``version`` of a campaign (a fork's early versions are its source's)."""
    cid, v = resolve_iteration(s, campaign_id, version)
    return s.scalar(sa.select(PoolVersion).where(PoolVersion.campaign_id == cid, PoolVersion.version == v))


def own_versions(s: Session, campaign_id: int) -> list[PoolVersion]:
    """The pool versions a campaign made itself, in order."""
    q = sa.select(PoolVersion).where(PoolVersion.campaign_id == campaign_id).order_by(PoolVersion.version)
    return list(s.scalars(q))


def oracle_dataset(s: Session, iteration_id: int) -> Dataset | None:
    """The dataset an iteration's oracle run produced (None if it has none)."""
    return s.scalar(sa.select(Dataset).where(Dataset.iteration_id == iteration_id, Dataset.origin == "oracle"))


def oracle_datasets(s: Session, iteration_id: int) -> list[Dataset]:
    """The datasets an iteration's oracle runs produced, in the order of their oracle slots
    (one for the paper's loop, one per replayed pick for a batch)."""
    q = (
        sa.select(Dataset)
        .join(OracleRun, OracleRun.id == Dataset.oracle_run_id)
        .where(Dataset.iteration_id == iteration_id, Dataset.origin == "oracle")
        .order_by(OracleRun.slot, Dataset.id)
    )
    return list(s.scalars(q))


def owned_dataset_ids(s: Session, owner_id: int, ids: list[int]) -> set[int]:
    """Which of ``ids`` are datasets ``owner_id`` uploaded."""
    return set(s.scalars(sa.select(Dataset.id).where(Dataset.id.in_(ids), Dataset.owner_id == owner_id)))


def add_members(s: Session, pool_version_id: int, members: list[tuple[int, bool]]) -> None:
    """The member rows of a new pool version in order (dataset id, added by this version),
    inserted with one executemany."""
    if members:
        rows = [
            {"pool_version_id": pool_version_id, "dataset_id": i, "position": k, "added_in_this_version": added}
            for k, (i, added) in enumerate(members)
        ]
        s.execute(sa.insert(PoolVersionMember), rows)


def validation_datasets(s: Session, suite_id: int) -> list[Dataset]:
    """The replayed motions of a validation suite, in motion order (never members of a pool version)."""
    from alcove.models import ValidationMotion

    return list(
        s.scalars(
            sa.select(Dataset)
            .join(ValidationMotion, ValidationMotion.dataset_id == Dataset.id)
            .where(ValidationMotion.suite_id == suite_id)
            .order_by(ValidationMotion.index)
        )
    )
