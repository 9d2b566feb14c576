"""Arrays, datasets, data-pool versions, model versions, OCP solutions, oracle runs,
quarantined results and per-iteration metrics.

Arrays are never stored one row per sample: a :class:`Blob` holds a dict of NumPy arrays
as compressed ``.npz`` bytes, keyed by the SHA-256 of their canonical content (names,
dtypes, shapes, bytes), so identical arrays are stored once. Use
:mod:`alcove.db.arrays` (``put_arrays`` / ``get_arrays``) to write and read them.

Pool versions are immutable: version k = version k-1 + the datasets appended by
iteration k. ``pool_version_members`` lists the full membership of every version (a
dataset at most once per version) and ``pool_versions.iteration_id`` is unique, so an
iteration can append at most once.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from typing import TYPE_CHECKING, Any

import sqlalchemy as sa
from sqlalchemy.orm import Mapped, deferred, mapped_column, relationship

from alcove.models.base import Base, BatchJobState, DatasetOrigin, OracleRunStatus, enum_check, utcnow

if TYPE_CHECKING:
    from alcove.models.campaigns import Iteration


@dataclass(frozen=True)
class HeadrestPlacement:
    """Where a scenario put the headrest for a dataset's samples, relative to the task's own:
    ``offset`` [m] along its normal and ``tilt`` [rad], the scenario's drawn inclination (None:
    the task's own, not drawn). The samples' features are computed against this headrest, so it
    is part of the training data. Stored in the dataset's ``meta`` under these two keys."""

    offset: float | None = None
    tilt: float | None = None

    @classmethod
    def from_meta(cls, meta: dict[str, Any] | None) -> HeadrestPlacement:
        meta = meta or {}
        offset, tilt = meta.get("headrest_offset"), meta.get("headrest_tilt")
        return cls(None if offset is None else float(offset), None if tilt is None else float(tilt))

    def as_meta(self) -> dict[str, float]:
        """The ``meta`` entries of this placement (none for the task's own headrest)."""
        out = {} if self.offset is None else {"headrest_offset": self.offset}
        return out if self.tilt is None else out | {"headrest_tilt": self.tilt}


class Blob(Base):
    """Content-addressed bytes (normally an ``.npz`` of named arrays). Immutable."""

    __tablename__ = "blobs"
    __immutable_columns__ = ("sha256", "media_type", "data", "size_bytes")

    sha256: Mapped[str] = mapped_column(sa.String(64), primary_key=True, comment="sha256 of the canonical content")
    media_type: Mapped[str] = mapped_column(
        sa.String(100), default="application/x-npz", server_default="application/x-npz"
    )
    size_bytes: Mapped[int] = mapped_column(sa.BigInteger, comment="len(data)")
    manifest: Mapped[dict[str, Any]] = mapped_column(
        default=dict, comment="{name: {dtype, shape}} of the arrays inside"
    )
    data: Mapped[bytes] = deferred(mapped_column(sa.LargeBinary))
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())


class Dataset(Base):
    """Samples with their oracle truth: one trajectory replayed by an oracle, the
    preliminary samples, or an uploaded table. The arrays are in ``content_sha256``:
    ``t``, ``q``, ``qd`` (n, ndof), relative kinematics, ``f`` (n, 6: fx fy fz mx my mz in
    the headrest frame) and, for multi-trajectory sets, ``group`` (n,) trajectory ids."""

    __tablename__ = "datasets"
    __table_args__ = (
        enum_check("origin", DatasetOrigin),
        sa.Index("ix_datasets_campaign_id_origin", "campaign_id", "origin"),
    )
    __immutable_columns__ = ("content_sha256", "origin", "n_samples")

    id: Mapped[int] = mapped_column(primary_key=True)
    origin: Mapped[str] = mapped_column(sa.String(16))
    content_sha256: Mapped[str] = mapped_column(sa.ForeignKey("blobs.sha256", ondelete="RESTRICT"), index=True)
    campaign_id: Mapped[int | None] = mapped_column(sa.ForeignKey("campaigns.id", ondelete="CASCADE"))
    iteration_id: Mapped[int | None] = mapped_column(sa.ForeignKey("iterations.id", ondelete="CASCADE"), index=True)
    oracle_run_id: Mapped[int | None] = mapped_column(
        sa.ForeignKey("oracle_runs.id", ondelete="SET NULL"), unique=True, comment="the run that produced it"
    )
    owner_id: Mapped[int | None] = mapped_column(
        sa.ForeignKey("users.id", ondelete="SET NULL"), index=True, comment="uploader (origin=upload)"
    )
    name: Mapped[str] = mapped_column(sa.String(200), default="", server_default="")
    n_samples: Mapped[int]
    n_trajectories: Mapped[int] = mapped_column(default=1, server_default="1")
    meta: Mapped[dict[str, Any]] = mapped_column(
        default=dict, comment="columns, units, source file name, sampling settings"
    )
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())

    content: Mapped[Blob] = relationship()

    @property
    def headrest(self) -> HeadrestPlacement:
        """Where the scenario of these samples put the headrest (both None: the task's own)."""
        return HeadrestPlacement.from_meta(self.meta)


class PoolVersion(Base):
    """Immutable snapshot of a campaign's training pool. ``version`` normally equals the
    index of the iteration that created it (0 = preliminary). ``parent_id`` is version
    k-1, possibly of the source campaign for a fork."""

    __tablename__ = "pool_versions"
    __table_args__ = (sa.UniqueConstraint("campaign_id", "version"), sa.UniqueConstraint("iteration_id"))
    __immutable_columns__ = (
        "campaign_id",
        "iteration_id",
        "version",
        "parent_id",
        "n_datasets",
        "n_samples",
        "content_hash",
    )

    id: Mapped[int] = mapped_column(primary_key=True)
    campaign_id: Mapped[int] = mapped_column(sa.ForeignKey("campaigns.id", ondelete="CASCADE"))
    iteration_id: Mapped[int] = mapped_column(
        sa.ForeignKey("iterations.id", ondelete="CASCADE"), comment="the iteration whose append created it"
    )
    version: Mapped[int]
    parent_id: Mapped[int | None] = mapped_column(sa.ForeignKey("pool_versions.id", ondelete="RESTRICT"), index=True)
    n_datasets: Mapped[int] = mapped_column(default=0, server_default="0")
    n_samples: Mapped[int] = mapped_column(sa.BigInteger, default=0, server_default="0")
    content_hash: Mapped[str] = mapped_column(sa.String(64), comment="sha256 over the members' content hashes in order")
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())

    parent: Mapped[PoolVersion | None] = relationship(remote_side=[id])
    members: Mapped[list[PoolVersionMember]] = relationship(
        order_by="PoolVersionMember.position", cascade="all, delete-orphan", passive_deletes=True
    )


class PoolVersionMember(Base):
    """Full membership of a pool version (a dataset at most once per version)."""

    __tablename__ = "pool_version_members"
    __table_args__ = (sa.UniqueConstraint("pool_version_id", "position"),)
    __immutable_columns__ = ("pool_version_id", "dataset_id", "position", "added_in_this_version")

    pool_version_id: Mapped[int] = mapped_column(
        sa.ForeignKey("pool_versions.id", ondelete="CASCADE"), primary_key=True
    )
    dataset_id: Mapped[int] = mapped_column(
        sa.ForeignKey("datasets.id", ondelete="RESTRICT"), primary_key=True, index=True
    )
    position: Mapped[int] = mapped_column(comment="0..n-1, stable order for reproducible training")
    added_in_this_version: Mapped[bool] = mapped_column(default=False, server_default=sa.false())

    dataset: Mapped[Dataset] = relationship()


class ModelVersion(Base):
    """A trained surrogate (force and moment MLPs) with its full lineage."""

    __tablename__ = "model_versions"
    __table_args__ = (sa.UniqueConstraint("campaign_id", "version"), sa.UniqueConstraint("iteration_id"))
    __immutable_columns__ = (
        "campaign_id",
        "iteration_id",
        "version",
        "pool_version_id",
        "parent_model_id",
        "seed",
        "weights_sha256",
        "architecture",
        "normalisation",
    )

    id: Mapped[int] = mapped_column(primary_key=True)
    campaign_id: Mapped[int | None] = mapped_column(sa.ForeignKey("campaigns.id", ondelete="CASCADE"))
    iteration_id: Mapped[int | None] = mapped_column(
        sa.ForeignKey("iterations.id", ondelete="CASCADE"), comment="the train step that produced it"
    )
    version: Mapped[int] = mapped_column(comment="normally the iteration index k")
    pool_version_id: Mapped[int] = mapped_column(
        sa.ForeignKey("pool_versions.id", ondelete="RESTRICT"), index=True, comment="trained on"
    )
    parent_model_id: Mapped[int | None] = mapped_column(
        sa.ForeignKey("model_versions.id", ondelete="RESTRICT"), index=True, comment="warm start"
    )
    surrogate_config_version_id: Mapped[int | None] = mapped_column(
        sa.ForeignKey("surrogate_config_versions.id", ondelete="RESTRICT")
    )
    seed: Mapped[int] = mapped_column(sa.BigInteger)
    architecture: Mapped[dict[str, Any]] = mapped_column(comment="widths, activations, dtype of both networks")
    normalisation: Mapped[dict[str, Any]] = mapped_column(comment="input mean/std (19 features) per network")
    training_config: Mapped[dict[str, Any]] = mapped_column(
        default=dict, comment="splits, optimiser, batch size, patience, sample weights"
    )
    training_metrics: Mapped[dict[str, Any]] = mapped_column(
        default=dict, comment="train/val/test RMSE force+moment, loss curves"
    )
    test_force_rmse: Mapped[float | None] = mapped_column(sa.Float)
    test_moment_rmse: Mapped[float | None] = mapped_column(sa.Float)
    epochs: Mapped[int | None]
    train_wall_time_s: Mapped[float | None] = mapped_column(sa.Float)
    weights_sha256: Mapped[str] = mapped_column(
        sa.ForeignKey("blobs.sha256", ondelete="RESTRICT"), comment="npz of all parameters"
    )
    artifact_sha256: Mapped[str | None] = mapped_column(
        sa.ForeignKey("blobs.sha256", ondelete="RESTRICT"), comment="self-contained artifact (zip: JSON + TorchScript)"
    )
    code_version: Mapped[str] = mapped_column(sa.String(100), comment="alcove version (+ git commit if known)")
    library_versions: Mapped[dict[str, Any]] = mapped_column(default=dict, comment="torch, numpy, casadi, python")
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())

    pool_version: Mapped[PoolVersion] = relationship()
    parent_model: Mapped[ModelVersion | None] = relationship(remote_side=[id])


class OcpSolution(Base):
    """One solve attempt of the task with a model version as the contact model."""

    __tablename__ = "ocp_solutions"
    __table_args__ = (sa.UniqueConstraint("iteration_id", "slot", "attempt"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    campaign_id: Mapped[int | None] = mapped_column(sa.ForeignKey("campaigns.id", ondelete="CASCADE"), index=True)
    iteration_id: Mapped[int | None] = mapped_column(sa.ForeignKey("iterations.id", ondelete="CASCADE"))
    slot: Mapped[int] = mapped_column(default=0, server_default="0", comment="the iteration's ocp slot (candidate)")
    model_version_id: Mapped[int | None] = mapped_column(
        sa.ForeignKey("model_versions.id", ondelete="RESTRICT"), index=True
    )
    attempt: Mapped[int] = mapped_column(default=1, server_default="1")
    initial_guess: Mapped[str] = mapped_column(sa.String(64), default="default", server_default="default")
    success: Mapped[bool]
    solver_status: Mapped[str] = mapped_column(sa.String(64), comment="IPOPT return status")
    n_iterations: Mapped[int | None]
    cost: Mapped[float | None] = mapped_column(sa.Float)
    wall_time_s: Mapped[float | None] = mapped_column(sa.Float)
    message: Mapped[str] = mapped_column(sa.Text, default="", server_default="")
    stats: Mapped[dict[str, Any]] = mapped_column(default=dict)
    trajectory_sha256: Mapped[str | None] = mapped_column(
        sa.ForeignKey("blobs.sha256", ondelete="RESTRICT"), comment="t, q, qd, tau"
    )
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())


class OracleRun(Base):
    """One oracle replay (attempt) of a trajectory."""

    __tablename__ = "oracle_runs"
    __table_args__ = (enum_check("status", OracleRunStatus), sa.UniqueConstraint("iteration_id", "slot", "attempt"))

    id: Mapped[int] = mapped_column(primary_key=True)
    campaign_id: Mapped[int | None] = mapped_column(sa.ForeignKey("campaigns.id", ondelete="CASCADE"), index=True)
    iteration_id: Mapped[int | None] = mapped_column(sa.ForeignKey("iterations.id", ondelete="CASCADE"))
    slot: Mapped[int] = mapped_column(default=0, server_default="0", comment="the iteration's oracle slot (pick)")
    oracle_version_id: Mapped[int | None] = mapped_column(
        sa.ForeignKey("oracle_versions.id", ondelete="RESTRICT"), index=True
    )
    ocp_solution_id: Mapped[int | None] = mapped_column(
        sa.ForeignKey("ocp_solutions.id", ondelete="SET NULL"), comment="trajectory source"
    )
    attempt: Mapped[int] = mapped_column(default=1, server_default="1")
    status: Mapped[str] = mapped_column(
        sa.String(16), default=OracleRunStatus.running.value, server_default=OracleRunStatus.running.value
    )
    worker_name: Mapped[str | None] = mapped_column(sa.String(200))
    started_at: Mapped[datetime | None]
    finished_at: Mapped[datetime | None]
    wall_time_s: Mapped[float | None] = mapped_column(sa.Float)
    failure_reason: Mapped[str | None] = mapped_column(sa.Text)
    diagnostics: Mapped[dict[str, Any]] = mapped_column(default=dict)
    input_sha256: Mapped[str | None] = mapped_column(
        sa.ForeignKey("blobs.sha256", ondelete="RESTRICT"), comment="replayed trajectory"
    )
    output_sha256: Mapped[str | None] = mapped_column(
        sa.ForeignKey("blobs.sha256", ondelete="RESTRICT"), comment="forces + kinematics"
    )
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())


class QuarantinedResult(Base):
    """An oracle result that failed the quality gate: kept for inspection, never appended."""

    __tablename__ = "quarantined_results"

    id: Mapped[int] = mapped_column(primary_key=True)
    oracle_run_id: Mapped[int] = mapped_column(sa.ForeignKey("oracle_runs.id", ondelete="CASCADE"), unique=True)
    campaign_id: Mapped[int | None] = mapped_column(sa.ForeignKey("campaigns.id", ondelete="CASCADE"), index=True)
    iteration_id: Mapped[int | None] = mapped_column(sa.ForeignKey("iterations.id", ondelete="CASCADE"))
    reason: Mapped[str] = mapped_column(sa.Text)
    gate: Mapped[dict[str, Any]] = mapped_column(default=dict, comment="quality-gate checks and their values")
    output_sha256: Mapped[str | None] = mapped_column(sa.ForeignKey("blobs.sha256", ondelete="RESTRICT"))
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())

    oracle_run: Mapped[OracleRun] = relationship()


class IterationMetrics(Base):
    """The paper's per-iteration numbers (model k on the unseen trajectory of iteration k)
    and the arrays to plot them (``curves_sha256``: t, q, qd, tau, f_true, f_pred)."""

    __tablename__ = "iteration_metrics"
    __table_args__ = (sa.UniqueConstraint("iteration_id"), sa.UniqueConstraint("campaign_id", "iteration_index"))

    id: Mapped[int] = mapped_column(primary_key=True)
    campaign_id: Mapped[int] = mapped_column(sa.ForeignKey("campaigns.id", ondelete="CASCADE"))
    iteration_id: Mapped[int] = mapped_column(sa.ForeignKey("iterations.id", ondelete="CASCADE"))
    iteration_index: Mapped[int] = mapped_column(comment="copy of iterations.index for cheap ?after=k queries")
    model_version_id: Mapped[int | None] = mapped_column(sa.ForeignKey("model_versions.id", ondelete="SET NULL"))
    dataset_id: Mapped[int | None] = mapped_column(sa.ForeignKey("datasets.id", ondelete="SET NULL"))
    force_rmse: Mapped[float | None] = mapped_column(sa.Float, comment="N")
    moment_rmse: Mapped[float | None] = mapped_column(sa.Float, comment="N m")
    force_rmse_contact: Mapped[float | None] = mapped_column(sa.Float, comment="N, samples in contact")
    moment_rmse_contact: Mapped[float | None] = mapped_column(sa.Float, comment="N m, samples in contact")
    calibration: Mapped[float | None] = mapped_column(sa.Float, comment="share of oracle values within mean +- 2 std")
    metrics_definition: Mapped[str] = mapped_column(
        sa.String(32),
        default="vector",
        server_default="vector",
        comment="vector: RMSE of the force/moment error vector (docs/concepts.md)",
    )
    force_max_error: Mapped[float | None] = mapped_column(sa.Float)
    moment_max_error: Mapped[float | None] = mapped_column(sa.Float)
    ocp_success: Mapped[bool | None]
    ocp_status: Mapped[str | None] = mapped_column(sa.String(64))
    ocp_iterations: Mapped[int | None]
    ocp_cost: Mapped[float | None] = mapped_column(sa.Float)
    ocp_wall_time_s: Mapped[float | None] = mapped_column(sa.Float)
    ocp_trusted: Mapped[bool | None] = mapped_column(
        comment="false: the OCP solution relies on force outside the data (ghost force, ensemble disagreement)"
    )
    ocp_trust: Mapped[dict[str, Any] | None] = mapped_column(
        comment="trust diagnostics of the OCP solution (alcove.science.surrogate.trust.TrustReport)"
    )
    oracle_wall_time_s: Mapped[float | None] = mapped_column(sa.Float)
    train_wall_time_s: Mapped[float | None] = mapped_column(sa.Float)
    n_pool_samples: Mapped[int | None] = mapped_column(sa.BigInteger)
    extra: Mapped[dict[str, Any]] = mapped_column(
        default=dict, comment="per-component errors, step timings, anything else"
    )
    curves_sha256: Mapped[str | None] = mapped_column(sa.ForeignKey("blobs.sha256", ondelete="RESTRICT"))
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())

    iteration: Mapped[Iteration] = relationship()


class OracleBatchJob(Base):
    """A batch-scheduler job that runs one oracle call (a command oracle whose launcher is a
    batch scheduler), kept with its oracle step: a later attempt of the step attaches to a job
    still queued, running or completed instead of submitting the call again."""

    __tablename__ = "oracle_batch_jobs"
    __table_args__ = (enum_check("state", BatchJobState), sa.Index("ix_oracle_batch_jobs_step_id", "step_id"))

    id: Mapped[int] = mapped_column(primary_key=True)
    step_id: Mapped[int] = mapped_column(sa.ForeignKey("iteration_steps.id", ondelete="CASCADE"))
    campaign_id: Mapped[int] = mapped_column(sa.ForeignKey("campaigns.id", ondelete="CASCADE"), index=True)
    attempt: Mapped[int] = mapped_column(comment="the step's attempt that submitted the job")
    scheduler: Mapped[str] = mapped_column(sa.String(16), comment="slurm | pbs | lsf")
    job_id: Mapped[str] = mapped_column(sa.String(64), comment="the scheduler's id of the job")
    state: Mapped[str] = mapped_column(sa.String(16))
    reason: Mapped[str | None] = mapped_column(sa.Text, comment="why the job failed or was cancelled")
    workdir: Mapped[str] = mapped_column(sa.Text, comment="the job folder (inputs, outputs, logs)")
    worker_name: Mapped[str | None] = mapped_column(sa.String(200), comment="the worker waiting for it")
    exit_code: Mapped[int | None]
    submitted_at: Mapped[datetime | None]
    started_at: Mapped[datetime | None]
    ended_at: Mapped[datetime | None]
    collected_at: Mapped[datetime | None] = mapped_column(comment="when its result was stored with the step")
    updated_at: Mapped[datetime] = mapped_column(default=utcnow, onupdate=utcnow, server_default=sa.func.now())
