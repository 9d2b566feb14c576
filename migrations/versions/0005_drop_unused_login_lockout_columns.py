"""users: drop the unused login-lockout columns

``users.failed_login_count`` and ``users.locked_until`` held the old per-account lockout
(five wrong passwords locked the account for everyone for five minutes). Login throttling
is now per (e-mail as typed, client address) with growing delays, kept in Redis or process
memory (:mod:`alcove.users.ratelimit`), so that unknown e-mails are throttled exactly like
existing ones and a failed login writes nothing to the database. Nothing reads or writes
the columns any more. Downgrade puts them back empty (no account locked).

Revision ID: 0005
Revises: 0004
Create Date: 2026-12-02 05:30:00
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0005"
down_revision: str | Sequence[str] | None = "0004"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    with op.batch_alter_table("users") as batch:  # SQLite rebuilds the table
        batch.drop_column("locked_until")
        batch.drop_column("failed_login_count")


def downgrade() -> None:
    with op.batch_alter_table("users") as batch:
        batch.add_column(sa.Column("failed_login_count", sa.Integer(), server_default="0", nullable=False))
        comment = "login lockout after repeated failures"
        batch.add_column(sa.Column("locked_until", sa.DateTime(timezone=True), nullable=True, comment=comment))
