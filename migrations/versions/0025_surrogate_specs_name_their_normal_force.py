"""surrogate specs name their normal force: a stored spec without ``normal_force`` says "shared"

A surrogate config version stored before the option existed was trained and is meant with the
force net's hidden layers shared by fx and (fy, fz). The option's default is now "own", so
such a spec is given the value it always meant, and its ``spec_hash`` (SHA-256 of the spec's
canonical JSON) is recomputed. The downgrade leaves the explicit value: it means the same
to every revision.

Revision ID: 0025
Revises: 0024
Create Date: 2026-12-06 01:00:00
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from typing import Any

import sqlalchemy as sa
from alembic import op

revision: str = "0025"
down_revision: str | Sequence[str] | None = "0024"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

#: what a stored spec without the key was trained with
STORED_MEANING = "shared"


def _spec_hash(spec: Any) -> str:
    # alcove.models.definitions.spec_hash, spelled out: a migration does not import the models
    canonical = json.dumps(spec, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False)
    return hashlib.sha256(canonical.encode()).hexdigest()


def upgrade() -> None:
    versions = sa.table(
        "surrogate_config_versions",
        sa.column("id", sa.Integer),
        sa.column("spec", sa.JSON),
        sa.column("spec_hash", sa.String),
    )
    conn = op.get_bind()
    for row_id, spec in conn.execute(sa.select(versions.c.id, versions.c.spec)).all():
        if not isinstance(spec, dict) or "normal_force" in spec:
            continue
        named = {**spec, "normal_force": STORED_MEANING}
        conn.execute(sa.update(versions).where(versions.c.id == row_id).values(spec=named, spec_hash=_spec_hash(named)))


def downgrade() -> None:
    pass
