"""The campaign API's read queries: the list page (one query for the page, its ETA inputs in
a second), the lean revision reads behind the ETag caches, the compact iteration list.
Never commits."""

from __future__ import annotations

from typing import Any, Literal

import sqlalchemy as sa
from sqlalchemy.orm import Session, aliased

from alcove.models import (
    Campaign,
    CampaignEvent,
    CampaignStatus,
    Iteration,
    IterationMetrics,
    IterationStatus,
    IterationStep,
    ModelVersion,
    OcpSolution,
    OracleDefinition,
    OracleVersion,
    Share,
    SharePermission,
    TaskDefinition,
    TaskVersion,
    User,
    ValidationMetrics,
    ValidationMotion,
    ValidationSuite,
)
from alcove.users.access import visible_clause


def summaries(
    session: Session,
    user: User,
    *,
    status: CampaignStatus | None,
    owner: Literal["any", "me", "shared"],
    task_id: int | None,
    limit: int,
    offset: int,
) -> list[Any]:
    """(campaign, owner e-mail, task version, task name, oracle version, oracle name, latest
    iteration with metrics, its force and moment RMSE) for the campaigns the user may see,
    newest first."""
    latest = (
        sa.select(IterationMetrics.campaign_id, sa.func.max(IterationMetrics.iteration_index).label("k"))
        .group_by(IterationMetrics.campaign_id)
        .subquery()
    )
    q = (
        sa.select(
            Campaign,
            User.email,
            TaskVersion,
            TaskDefinition.name,
            OracleVersion,
            OracleDefinition.name,
            latest.c.k,
            IterationMetrics.force_rmse,
            IterationMetrics.moment_rmse,
        )
        .join(User, User.id == Campaign.owner_id)
        .join(TaskVersion, TaskVersion.id == Campaign.task_version_id)
        .join(TaskDefinition, TaskDefinition.id == TaskVersion.definition_id)
        .join(OracleVersion, OracleVersion.id == Campaign.oracle_version_id)
        .join(OracleDefinition, OracleDefinition.id == OracleVersion.definition_id)
        .outerjoin(latest, latest.c.campaign_id == Campaign.id)
        .outerjoin(
            IterationMetrics,
            sa.and_(IterationMetrics.campaign_id == Campaign.id, IterationMetrics.iteration_index == latest.c.k),
        )
        .where(visible_clause(Campaign, user))
        .order_by(Campaign.id.desc())
        .limit(limit)
        .offset(offset)
    )
    if status is not None:
        q = q.where(Campaign.status == status.value)
    if owner == "me":
        q = q.where(Campaign.owner_id == user.id)
    elif owner == "shared":
        q = q.where(Campaign.owner_id != user.id)
    if task_id is not None:
        q = q.where(TaskVersion.definition_id == task_id)
    return list(session.execute(q).all())


def iteration_timing(session: Session, campaign_ids: list[int]) -> dict[int, tuple[int, list[float]]]:
    """For each campaign: the index of its last finished iteration and the wall times of its
    last 20 finished iterations (one query for the whole page; the same rule as the detail's ETA)."""
    if not campaign_ids:
        return {}
    finished = (IterationStatus.succeeded.value, IterationStatus.failed.value)
    ranked = (
        sa.select(
            Iteration.campaign_id,
            Iteration.index,
            Iteration.started_at,
            Iteration.finished_at,
            sa.func.row_number().over(partition_by=Iteration.campaign_id, order_by=Iteration.index.desc()).label("rn"),
        )
        .where(
            Iteration.campaign_id.in_(campaign_ids),
            Iteration.index > 0,
            Iteration.status.in_(finished),
            Iteration.started_at.is_not(None),
            Iteration.finished_at.is_not(None),
        )
        .subquery()
    )
    out: dict[int, tuple[int, list[float]]] = {}
    for cid, k, a, b, _ in session.execute(
        sa.select(ranked).where(ranked.c.rn <= 20).order_by(ranked.c.campaign_id, ranked.c.rn)
    ):
        _, times = out.setdefault(cid, (k, []))
        times.append((b - a).total_seconds())
    return out


_ITERATION_FIELDS = ("id", "index", "status", "current_step", "config_version_id", "error", "started_at", "finished_at")


def compact_iterations(session: Session, campaign_id: int, after: int | None) -> list[dict[str, Any]]:
    """The iterations' own columns (no steps), in order; only those after ``after``."""
    cols = [getattr(Iteration, k) for k in _ITERATION_FIELDS]
    q = sa.select(*cols).where(Iteration.campaign_id == campaign_id).order_by(Iteration.index)
    if after is not None:
        q = q.where(Iteration.index > after)
    return [dict(r._mapping) for r in session.execute(q)]


# ----------------------------------------------------------------------------- revisions (ETag caches)


def _visible_campaign() -> sa.ColumnElement[bool]:
    return sa.and_(
        Campaign.id == sa.bindparam("cid"),
        sa.or_(
            Campaign.owner_id == sa.bindparam("uid"),
            Campaign.id.in_(sa.select(Share.campaign_id).where(Share.user_id == sa.bindparam("uid"))),
        ),
    )


# the validation suite's results arrive after the iteration's (asynchronously): they are in the revisions
_LAST_VALIDATION = (
    sa.select(sa.func.max(ValidationMetrics.id))
    .join(ModelVersion, ModelVersion.id == ValidationMetrics.model_version_id)
    .where(ModelVersion.campaign_id == Campaign.id)
    .scalar_subquery()
)
_SUITE_PROGRESS = (
    sa.select(sa.func.count())
    .where(ValidationMotion.suite_id == Campaign.validation_suite_id, ValidationMotion.status != "queued")
    .scalar_subquery()
)
_SUITE_STATUS = sa.select(ValidationSuite.status).where(ValidationSuite.id == Campaign.validation_suite_id)

# built once: building a statement costs several times more than executing a cached one
_REVISION = sa.select(
    Campaign.updated_at,
    sa.select(sa.func.count()).where(IterationMetrics.campaign_id == Campaign.id).scalar_subquery(),
    sa.select(sa.func.max(IterationMetrics.id)).where(IterationMetrics.campaign_id == Campaign.id).scalar_subquery(),
    _LAST_VALIDATION,
).where(_visible_campaign())
#: The detail's revision, one index lookup each: the campaign row, the user's ``can_edit``,
#: the owner's email, the current iteration's steps (claims and heartbeats bump their
#: ``updated_at``), the last event (every other step or iteration transition writes one) and
#: the latest metrics row.
_DETAIL_REVISION = sa.select(
    Campaign.updated_at,
    sa.or_(
        Campaign.owner_id == sa.bindparam("uid"),
        sa.select(Share.permission)
        .where(Share.campaign_id == Campaign.id, Share.user_id == sa.bindparam("uid"))
        .scalar_subquery()
        == SharePermission.edit.value,
    ),
    sa.select(User.email).where(User.id == Campaign.owner_id).scalar_subquery(),
    sa.select(sa.func.max(IterationStep.updated_at))
    .join(Iteration, Iteration.id == IterationStep.iteration_id)
    .where(Iteration.campaign_id == Campaign.id, Iteration.index == Campaign.current_iteration)
    .scalar_subquery(),
    sa.select(sa.func.max(CampaignEvent.id)).where(CampaignEvent.campaign_id == Campaign.id).scalar_subquery(),
    sa.select(IterationMetrics.id)
    .where(IterationMetrics.campaign_id == Campaign.id)
    .order_by(IterationMetrics.iteration_index.desc())
    .limit(1)
    .scalar_subquery(),
    _LAST_VALIDATION,
    _SUITE_PROGRESS,
    _SUITE_STATUS.scalar_subquery(),
    sa.select(sa.func.count())
    .where(ValidationMotion.suite_id == Campaign.validation_suite_id, ValidationMotion.status == "succeeded")
    .scalar_subquery(),
).where(_visible_campaign())
_CURVES_SHA = (
    sa.select(IterationMetrics.curves_sha256)
    .join(Campaign, Campaign.id == IterationMetrics.campaign_id)
    .where(
        IterationMetrics.campaign_id == sa.bindparam("cid"),
        IterationMetrics.iteration_index == sa.bindparam("k"),
        IterationMetrics.curves_sha256.is_not(None),
        _visible_campaign(),
    )
)

#: The campaigns an iteration's outputs may live in: the visible campaign, then (recursively)
#: a fork's source while ``k`` is at most the fork's source iteration (as ``repo.resolve_source``).
_SOURCES = (
    sa.select(Campaign.id, Campaign.source_campaign_id, Campaign.source_iteration)
    .where(_visible_campaign())
    .cte("sources", recursive=True)
)
_SOURCE = aliased(Campaign)
_SOURCES = _SOURCES.union_all(
    sa.select(_SOURCE.id, _SOURCE.source_campaign_id, _SOURCE.source_iteration)
    .join(_SOURCES, _SOURCE.id == _SOURCES.c.source_campaign_id)
    .where(_SOURCES.c.source_iteration >= sa.bindparam("k"))
)
#: The latest OCP solution with a trajectory of iteration ``k`` in the campaign holding it.
_TRAJECTORY_SOLUTION = (
    sa.select(OcpSolution.id)
    .join(Iteration, Iteration.id == OcpSolution.iteration_id)
    .join(_SOURCES, _SOURCES.c.id == Iteration.campaign_id)
    .where(
        Iteration.index == sa.bindparam("k"),
        OcpSolution.trajectory_sha256.is_not(None),
        sa.or_(
            _SOURCES.c.source_campaign_id.is_(None),
            _SOURCES.c.source_iteration.is_(None),
            _SOURCES.c.source_iteration < sa.bindparam("k"),
        ),
    )
    .order_by(OcpSolution.attempt.desc())
    .limit(1)
)


def metrics_revision(conn: sa.Connection, campaign_id: int, user_id: int) -> tuple[Any, ...] | None:
    """What makes the cached series stale: the campaign's ``updated_at``, the count and last
    id of its metrics rows (None: no such campaign visible to the user)."""
    row = conn.execute(_REVISION, {"cid": campaign_id, "uid": user_id}).first()
    return None if row is None else tuple(row)


def detail_revision(conn: sa.Connection, campaign_id: int, user_id: int) -> tuple[Any, ...] | None:
    """What makes the cached detail stale (None: no such campaign visible to the user)."""
    row = conn.execute(_DETAIL_REVISION, {"cid": campaign_id, "uid": user_id}).first()
    return None if row is None else tuple(row)


def curves_sha(conn: sa.Connection, campaign_id: int, iteration: int, user_id: int) -> str | None:
    return conn.execute(_CURVES_SHA, {"cid": campaign_id, "k": iteration, "uid": user_id}).scalar()


def trajectory_solution(conn: sa.Connection, campaign_id: int, iteration: int, user_id: int) -> int | None:
    """The id of the OCP solution iteration ``iteration`` shows (None: none yet, or no such
    campaign visible to the user)."""
    return conn.execute(_TRAJECTORY_SOLUTION, {"cid": campaign_id, "k": iteration, "uid": user_id}).scalar()
