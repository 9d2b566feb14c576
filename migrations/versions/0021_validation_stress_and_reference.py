"""a validation suite's stress part is reported apart; its best-possible line

``validation_metrics.stress`` holds a model version's error on the motions of its suite's stress
part (force and moment RMSE, per component, calibration, sample count); the row's other figures
cover the core motions only. NULL: the suite has no stress part. ``validation_suites.reference`` holds the suite's
best-possible line (per oracle budget, the error of a model trained from scratch on that many of
the suite's reference replays); NULL: not computed (yet), or the suite has no reference motions.

Revision ID: 0021
Revises: 0020
Create Date: 2026-12-04 23:30:00
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op
from sqlalchemy.dialects import postgresql

revision: str = "0021"
down_revision: str | Sequence[str] | None = "0020"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

JSON = sa.JSON().with_variant(postgresql.JSONB(), "postgresql")


def upgrade() -> None:
    with op.batch_alter_table("validation_metrics") as batch:
        batch.add_column(
            sa.Column(
                "stress",
                JSON,
                nullable=True,
                comment="the error on the suite's stress part (force_rmse, moment_rmse, components, calibration, "
                "n_samples); null: no stress part",
            )
        )

    with op.batch_alter_table("validation_suites") as batch:
        batch.add_column(
            sa.Column(
                "reference",
                JSON,
                nullable=True,
                comment="the best-possible line (alcove.surrogates.reference_line): per oracle budget, the error of "
                "a model trained from scratch on that many reference replays; null: not computed (yet) or not "
                "asked for",
            )
        )


def downgrade() -> None:
    with op.batch_alter_table("validation_suites") as batch:
        batch.drop_column("reference")
    with op.batch_alter_table("validation_metrics") as batch:
        batch.drop_column("stress")
