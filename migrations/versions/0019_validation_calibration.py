"""validation suite calibration: the ensemble's calibration per model version on the held-out suite

``validation_metrics.calibration``: the fraction of oracle values inside the ensemble mean +- 2 std
over all samples of all motions (docs/concepts.md, Metrics), null for a single model (K = 1,
no spread). ``validation_metrics.calibration_recorded`` tells the two nulls apart: rows evaluated
before this migration never computed it, so they get ``false`` (not recorded; their null does not
mean K = 1) and are not silently mixed with new rows, which get ``true``. Recomputing them would
need every model version's weights and the suite's replays: re-evaluate instead (delete the row and
let ``alcove.default.validation_evaluate`` write it again).

Revision ID: 0019
Revises: 0018
Create Date: 2026-12-03 07:10:00
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0019"
down_revision: str | Sequence[str] | None = "0018"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

_RECORDED = "false: evaluated before migration 0019, when the calibration was not computed (null, not 'K = 1')"


def upgrade() -> None:
    with op.batch_alter_table("validation_metrics") as batch:
        batch.add_column(
            sa.Column(
                "calibration",
                sa.Float(),
                nullable=True,
                comment="share of oracle values within mean +- 2 std; null for K = 1 or when not recorded",
            )
        )
        # existing rows: not recorded
        batch.add_column(
            sa.Column(
                "calibration_recorded", sa.Boolean(), nullable=False, server_default=sa.false(), comment=_RECORDED
            )
        )
    with op.batch_alter_table("validation_metrics") as batch:
        # new rows: recorded
        batch.alter_column(
            "calibration_recorded", existing_type=sa.Boolean(), server_default=sa.true(), existing_comment=_RECORDED
        )


def downgrade() -> None:
    with op.batch_alter_table("validation_metrics") as batch:
        batch.drop_column("calibration_recorded")
        batch.drop_column("calibration")
