"""batch acquisition: parallel slots of a step and the iteration's candidates

Issue 17, batch increment: an iteration fans out into several ``ocp`` jobs (one per candidate
scenario) and several ``oracle`` jobs (one per pick) and fans back in.

* ``iteration_steps.slot`` (0 for every existing step): which of the iteration's parallel jobs
  of a step a row is; unique ``(iteration_id, step, slot)`` replaces ``(iteration_id, step)``;
* ``ocp_solutions.slot`` and ``oracle_runs.slot`` (0 for existing rows): unique
  ``(iteration_id, slot, attempt)`` replaces ``(iteration_id, attempt)``;
* ``iteration_candidates``: per iteration, the scenarios its OCP solved, their scores, which
  were picked (the oracle slot), and each pick's oracle run, dataset and in-loop RMSE.

Existing rows need no data moved (their slot is 0 and they have no candidate rows; an iteration
without candidate rows is read as the paper's single trajectory).

Revision ID: 0018
Revises: 0013
Create Date: 2026-12-02 16:30:00
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op
from sqlalchemy.dialects import postgresql

revision: str = "0018"
down_revision: str | Sequence[str] | None = "0013"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

JSON = sa.JSON().with_variant(postgresql.JSONB(), "postgresql")

_SLOT = {
    "iteration_steps": (
        "which of the iteration's parallel jobs of this step (ocp: the candidate, oracle: the pick); 0 for the rest",
        ("iteration_id", "step"),
        ("iteration_id", "step", "slot"),
    ),
    "ocp_solutions": (
        "the iteration's ocp slot (candidate)",
        ("iteration_id", "attempt"),
        ("iteration_id", "slot", "attempt"),
    ),
    "oracle_runs": (
        "the iteration's oracle slot (pick)",
        ("iteration_id", "attempt"),
        ("iteration_id", "slot", "attempt"),
    ),
}


def _uq(table: str, cols: Sequence[str]) -> str:
    return f"uq_{table}_{'_'.join(cols)}"


def upgrade() -> None:
    for table, (comment, old, new) in _SLOT.items():
        with op.batch_alter_table(table) as batch:
            batch.add_column(sa.Column("slot", sa.Integer(), nullable=False, server_default="0", comment=comment))
            batch.drop_constraint(_uq(table, old), type_="unique")
            batch.create_unique_constraint(_uq(table, new), list(new))
    op.create_table(
        "iteration_candidates",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("iteration_id", sa.Integer(), nullable=False),
        sa.Column("slot", sa.Integer(), nullable=False, comment="the ocp slot that solved it"),
        sa.Column("scenario", JSON, nullable=True, comment="seed, iteration, slot, values; null: the task"),
        sa.Column("ocp_solution_id", sa.Integer(), nullable=True),
        sa.Column("converged", sa.Boolean(), nullable=True),
        sa.Column(
            "score",
            sa.Float(),
            nullable=True,
            comment="ensemble disagreement over the contact phase [N] (ensemble-disagreement)",
        ),
        sa.Column("features", JSON, nullable=True, comment="the point in feature space the diversity rule uses"),
        sa.Column("pick", sa.Integer(), nullable=True, comment="the oracle slot that replays it; null: not picked"),
        sa.Column("pick_reason", sa.Text(), nullable=True),
        sa.Column("oracle_run_id", sa.Integer(), nullable=True),
        sa.Column("dataset_id", sa.Integer(), nullable=True),
        sa.Column("force_rmse", sa.Float(), nullable=True, comment="in-loop force RMSE on its oracle data [N]"),
        sa.Column("moment_rmse", sa.Float(), nullable=True),
        sa.ForeignKeyConstraint(
            ["iteration_id"],
            ["iterations.id"],
            name=op.f("fk_iteration_candidates_iteration_id_iterations"),
            ondelete="CASCADE",
        ),
        sa.ForeignKeyConstraint(
            ["ocp_solution_id"],
            ["ocp_solutions.id"],
            name=op.f("fk_iteration_candidates_ocp_solution_id_ocp_solutions"),
            ondelete="SET NULL",
        ),
        sa.ForeignKeyConstraint(
            ["oracle_run_id"],
            ["oracle_runs.id"],
            name=op.f("fk_iteration_candidates_oracle_run_id_oracle_runs"),
            ondelete="SET NULL",
        ),
        sa.ForeignKeyConstraint(
            ["dataset_id"],
            ["datasets.id"],
            name=op.f("fk_iteration_candidates_dataset_id_datasets"),
            ondelete="SET NULL",
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_iteration_candidates")),
        sa.UniqueConstraint("iteration_id", "slot", name=op.f("uq_iteration_candidates_iteration_id_slot")),
        sa.UniqueConstraint("iteration_id", "pick", name=op.f("uq_iteration_candidates_iteration_id_pick")),
    )
    op.create_index(
        op.f("ix_iteration_candidates_iteration_id"), "iteration_candidates", ["iteration_id"], unique=False
    )


def downgrade() -> None:
    op.drop_index(op.f("ix_iteration_candidates_iteration_id"), table_name="iteration_candidates")
    op.drop_table("iteration_candidates")
    for table, (_, old, new) in _SLOT.items():
        with op.batch_alter_table(table) as batch:
            batch.drop_constraint(_uq(table, new), type_="unique")
            batch.create_unique_constraint(_uq(table, old), list(old))
            batch.drop_column("slot")
