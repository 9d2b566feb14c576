"""every pick of a batch iteration keeps its curves

Issue 17, what the user sees: ``iteration_candidates.curves_sha256`` (content-addressed arrays
t, q, qd, f_true, f_pred and, for an ensemble, f_std) holds the curves of each picked
trajectory, stored by ``evaluate`` beside the iteration's metrics row (which keeps the first
pick's). Existing rows keep NULL: their first pick's curves are the metrics row's; the others'
were not stored.

Revision ID: 0020
Revises: 0019
Create Date: 2026-12-03 07:00:00
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0020"
down_revision: str | Sequence[str] | None = "0019"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    with op.batch_alter_table("iteration_candidates") as batch:
        batch.add_column(
            sa.Column(
                "curves_sha256",
                sa.String(64),
                nullable=True,
                comment="a pick's curves: t, q, qd, f_true, f_pred (ensemble mean), f_std (K > 1)",
            )
        )
        batch.create_foreign_key(
            "fk_iteration_candidates_curves_sha256_blobs",
            "blobs",
            ["curves_sha256"],
            ["sha256"],
            ondelete="RESTRICT",
        )


def downgrade() -> None:
    with op.batch_alter_table("iteration_candidates") as batch:
        batch.drop_constraint("fk_iteration_candidates_curves_sha256_blobs", type_="foreignkey")
        batch.drop_column("curves_sha256")
