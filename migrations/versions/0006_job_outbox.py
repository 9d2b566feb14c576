"""the job outbox: every job is recorded before it is sent

Revision ID: 0006
Revises: 0005
Create Date: 2026-12-02 05:30:00
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op
from sqlalchemy.dialects import postgresql

revision: str = "0006"
down_revision: str | Sequence[str] | None = "0005"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    op.create_table(
        "job_outbox",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("job_name", sa.String(length=100), nullable=False, comment="Celery job name, e.g. alcove.train.step"),
        sa.Column("queue", sa.String(length=32), nullable=False),
        sa.Column(
            "args",
            sa.JSON().with_variant(postgresql.JSONB(), "postgresql"),
            nullable=False,
            comment="the message's positional arguments (JSON)",
        ),
        sa.Column("message_id", sa.String(length=100), nullable=False, comment="the Celery task id it is sent as"),
        sa.Column(
            "subject",
            sa.String(length=100),
            nullable=False,
            comment="what it runs, e.g. preview/12 or campaign/3/k2/train",
        ),
        sa.Column("created_at", sa.DateTime(timezone=True), server_default=sa.func.now(), nullable=False),
        sa.Column(
            "sent_at",
            sa.DateTime(timezone=True),
            nullable=True,
            comment="last handed to the broker; NULL: waiting for it",
        ),
        sa.Column(
            "sent_to",
            sa.String(length=64),
            nullable=True,
            comment="the broker incarnation it was sent to (Redis run_id); another one lost it",
        ),
        sa.Column("send_count", sa.Integer(), server_default="0", nullable=False),
        sa.Column("last_error", sa.Text(), nullable=True, comment="why the last send failed"),
        sa.Column("delivered_at", sa.DateTime(timezone=True), nullable=True, comment="a worker started the job"),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_job_outbox")),
        sa.UniqueConstraint("message_id", name=op.f("uq_job_outbox_message_id")),
    )
    op.create_index("ix_job_outbox_delivered_at_sent_at", "job_outbox", ["delivered_at", "sent_at"], unique=False)
    op.create_index(op.f("ix_job_outbox_subject"), "job_outbox", ["subject"], unique=False)


def downgrade() -> None:
    op.drop_index(op.f("ix_job_outbox_subject"), table_name="job_outbox")
    op.drop_index("ix_job_outbox_delivered_at_sent_at", table_name="job_outbox")
    op.drop_table("job_outbox")
