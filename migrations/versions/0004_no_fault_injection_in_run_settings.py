"""run settings no longer carry fault injection

``RunSettings.fault_injection`` was a test hook in the public API; it is gone (tests inject
faults through ``ALCOVE_FAULT_PLAN`` in test processes only). Stored config versions drop
the key so that they validate against the settings schema again. Downgrade puts an empty
``fault_injection`` back (the faults themselves were test-only and are not restored).

Revision ID: 0004
Revises: 0003
Create Date: 2026-12-02 04:10:00
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import sqlalchemy as sa
from alembic import op
from sqlalchemy.dialects import postgresql

revision: str = "0004"
down_revision: str | Sequence[str] | None = "0003"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

KEY = "fault_injection"
JSON = sa.JSON().with_variant(postgresql.JSONB(), "postgresql")
versions = sa.table("campaign_config_versions", sa.column("id", sa.Integer), sa.column("settings", JSON))


def _rewrite(change: Any) -> None:
    conn = op.get_bind()
    for row_id, settings in conn.execute(sa.select(versions.c.id, versions.c.settings)).all():
        new = change(dict(settings or {}))
        if new is not None:
            conn.execute(sa.update(versions).where(versions.c.id == row_id).values(settings=new))


def upgrade() -> None:
    def drop(settings: dict[str, Any]) -> dict[str, Any] | None:
        if KEY not in settings:
            return None
        settings.pop(KEY)
        return settings

    _rewrite(drop)


def downgrade() -> None:
    def restore(settings: dict[str, Any]) -> dict[str, Any] | None:
        return None if KEY in settings else {**settings, KEY: {}}

    _rewrite(restore)
