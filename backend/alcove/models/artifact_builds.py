"""Artifact builds: the model artifact zips (TorchScript, CasADi and ONNX exports) a download
needs, built by a worker on queue ``artifacts`` (never in the API process), at most
``ALCOVE_ARTIFACT_BUILDS`` at once across all workers."""

from __future__ import annotations

import enum
from datetime import datetime
from typing import Any

import sqlalchemy as sa
from sqlalchemy.orm import Mapped, mapped_column

from alcove.models.base import Base, enum_check, utcnow


class ArtifactBuildStatus(str, enum.Enum):
    queued = "queued"  # committed; its job is sent after the commit (or waits for a free build slot)
    running = "running"  # a worker holds a build slot and runs the build's child process
    ready = "ready"  # every zip is in the artifacts folder: the download answers 200
    failed = "failed"


class ArtifactBuild(Base):
    """One build of the artifact zips of some model versions of a campaign, asked for by a
    download (``download_path``: the request to repeat once the build is ready). A worker claims
    the row together with a build slot (``slot``, unique while held), so a duplicate delivery
    of the job does nothing and no more than ``ALCOVE_ARTIFACT_BUILDS`` run at once."""

    __tablename__ = "artifact_builds"
    __table_args__ = (
        enum_check("status", ArtifactBuildStatus),
        sa.UniqueConstraint("slot"),
        sa.Index("ix_artifact_builds_campaign_id_status", "campaign_id", "status"),
    )

    id: Mapped[int] = mapped_column(primary_key=True)
    campaign_id: Mapped[int] = mapped_column(sa.ForeignKey("campaigns.id", ondelete="CASCADE"))
    requested_by_id: Mapped[int | None] = mapped_column(sa.ForeignKey("users.id", ondelete="SET NULL"))
    model_version_ids: Mapped[list[Any]] = mapped_column(comment="the model versions whose zips it builds")
    download_path: Mapped[str] = mapped_column(sa.String(500), comment="the download that waits for it")
    status: Mapped[str] = mapped_column(
        sa.String(16), default=ArtifactBuildStatus.queued.value, server_default=ArtifactBuildStatus.queued.value
    )
    models_total: Mapped[int] = mapped_column(default=0, server_default="0")
    models_done: Mapped[int] = mapped_column(default=0, server_default="0")
    slot: Mapped[int | None] = mapped_column(comment="the build slot a running build holds (NULL otherwise)")
    error: Mapped[str | None] = mapped_column(sa.Text)
    worker_name: Mapped[str | None] = mapped_column(sa.String(200))
    attempts: Mapped[int] = mapped_column(default=0, server_default="0")
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())
    touched_at: Mapped[datetime] = mapped_column(
        default=utcnow,
        server_default=sa.func.now(),
        comment="last sign of life: claimed, a zip built, or a worker found every build slot taken",
    )
    started_at: Mapped[datetime | None]
    finished_at: Mapped[datetime | None]
