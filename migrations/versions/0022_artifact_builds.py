"""artifact builds: the model artifact zips a download needs, built by a worker

``artifact_builds`` holds one build of the zips (TorchScript, CasADi, ONNX) of some model versions
of a campaign, asked for by a download (``download_path``); a running build holds a build slot
(``slot``, unique), so no more than ``ALCOVE_ARTIFACT_BUILDS`` builds run at once.

Revision ID: 0022
Revises: 0021
Create Date: 2026-12-05 21:30:00
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op
from sqlalchemy.dialects import postgresql

revision: str = "0022"
down_revision: str | Sequence[str] | None = "0021"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    op.create_table(
        "artifact_builds",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("campaign_id", sa.Integer(), nullable=False),
        sa.Column("requested_by_id", sa.Integer(), nullable=True),
        sa.Column(
            "model_version_ids",
            sa.JSON().with_variant(postgresql.JSONB(), "postgresql"),
            nullable=False,
            comment="the model versions whose zips it builds",
        ),
        sa.Column("download_path", sa.String(length=500), nullable=False, comment="the download that waits for it"),
        sa.Column("status", sa.String(length=16), server_default="queued", nullable=False),
        sa.Column("models_total", sa.Integer(), server_default="0", nullable=False),
        sa.Column("models_done", sa.Integer(), server_default="0", nullable=False),
        sa.Column("slot", sa.Integer(), nullable=True, comment="the build slot a running build holds (NULL otherwise)"),
        sa.Column("error", sa.Text(), nullable=True),
        sa.Column("worker_name", sa.String(length=200), nullable=True),
        sa.Column("attempts", sa.Integer(), server_default="0", nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), server_default=sa.func.now(), nullable=False),
        sa.Column(
            "touched_at",
            sa.DateTime(timezone=True),
            server_default=sa.func.now(),
            nullable=False,
            comment="last sign of life: claimed, a zip built, or a worker found every build slot taken",
        ),
        sa.Column("started_at", sa.DateTime(timezone=True), nullable=True),
        sa.Column("finished_at", sa.DateTime(timezone=True), nullable=True),
        sa.CheckConstraint(
            "status IN ('queued', 'running', 'ready', 'failed')", name=op.f("ck_artifact_builds_status_valid")
        ),
        sa.ForeignKeyConstraint(
            ["campaign_id"], ["campaigns.id"], name=op.f("fk_artifact_builds_campaign_id_campaigns"), ondelete="CASCADE"
        ),
        sa.ForeignKeyConstraint(
            ["requested_by_id"],
            ["users.id"],
            name=op.f("fk_artifact_builds_requested_by_id_users"),
            ondelete="SET NULL",
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_artifact_builds")),
        sa.UniqueConstraint("slot", name=op.f("uq_artifact_builds_slot")),
    )
    with op.batch_alter_table("artifact_builds", schema=None) as batch_op:
        batch_op.create_index("ix_artifact_builds_campaign_id_status", ["campaign_id", "status"], unique=False)


def downgrade() -> None:
    with op.batch_alter_table("artifact_builds", schema=None) as batch_op:
        batch_op.drop_index("ix_artifact_builds_campaign_id_status")

    op.drop_table("artifact_builds")
