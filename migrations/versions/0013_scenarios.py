"""iterations store the scenario their OCP solved

``iterations.scenario`` (issue 17): with the ``random-scenarios`` strategy, the scenario drawn
for the iteration (campaign seed, iteration index, slot and the drawn parameter values; the
concrete task follows from the task version). Stored iterations keep NULL: they solved the task
as written, as every ``paper`` iteration does.

Revision ID: 0013
Revises: 0010
Create Date: 2026-12-02 13:20:00
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op
from sqlalchemy.dialects import postgresql

revision: str = "0013"
down_revision: str | Sequence[str] | None = "0010"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

JSON = sa.JSON().with_variant(postgresql.JSONB(), "postgresql")


def upgrade() -> None:
    with op.batch_alter_table("iterations") as batch:
        batch.add_column(
            sa.Column(
                "scenario",
                JSON,
                nullable=True,
                comment="the scenario the iteration's OCP solved (random-scenarios: seed, iteration, slot, values); "
                "null: the task as written",
            )
        )


def downgrade() -> None:
    with op.batch_alter_table("iterations") as batch:
        batch.drop_column("scenario")
