"""share invitations by e-mail

A share to an e-mail that no account has is kept as an invitation (``email`` set,
``user_id`` NULL) and given to the account created with that e-mail later, so that sharing
does not tell whether an address has an account.

Revision ID: 0003
Revises: 0002
Create Date: 2026-12-02 01:14:42.407888
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0003"
down_revision: str | Sequence[str] | None = "0002"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

OBJECT_COLUMNS = ("campaign_id", "oracle_definition_id", "surrogate_config_id", "task_definition_id")


def upgrade() -> None:
    with op.batch_alter_table("shares", schema=None) as batch_op:
        batch_op.add_column(
            sa.Column(
                "email",
                sa.String(length=320),
                nullable=True,
                comment="invited e-mail (lower-case) that no account has yet; else NULL",
            )
        )
        batch_op.alter_column(
            "user_id",
            existing_type=sa.INTEGER(),
            nullable=True,
            comment="grantee; NULL while an invitation",
            existing_comment="grantee",
        )
        batch_op.create_index(batch_op.f("ix_shares_email"), ["email"], unique=False)
        for column in OBJECT_COLUMNS:
            batch_op.create_unique_constraint(batch_op.f(f"uq_shares_email_{column}"), ["email", column])
        batch_op.create_check_constraint(
            batch_op.f("ck_shares_grantee_or_invited_email"), "(user_id IS NULL) <> (email IS NULL)"
        )


def downgrade() -> None:
    op.execute("DELETE FROM shares WHERE user_id IS NULL")  # open invitations cannot be kept
    with op.batch_alter_table("shares", schema=None) as batch_op:
        batch_op.drop_constraint(batch_op.f("ck_shares_grantee_or_invited_email"), type_="check")
        for column in reversed(OBJECT_COLUMNS):
            batch_op.drop_constraint(batch_op.f(f"uq_shares_email_{column}"), type_="unique")
        batch_op.drop_index(batch_op.f("ix_shares_email"))
        batch_op.alter_column(
            "user_id",
            existing_type=sa.INTEGER(),
            nullable=False,
            comment="grantee",
            existing_comment="grantee; NULL while an invitation",
        )
        batch_op.drop_column("email")
