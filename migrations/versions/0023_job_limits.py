"""job limits: how much work a user may ask of the shared workers

``job_limits`` holds the members' default limits (the row without a user, inserted here) and
each user's own limits an administrator set (a NULL limit: no limit): campaigns running at once,
preliminary samples, OCP intervals per phase, ensemble size, hidden layers, layer width, epochs.
``campaigns.wait_reason`` says why a queued campaign waits before its first job is sent (its
owner runs as many campaigns as their limit allows).

Revision ID: 0023
Revises: 0022
Create Date: 2026-12-05 22:00:00
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0023"
down_revision: str | Sequence[str] | None = "0022"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

#: the defaults of every member (as alcove.models.limits.DEFAULT_JOB_LIMITS when this was written)
DEFAULTS = {
    "max_running_campaigns": 4,
    "max_preliminary_samples": 100_000,
    "max_ocp_intervals": 2_000,
    "max_ensemble_size": 16,
    "max_hidden_layers": 8,
    "max_layer_width": 512,
    "max_epochs": 10_000,
}
COMMENTS = {
    "max_running_campaigns": "campaigns running at once (more wait in 'queued' until one ends); NULL: no limit",
    "max_preliminary_samples": "preliminary.samples; NULL: no limit",
    "max_ocp_intervals": "DMOCC intervals per phase (settings.ocp_intervals, the task's, a preview's); NULL: no limit",
    "max_ensemble_size": "surrogate ensemble_size; NULL: no limit",
    "max_hidden_layers": "hidden layers of one net; NULL: no limit",
    "max_layer_width": "units of one hidden layer; NULL: no limit",
    "max_epochs": "max_epochs and warm_max_epochs; NULL: no limit",
}


def upgrade() -> None:
    limits = op.create_table(
        "job_limits",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("user_id", sa.Integer(), nullable=True, comment="NULL: the defaults of every member"),
        *(sa.Column(name, sa.Integer(), nullable=True, comment=COMMENTS[name]) for name in DEFAULTS),
        sa.Column("updated_at", sa.DateTime(timezone=True), server_default=sa.func.now(), nullable=False),
        sa.ForeignKeyConstraint(
            ["user_id"], ["users.id"], name=op.f("fk_job_limits_user_id_users"), ondelete="CASCADE"
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_job_limits")),
        sa.UniqueConstraint("user_id", name=op.f("uq_job_limits_user_id")),
    )
    op.bulk_insert(limits, [dict(DEFAULTS)])
    with op.batch_alter_table("campaigns") as batch:
        batch.add_column(
            sa.Column(
                "wait_reason",
                sa.Text(),
                nullable=True,
                comment="why a queued campaign waits before its first job is sent (its owner's running-campaigns "
                "limit); NULL: it does not wait",
            )
        )


def downgrade() -> None:
    with op.batch_alter_table("campaigns") as batch:
        batch.drop_column("wait_reason")
    op.drop_table("job_limits")
