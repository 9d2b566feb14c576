"""Campaigns, their config history, iterations and the per-step state machine rows.

Numbering: iteration 0 is the start of a campaign (its single ``preliminary`` step builds
pool version 0); iterations k >= 1 run ``train -> ocp -> oracle -> evaluate -> append``,
one :class:`IterationStep` row per step. A fork or warm start names its source
(``source_campaign_id``, ``source_iteration``) and continues from that campaign's pool
and model at that iteration instead of running a preliminary step.

The database is the record; a Celery message only says "run step S of iteration k of
campaign C". A job claims its step with a conditional update
(``UPDATE iteration_steps SET status='running', claim_token=:t, lease_until=:l ...
WHERE id=:id AND status='queued'``), heartbeats ``heartbeat_at``/``lease_until`` while it
runs, writes its results and ``status='succeeded'`` in one transaction guarded by its
``claim_token``, and the next step is enqueued after that commit.
"""

from __future__ import annotations

from datetime import datetime
from typing import TYPE_CHECKING, Any

import sqlalchemy as sa
from sqlalchemy.orm import Mapped, mapped_column, relationship

from alcove.models.base import (
    Base,
    CampaignStatus,
    IterationStatus,
    StepName,
    StepStatus,
    TimestampMixin,
    enum_check,
    utcnow,
)

if TYPE_CHECKING:
    from alcove.models.data import OracleBatchJob, OracleRun
    from alcove.models.definitions import OracleVersion, SurrogateConfigVersion, TaskVersion
    from alcove.models.users import User


class Campaign(TimestampMixin, Base):
    __tablename__ = "campaigns"
    __table_args__ = (
        enum_check("status", CampaignStatus),
        sa.Index("ix_campaigns_owner_id_status", "owner_id", "status"),
        sa.CheckConstraint(
            "source_iteration IS NULL OR source_campaign_id IS NOT NULL", name="source_iteration_needs_source"
        ),
    )

    id: Mapped[int] = mapped_column(primary_key=True)
    owner_id: Mapped[int] = mapped_column(sa.ForeignKey("users.id", ondelete="RESTRICT"), index=True)
    name: Mapped[str] = mapped_column(sa.String(200))
    description: Mapped[str] = mapped_column(sa.Text, default="", server_default="")

    # what the campaign runs (the versions are locked when the campaign starts)
    task_version_id: Mapped[int] = mapped_column(sa.ForeignKey("task_versions.id", ondelete="RESTRICT"), index=True)
    oracle_version_id: Mapped[int] = mapped_column(sa.ForeignKey("oracle_versions.id", ondelete="RESTRICT"), index=True)
    surrogate_config_version_id: Mapped[int] = mapped_column(
        sa.ForeignKey("surrogate_config_versions.id", ondelete="RESTRICT"),
        index=True,
        comment="current; history in campaign_config_versions",
    )
    preliminary_config: Mapped[dict[str, Any]] = mapped_column(
        default=dict,
        comment=(
            "preliminary data: LHS sample count K, velocity bounds, oracle, or an uploaded dataset id; "
            "down-weighting schedule"
        ),
    )
    stopping_rules: Mapped[dict[str, Any]] = mapped_column(
        default=dict,
        comment="any of max_iterations, target force/moment RMSE, plateau window/tolerance, oracle wall-time budget",
    )
    policies: Mapped[dict[str, Any]] = mapped_column(
        default=dict, comment="failure policies: OCP retries/initial guesses, oracle retries, on-failure continue|stop"
    )
    seed: Mapped[int] = mapped_column(sa.BigInteger, default=0, server_default="0")
    config_version: Mapped[int] = mapped_column(
        default=1, server_default="1", comment="number of the current campaign_config_versions row"
    )

    # fork / warm start
    source_campaign_id: Mapped[int | None] = mapped_column(
        sa.ForeignKey("campaigns.id", ondelete="RESTRICT"), index=True
    )
    source_iteration: Mapped[int | None] = mapped_column(
        comment="start from the source campaign's pool and model at this iteration"
    )

    # lifecycle
    status: Mapped[str] = mapped_column(
        sa.String(16), default=CampaignStatus.draft.value, server_default=CampaignStatus.draft.value
    )
    stop_reason: Mapped[str | None] = mapped_column(
        sa.String(64), comment="max_iterations | target_rmse | plateau | oracle_budget | cancelled | error | ..."
    )
    error: Mapped[str | None] = mapped_column(sa.Text)
    wait_reason: Mapped[str | None] = mapped_column(
        sa.Text,
        comment="why a queued campaign waits before its first job is sent (its owner's running-campaigns limit); "
        "NULL: it does not wait",
    )
    pause_requested: Mapped[bool] = mapped_column(default=False, server_default=sa.false())
    cancel_requested: Mapped[bool] = mapped_column(default=False, server_default=sa.false())
    current_iteration: Mapped[int] = mapped_column(default=0, server_default="0")
    current_step: Mapped[str | None] = mapped_column(sa.String(16))
    oracle_wall_time_s: Mapped[float] = mapped_column(
        sa.Float, default=0.0, server_default="0", comment="sum over oracle runs (budget rule)"
    )
    started_at: Mapped[datetime | None]
    finished_at: Mapped[datetime | None]
    validation_suite_id: Mapped[int | None] = mapped_column(
        sa.ForeignKey("validation_suites.id", ondelete="SET NULL"),
        index=True,
        comment="the held-out validation suite its model versions are evaluated on (shared)",
    )

    owner: Mapped[User] = relationship()
    task_version: Mapped[TaskVersion] = relationship()
    oracle_version: Mapped[OracleVersion] = relationship()
    surrogate_config_version: Mapped[SurrogateConfigVersion] = relationship()
    source_campaign: Mapped[Campaign | None] = relationship(remote_side=[id])
    config_versions: Mapped[list[CampaignConfigVersion]] = relationship(
        back_populates="campaign",
        order_by="CampaignConfigVersion.version",
        cascade="all, delete-orphan",
        passive_deletes=True,
    )
    iterations: Mapped[list[Iteration]] = relationship(
        back_populates="campaign", order_by="Iteration.index", cascade="all, delete-orphan", passive_deletes=True
    )

    @property
    def is_terminal(self) -> bool:
        return CampaignStatus(self.status) in CampaignStatus.terminal()


class CampaignConfigVersion(Base):
    """Immutable snapshot of a campaign's editable settings. Version 1 is written at
    creation; each edit of a running campaign adds version n+1 (and bumps
    ``campaigns.config_version``). Iterations and steps record the version they used."""

    __tablename__ = "campaign_config_versions"
    __table_args__ = (sa.UniqueConstraint("campaign_id", "version"),)
    __immutable_columns__ = (
        "campaign_id",
        "version",
        "surrogate_config_version_id",
        "preliminary_config",
        "stopping_rules",
        "policies",
        "settings",
    )

    id: Mapped[int] = mapped_column(primary_key=True)
    campaign_id: Mapped[int] = mapped_column(sa.ForeignKey("campaigns.id", ondelete="CASCADE"), index=True)
    version: Mapped[int]
    surrogate_config_version_id: Mapped[int] = mapped_column(
        sa.ForeignKey("surrogate_config_versions.id", ondelete="RESTRICT")
    )
    preliminary_config: Mapped[dict[str, Any]] = mapped_column(default=dict)
    stopping_rules: Mapped[dict[str, Any]] = mapped_column(default=dict)
    policies: Mapped[dict[str, Any]] = mapped_column(default=dict)
    settings: Mapped[dict[str, Any]] = mapped_column(default=dict, comment="anything else that affects the run")
    note: Mapped[str] = mapped_column(sa.Text, default="", server_default="")
    created_by_id: Mapped[int | None] = mapped_column(sa.ForeignKey("users.id", ondelete="SET NULL"))
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())

    campaign: Mapped[Campaign] = relationship(back_populates="config_versions")
    surrogate_config_version: Mapped[SurrogateConfigVersion] = relationship()


class Iteration(Base):
    __tablename__ = "iterations"
    __table_args__ = (
        sa.UniqueConstraint("campaign_id", "index"),
        enum_check("status", IterationStatus),
        sa.CheckConstraint('"index" >= 0', name="index_non_negative"),
    )

    id: Mapped[int] = mapped_column(primary_key=True)
    campaign_id: Mapped[int] = mapped_column(sa.ForeignKey("campaigns.id", ondelete="CASCADE"), index=True)
    index: Mapped[int] = mapped_column(comment="k; 0 = preliminary data")
    config_version_id: Mapped[int] = mapped_column(
        sa.ForeignKey("campaign_config_versions.id", ondelete="RESTRICT"), index=True
    )
    status: Mapped[str] = mapped_column(
        sa.String(16), default=IterationStatus.pending.value, server_default=IterationStatus.pending.value
    )
    current_step: Mapped[str | None] = mapped_column(sa.String(16))
    error: Mapped[str | None] = mapped_column(sa.Text)
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())
    started_at: Mapped[datetime | None]
    finished_at: Mapped[datetime | None]
    scenario: Mapped[dict[str, Any] | None] = mapped_column(
        comment="the scenario the iteration's OCP solved (random-scenarios: seed, iteration, slot, values); "
        "null: the task as written",
    )

    campaign: Mapped[Campaign] = relationship(back_populates="iterations")
    config_version: Mapped[CampaignConfigVersion] = relationship()
    steps: Mapped[list[IterationStep]] = relationship(
        back_populates="iteration", order_by="IterationStep.id", cascade="all, delete-orphan", passive_deletes=True
    )
    candidates: Mapped[list[IterationCandidate]] = relationship(
        order_by="IterationCandidate.slot", cascade="all, delete-orphan", passive_deletes=True
    )
    oracle_runs: Mapped[list[OracleRun]] = relationship(
        primaryjoin="Iteration.id == foreign(OracleRun.iteration_id)", viewonly=True, order_by="OracleRun.id"
    )

    @property
    def oracle_calls(self) -> int:
        """Oracle runs the iteration made (every attempt that reached the oracle; a job lost
        with its worker leaves none)."""
        return len(self.oracle_runs)

    @property
    def picks(self) -> list[IterationCandidate]:
        """The candidates the oracle replayed, in pick order."""
        return sorted((c for c in self.candidates if c.pick is not None), key=lambda c: c.pick or 0)


class IterationCandidate(Base):
    """One scenario an iteration's OCP solved (ocp slot ``slot``) and, if it was picked, the
    oracle slot that replayed it (``pick``), with what came out. ``random-scenarios``
    picks every candidate (pick = slot); ``ensemble-disagreement`` scores C candidates and picks q."""

    __tablename__ = "iteration_candidates"
    __table_args__ = (sa.UniqueConstraint("iteration_id", "slot"), sa.UniqueConstraint("iteration_id", "pick"))

    id: Mapped[int] = mapped_column(primary_key=True)
    iteration_id: Mapped[int] = mapped_column(sa.ForeignKey("iterations.id", ondelete="CASCADE"), index=True)
    slot: Mapped[int] = mapped_column(comment="the ocp slot that solved it")
    scenario: Mapped[dict[str, Any] | None] = mapped_column(comment="seed, iteration, slot, values; null: the task")
    ocp_solution_id: Mapped[int | None] = mapped_column(sa.ForeignKey("ocp_solutions.id", ondelete="SET NULL"))
    converged: Mapped[bool | None]
    score: Mapped[float | None] = mapped_column(
        sa.Float, comment="ensemble disagreement over the contact phase [N] (ensemble-disagreement)"
    )
    features: Mapped[list[Any] | None] = mapped_column(comment="the point in feature space the diversity rule uses")
    pick: Mapped[int | None] = mapped_column(comment="the oracle slot that replays it; null: not picked")
    pick_reason: Mapped[str | None] = mapped_column(sa.Text)
    oracle_run_id: Mapped[int | None] = mapped_column(sa.ForeignKey("oracle_runs.id", ondelete="SET NULL"))
    dataset_id: Mapped[int | None] = mapped_column(sa.ForeignKey("datasets.id", ondelete="SET NULL"))
    force_rmse: Mapped[float | None] = mapped_column(sa.Float, comment="in-loop force RMSE on its oracle data [N]")
    moment_rmse: Mapped[float | None] = mapped_column(sa.Float)
    curves_sha256: Mapped[str | None] = mapped_column(
        sa.ForeignKey("blobs.sha256", ondelete="RESTRICT"),
        comment="a pick's curves: t, q, qd, f_true, f_pred (ensemble mean), f_std (K > 1)",
    )


class IterationStep(Base):
    """One step of one iteration: the unit of work a Celery job executes."""

    __tablename__ = "iteration_steps"
    __table_args__ = (
        sa.UniqueConstraint("iteration_id", "step", "slot"),
        enum_check("step", StepName),
        enum_check("status", StepStatus),
        sa.Index("ix_iteration_steps_status_lease_until", "status", "lease_until"),
        sa.Index("ix_iteration_steps_campaign_id_status", "campaign_id", "status"),
    )

    id: Mapped[int] = mapped_column(primary_key=True)
    campaign_id: Mapped[int] = mapped_column(sa.ForeignKey("campaigns.id", ondelete="CASCADE"))
    iteration_id: Mapped[int] = mapped_column(sa.ForeignKey("iterations.id", ondelete="CASCADE"), index=True)
    step: Mapped[str] = mapped_column(sa.String(16))
    slot: Mapped[int] = mapped_column(
        default=0,
        server_default="0",
        comment="which of the iteration's parallel jobs of this step (ocp: the candidate, oracle: the pick); "
        "0 for the rest",
    )
    status: Mapped[str] = mapped_column(
        sa.String(16), default=StepStatus.pending.value, server_default=StepStatus.pending.value
    )
    queue: Mapped[str] = mapped_column(
        sa.String(32), default="default", server_default="default", comment="Celery queue it is sent to"
    )
    config_version_id: Mapped[int | None] = mapped_column(
        sa.ForeignKey("campaign_config_versions.id", ondelete="RESTRICT")
    )
    attempts: Mapped[int] = mapped_column(default=0, server_default="0", comment="claims so far")
    max_attempts: Mapped[int] = mapped_column(default=3, server_default="3")
    claim_token: Mapped[str | None] = mapped_column(
        sa.String(64), comment="set by the claiming job; completion is conditional on it"
    )
    lease_until: Mapped[datetime | None] = mapped_column(comment="the reconciler re-queues a running step after this")
    heartbeat_at: Mapped[datetime | None]
    worker_name: Mapped[str | None] = mapped_column(sa.String(200))
    celery_task_id: Mapped[str | None] = mapped_column(sa.String(64))
    queued_at: Mapped[datetime | None]
    started_at: Mapped[datetime | None]
    finished_at: Mapped[datetime | None]
    wall_time_s: Mapped[float | None] = mapped_column(sa.Float)
    error: Mapped[str | None] = mapped_column(sa.Text)
    result: Mapped[dict[str, Any]] = mapped_column(
        default=dict, comment="small JSON summary of the outcome (ids of rows written, status)"
    )
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())
    updated_at: Mapped[datetime] = mapped_column(default=utcnow, onupdate=utcnow, server_default=sa.func.now())

    iteration: Mapped[Iteration] = relationship(back_populates="steps")
    batch_jobs: Mapped[list[OracleBatchJob]] = relationship(order_by="OracleBatchJob.id", viewonly=True)


class CampaignEvent(Base):
    """Append-only log of what happened (status changes, step outcomes, edits). The
    increasing ``id`` lets clients poll ``?after=<id>`` or stream them as SSE."""

    __tablename__ = "campaign_events"
    __table_args__ = (sa.Index("ix_campaign_events_campaign_id_id", "campaign_id", "id"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    campaign_id: Mapped[int] = mapped_column(sa.ForeignKey("campaigns.id", ondelete="CASCADE"))
    iteration_index: Mapped[int | None]
    step: Mapped[str | None] = mapped_column(sa.String(16))
    kind: Mapped[str] = mapped_column(
        sa.String(32), comment="e.g. status, step_started, step_succeeded, step_failed, config_changed"
    )
    message: Mapped[str] = mapped_column(sa.Text, default="", server_default="")
    data: Mapped[dict[str, Any]] = mapped_column(default=dict)
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())
