"""iteration metrics record whether the OCP solution can be trusted

``iteration_metrics.ocp_trusted`` (false: the solution relies on force outside the data, a
ghost force with the gap open or ensemble disagreement in contact) and ``ocp_trust`` (the
diagnostics: ensemble force std in contact, predicted force with the gap open, distance to
the nearest pool sample; alcove.science.surrogate.trust). Stored iterations keep NULL: they
were not assessed, which is not the same as trusted.

Revision ID: 0010
Revises: 0008
Create Date: 2026-12-02 06:20:00
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op
from sqlalchemy.dialects import postgresql

revision: str = "0010"
down_revision: str | Sequence[str] | None = "0008"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

JSON = sa.JSON().with_variant(postgresql.JSONB(), "postgresql")


def upgrade() -> None:
    with op.batch_alter_table("iteration_metrics") as batch:
        batch.add_column(
            sa.Column(
                "ocp_trusted",
                sa.Boolean(),
                nullable=True,
                comment="false: the OCP solution relies on force outside the data (ghost force, ensemble disagreement)",
            )
        )
        batch.add_column(
            sa.Column(
                "ocp_trust",
                JSON,
                nullable=True,
                comment="trust diagnostics of the OCP solution (alcove.science.surrogate.trust.TrustReport)",
            )
        )


def downgrade() -> None:
    with op.batch_alter_table("iteration_metrics") as batch:
        batch.drop_column("ocp_trust")
        batch.drop_column("ocp_trusted")
