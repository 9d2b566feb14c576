"""oracle batch jobs: command oracles submitted to a batch scheduler

``command_oracles.launcher`` says where an entry's program runs (NULL: on the oracle worker;
else the batch scheduler and the job's resources). ``oracle_batch_jobs`` keeps each batch job
of an oracle call with its oracle step: its scheduler id, state and times, so that a worker
started again attaches to the jobs still running instead of submitting them again.

Revision ID: 0024
Revises: 0023
Create Date: 2026-12-05 23:00:00
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op
from sqlalchemy.dialects import postgresql

revision: str = "0024"
down_revision: str | Sequence[str] | None = "0023"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

STATES = ("queued", "running", "completed", "collected", "failed", "cancelled")


def upgrade() -> None:
    with op.batch_alter_table("command_oracles") as batch:
        batch.add_column(
            sa.Column(
                "launcher",
                sa.JSON().with_variant(postgresql.JSONB(), "postgresql"),
                nullable=True,
                comment="where the program runs: NULL on the oracle worker, else the batch scheduler and the job's "
                "resources",
            )
        )
    op.create_table(
        "oracle_batch_jobs",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("step_id", sa.Integer(), nullable=False),
        sa.Column("campaign_id", sa.Integer(), nullable=False),
        sa.Column("attempt", sa.Integer(), nullable=False, comment="the step's attempt that submitted the job"),
        sa.Column("scheduler", sa.String(length=16), nullable=False, comment="slurm | pbs | lsf"),
        sa.Column("job_id", sa.String(length=64), nullable=False, comment="the scheduler's id of the job"),
        sa.Column("state", sa.String(length=16), nullable=False),
        sa.Column("reason", sa.Text(), nullable=True, comment="why the job failed or was cancelled"),
        sa.Column("workdir", sa.Text(), nullable=False, comment="the job folder (inputs, outputs, logs)"),
        sa.Column("worker_name", sa.String(length=200), nullable=True, comment="the worker waiting for it"),
        sa.Column("exit_code", sa.Integer(), nullable=True),
        sa.Column("submitted_at", sa.DateTime(timezone=True), nullable=True),
        sa.Column("started_at", sa.DateTime(timezone=True), nullable=True),
        sa.Column("ended_at", sa.DateTime(timezone=True), nullable=True),
        sa.Column(
            "collected_at",
            sa.DateTime(timezone=True),
            nullable=True,
            comment="when its result was stored with the step",
        ),
        sa.Column("updated_at", sa.DateTime(timezone=True), server_default=sa.func.now(), nullable=False),
        sa.CheckConstraint(
            "state IN (" + ", ".join(f"'{s}'" for s in STATES) + ")", name=op.f("ck_oracle_batch_jobs_state_valid")
        ),
        sa.ForeignKeyConstraint(
            ["campaign_id"],
            ["campaigns.id"],
            name=op.f("fk_oracle_batch_jobs_campaign_id_campaigns"),
            ondelete="CASCADE",
        ),
        sa.ForeignKeyConstraint(
            ["step_id"],
            ["iteration_steps.id"],
            name=op.f("fk_oracle_batch_jobs_step_id_iteration_steps"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_oracle_batch_jobs")),
    )
    op.create_index("ix_oracle_batch_jobs_step_id", "oracle_batch_jobs", ["step_id"])
    op.create_index(op.f("ix_oracle_batch_jobs_campaign_id"), "oracle_batch_jobs", ["campaign_id"])


def downgrade() -> None:
    op.drop_index(op.f("ix_oracle_batch_jobs_campaign_id"), table_name="oracle_batch_jobs")
    op.drop_index("ix_oracle_batch_jobs_step_id", table_name="oracle_batch_jobs")
    op.drop_table("oracle_batch_jobs")
    with op.batch_alter_table("command_oracles") as batch:
        batch.drop_column("launcher")
