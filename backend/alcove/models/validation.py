"""The held-out validation suite: its motions, their replays and each model version's error on them.

A suite is computed once per (oracle version, suite spec) and shared by every campaign that
asks for the same one (``campaigns.validation_suite_id``). Its motions are replayed by the
oracle as jobs on the ``oracle`` queue, each claiming its :class:`ValidationMotion` row with
a conditional update (a duplicate delivery does nothing); the replays are stored as datasets
of origin ``validation``, which no pool version ever contains. Every model version of a
campaign gets one :class:`ValidationMetrics` row: its generalisation error on all motions.
"""

from __future__ import annotations

import enum
from datetime import datetime
from typing import Any

import sqlalchemy as sa
from sqlalchemy.orm import Mapped, mapped_column, relationship

from alcove.models.base import Base, enum_check, utcnow


class SuiteStatus(str, enum.Enum):
    replaying = "replaying"  # motions queued or running
    complete = "complete"  # every motion has its dataset
    failed = "failed"  # a motion failed for good (attempts exhausted or quarantined)


class MotionStatus(str, enum.Enum):
    queued = "queued"
    running = "running"
    succeeded = "succeeded"
    failed = "failed"


class ValidationSuite(Base):
    __tablename__ = "validation_suites"
    __table_args__ = (
        sa.UniqueConstraint("oracle_version_id", "spec_hash"),
        enum_check("status", SuiteStatus),
    )
    __immutable_columns__ = ("oracle_version_id", "spec_hash", "spec", "preset", "n_motions")

    id: Mapped[int] = mapped_column(primary_key=True)
    oracle_version_id: Mapped[int] = mapped_column(sa.ForeignKey("oracle_versions.id", ondelete="RESTRICT"))
    spec_hash: Mapped[str] = mapped_column(sa.String(64), comment="sha256 of the suite spec and the model preset")
    spec: Mapped[dict[str, Any]] = mapped_column(comment="motions, seed, dt, ranges (alcove.science.validation_suite)")
    preset: Mapped[dict[str, Any]] = mapped_column(comment="the model preset the motions are drawn for")
    n_motions: Mapped[int]
    status: Mapped[str] = mapped_column(
        sa.String(16), default=SuiteStatus.replaying.value, server_default=SuiteStatus.replaying.value
    )
    error: Mapped[str | None] = mapped_column(sa.Text)
    replay_wall_time_s: Mapped[float | None] = mapped_column(
        sa.Float, comment="first motion queued to last motion stored"
    )
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())
    completed_at: Mapped[datetime | None]
    reference: Mapped[dict[str, Any] | None] = mapped_column(
        comment="the best-possible line (alcove.surrogates.reference_line): per oracle budget, the error of a "
        "model trained from scratch on that many reference replays; null: not computed (yet) or not asked for"
    )

    motions: Mapped[list[ValidationMotion]] = relationship(
        order_by="ValidationMotion.index", cascade="all, delete-orphan", passive_deletes=True
    )


class ValidationMotion(Base):
    """One held-out motion of a suite and the state of its oracle replay job."""

    __tablename__ = "validation_motions"
    __table_args__ = (sa.UniqueConstraint("suite_id", "index"), enum_check("status", MotionStatus))

    id: Mapped[int] = mapped_column(primary_key=True)
    suite_id: Mapped[int] = mapped_column(sa.ForeignKey("validation_suites.id", ondelete="CASCADE"), index=True)
    index: Mapped[int]
    params: Mapped[dict[str, Any]] = mapped_column(comment="start, depth, speed, dwell")
    status: Mapped[str] = mapped_column(
        sa.String(16), default=MotionStatus.queued.value, server_default=MotionStatus.queued.value
    )
    attempts: Mapped[int] = mapped_column(default=0, server_default="0")
    max_attempts: Mapped[int] = mapped_column(default=3, server_default="3")
    claim_token: Mapped[str | None] = mapped_column(sa.String(64))
    lease_until: Mapped[datetime | None]
    worker_name: Mapped[str | None] = mapped_column(sa.String(200))
    queued_at: Mapped[datetime | None]
    started_at: Mapped[datetime | None]
    finished_at: Mapped[datetime | None]
    wall_time_s: Mapped[float | None] = mapped_column(sa.Float, comment="the oracle's wall time")
    error: Mapped[str | None] = mapped_column(sa.Text)
    dataset_id: Mapped[int | None] = mapped_column(sa.ForeignKey("datasets.id", ondelete="RESTRICT"), unique=True)


class ValidationMetrics(Base):
    """A model version's generalisation error on all motions of its campaign's suite."""

    __tablename__ = "validation_metrics"
    __table_args__ = (sa.UniqueConstraint("model_version_id"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    model_version_id: Mapped[int] = mapped_column(sa.ForeignKey("model_versions.id", ondelete="CASCADE"))
    suite_id: Mapped[int] = mapped_column(sa.ForeignKey("validation_suites.id", ondelete="CASCADE"), index=True)
    force_rmse: Mapped[float] = mapped_column(sa.Float, comment="N: sqrt(mean |F_pred - F_true|^2) over all samples")
    moment_rmse: Mapped[float] = mapped_column(sa.Float, comment="N m: the same for the moment vector")
    components: Mapped[dict[str, Any]] = mapped_column(comment="RMSE per component fx..mz")
    calibration: Mapped[float | None] = mapped_column(
        sa.Float, comment="share of oracle values within mean +- 2 std; null for K = 1 or when not recorded"
    )
    calibration_recorded: Mapped[bool] = mapped_column(
        default=True,
        server_default=sa.true(),
        comment="false: evaluated before migration 0019, when the calibration was not computed (null, not 'K = 1')",
    )
    per_motion: Mapped[list[Any]] = mapped_column(comment="force and moment RMSE per motion, in suite order")
    n_samples: Mapped[int]
    stress: Mapped[dict[str, Any] | None] = mapped_column(
        comment="the error on the suite's stress part (force_rmse, moment_rmse, components, calibration, "
        "n_samples); null: no stress part"
    )
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())
