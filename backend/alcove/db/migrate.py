"""Run Alembic programmatically (used by ``alcove db ...``, ``alcove up`` and tests)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from alembic import command
from alembic.config import Config
from alembic.runtime.migration import MigrationContext
from alembic.script import ScriptDirectory

import alcove


def migrations_dir() -> Path:
    """``migrations/`` at the repository root (override with ``ALCOVE_MIGRATIONS_DIR``)."""
    env = os.environ.get("ALCOVE_MIGRATIONS_DIR")
    if env:
        return Path(env)
    d = Path(alcove.__file__).resolve().parents[2] / "migrations"
    if not (d / "env.py").exists():
        raise RuntimeError(f"Alembic migrations not found at {d}; set ALCOVE_MIGRATIONS_DIR")
    return d


def alembic_config(url: str | None = None) -> Config:
    ini = migrations_dir().parent / "alembic.ini"
    cfg = Config(str(ini)) if ini.exists() else Config()
    cfg.set_main_option("script_location", str(migrations_dir()))
    cfg.attributes["configure_logger"] = False
    if url:
        cfg.attributes["url"] = url
    return cfg


def _url(url: str | None) -> str:
    if url:
        return url
    from alcove.settings import get_settings

    return get_settings().database_url


def upgrade(url: str | None = None, revision: str = "head") -> None:
    command.upgrade(alembic_config(_url(url)), revision)


def downgrade(url: str | None = None, revision: str = "-1") -> None:
    command.downgrade(alembic_config(_url(url)), revision)


def head_revision() -> str | None:
    return ScriptDirectory.from_config(alembic_config()).get_current_head()


def current_revision(url: str | None = None) -> str | None:
    from alcove.db.engine import make_engine

    engine = make_engine(_url(url))
    try:
        with engine.connect() as conn:
            return MigrationContext.configure(conn).get_current_revision()
    finally:
        engine.dispose()


def is_up_to_date(url: str | None = None) -> bool:
    return current_revision(url) == head_revision()


def schema_diff(url: str | None = None) -> list[Any]:
    """Differences between the models and the migrated database (empty = they agree)."""
    from alembic.autogenerate import compare_metadata

    from alcove.db.engine import make_engine
    from alcove.models import Base

    engine = make_engine(_url(url))
    try:
        with engine.connect() as conn:
            mc = MigrationContext.configure(
                conn, opts={"compare_type": True, "compare_server_default": False, "render_as_batch": True}
            )
            diffs: list[Any] = compare_metadata(mc, Base.metadata)  # typed Any: a list of diff tuples (or lists)
            return diffs
    finally:
        engine.dispose()
