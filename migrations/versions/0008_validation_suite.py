"""held-out validation suite: suites, motions, per-model-version metrics, dataset origin "validation"

A suite is shared per (oracle version, suite spec): ``validation_suites`` with its motions
(``validation_motions``, each an oracle job with its claim state); ``validation_metrics`` is
one row per model version (its generalisation error); ``campaigns.validation_suite_id``
names the suite a campaign's models are evaluated on. Datasets may now have origin
``validation`` (never members of a pool version).

Revision ID: 0008
Revises: 0007
Create Date: 2026-12-02 05:40:00
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op
from sqlalchemy.dialects import postgresql

revision: str = "0008"
down_revision: str | Sequence[str] | None = "0007"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

JSON = sa.JSON().with_variant(postgresql.JSONB(), "postgresql")
TS = sa.DateTime(timezone=True)
ORIGINS_OLD = "origin IN ('preliminary', 'oracle', 'upload')"
ORIGINS_NEW = "origin IN ('preliminary', 'oracle', 'upload', 'validation')"


def upgrade() -> None:
    op.create_table(
        "validation_suites",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("oracle_version_id", sa.Integer(), nullable=False),
        sa.Column(
            "spec_hash", sa.String(length=64), nullable=False, comment="sha256 of the suite spec and the model preset"
        ),
        sa.Column("spec", JSON, nullable=False, comment="motions, seed, dt, ranges (alcove.science.validation_suite)"),
        sa.Column("preset", JSON, nullable=False, comment="the model preset the motions are drawn for"),
        sa.Column("n_motions", sa.Integer(), nullable=False),
        sa.Column("status", sa.String(length=16), server_default="replaying", nullable=False),
        sa.Column("error", sa.Text(), nullable=True),
        sa.Column("replay_wall_time_s", sa.Float(), nullable=True, comment="first motion queued to last motion stored"),
        sa.Column("created_at", TS, server_default=sa.func.now(), nullable=False),
        sa.Column("completed_at", TS, nullable=True),
        sa.CheckConstraint(
            "status IN ('replaying', 'complete', 'failed')", name=op.f("ck_validation_suites_status_valid")
        ),
        sa.ForeignKeyConstraint(
            ["oracle_version_id"],
            ["oracle_versions.id"],
            name=op.f("fk_validation_suites_oracle_version_id_oracle_versions"),
            ondelete="RESTRICT",
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_validation_suites")),
        sa.UniqueConstraint(
            "oracle_version_id", "spec_hash", name=op.f("uq_validation_suites_oracle_version_id_spec_hash")
        ),
    )
    op.create_table(
        "validation_motions",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("suite_id", sa.Integer(), nullable=False),
        sa.Column("index", sa.Integer(), nullable=False),
        sa.Column("params", JSON, nullable=False, comment="start, depth, speed, dwell"),
        sa.Column("status", sa.String(length=16), server_default="queued", nullable=False),
        sa.Column("attempts", sa.Integer(), server_default="0", nullable=False),
        sa.Column("max_attempts", sa.Integer(), server_default="3", nullable=False),
        sa.Column("claim_token", sa.String(length=64), nullable=True),
        sa.Column("lease_until", TS, nullable=True),
        sa.Column("worker_name", sa.String(length=200), nullable=True),
        sa.Column("queued_at", TS, nullable=True),
        sa.Column("started_at", TS, nullable=True),
        sa.Column("finished_at", TS, nullable=True),
        sa.Column("wall_time_s", sa.Float(), nullable=True, comment="the oracle's wall time"),
        sa.Column("error", sa.Text(), nullable=True),
        sa.Column("dataset_id", sa.Integer(), nullable=True),
        sa.CheckConstraint(
            "status IN ('queued', 'running', 'succeeded', 'failed')", name=op.f("ck_validation_motions_status_valid")
        ),
        sa.ForeignKeyConstraint(
            ["dataset_id"], ["datasets.id"], name=op.f("fk_validation_motions_dataset_id_datasets"), ondelete="RESTRICT"
        ),
        sa.ForeignKeyConstraint(
            ["suite_id"],
            ["validation_suites.id"],
            name=op.f("fk_validation_motions_suite_id_validation_suites"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_validation_motions")),
        sa.UniqueConstraint("dataset_id", name=op.f("uq_validation_motions_dataset_id")),
        sa.UniqueConstraint("suite_id", "index", name=op.f("uq_validation_motions_suite_id_index")),
    )
    op.create_index(op.f("ix_validation_motions_suite_id"), "validation_motions", ["suite_id"], unique=False)
    op.create_table(
        "validation_metrics",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("model_version_id", sa.Integer(), nullable=False),
        sa.Column("suite_id", sa.Integer(), nullable=False),
        sa.Column(
            "force_rmse", sa.Float(), nullable=False, comment="N: sqrt(mean |F_pred - F_true|^2) over all samples"
        ),
        sa.Column("moment_rmse", sa.Float(), nullable=False, comment="N m: the same for the moment vector"),
        sa.Column("components", JSON, nullable=False, comment="RMSE per component fx..mz"),
        sa.Column("per_motion", JSON, nullable=False, comment="force and moment RMSE per motion, in suite order"),
        sa.Column("n_samples", sa.Integer(), nullable=False),
        sa.Column("created_at", TS, server_default=sa.func.now(), nullable=False),
        sa.ForeignKeyConstraint(
            ["model_version_id"],
            ["model_versions.id"],
            name=op.f("fk_validation_metrics_model_version_id_model_versions"),
            ondelete="CASCADE",
        ),
        sa.ForeignKeyConstraint(
            ["suite_id"],
            ["validation_suites.id"],
            name=op.f("fk_validation_metrics_suite_id_validation_suites"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_validation_metrics")),
        sa.UniqueConstraint("model_version_id", name=op.f("uq_validation_metrics_model_version_id")),
    )
    op.create_index(op.f("ix_validation_metrics_suite_id"), "validation_metrics", ["suite_id"], unique=False)
    with op.batch_alter_table("campaigns") as batch_op:
        batch_op.add_column(
            sa.Column(
                "validation_suite_id",
                sa.Integer(),
                nullable=True,
                comment="the held-out validation suite its model versions are evaluated on (shared)",
            )
        )
        batch_op.create_index(batch_op.f("ix_campaigns_validation_suite_id"), ["validation_suite_id"], unique=False)
        batch_op.create_foreign_key(
            batch_op.f("fk_campaigns_validation_suite_id_validation_suites"),
            "validation_suites",
            ["validation_suite_id"],
            ["id"],
            ondelete="SET NULL",
        )
    with op.batch_alter_table("datasets") as batch_op:
        batch_op.drop_constraint(batch_op.f("ck_datasets_origin_valid"), type_="check")
        batch_op.create_check_constraint(batch_op.f("ck_datasets_origin_valid"), ORIGINS_NEW)


def downgrade() -> None:
    conn = op.get_bind()
    conn.execute(sa.text("UPDATE campaigns SET validation_suite_id = NULL"))
    op.drop_index(op.f("ix_validation_metrics_suite_id"), table_name="validation_metrics")
    op.drop_table("validation_metrics")
    conn.execute(sa.text("UPDATE validation_motions SET dataset_id = NULL"))
    conn.execute(sa.text("DELETE FROM datasets WHERE origin = 'validation'"))
    with op.batch_alter_table("datasets") as batch_op:
        batch_op.drop_constraint(batch_op.f("ck_datasets_origin_valid"), type_="check")
        batch_op.create_check_constraint(batch_op.f("ck_datasets_origin_valid"), ORIGINS_OLD)
    with op.batch_alter_table("campaigns") as batch_op:
        batch_op.drop_constraint(batch_op.f("fk_campaigns_validation_suite_id_validation_suites"), type_="foreignkey")
        batch_op.drop_index(batch_op.f("ix_campaigns_validation_suite_id"))
        batch_op.drop_column("validation_suite_id")
    op.drop_index(op.f("ix_validation_motions_suite_id"), table_name="validation_motions")
    op.drop_table("validation_motions")
    op.drop_table("validation_suites")
