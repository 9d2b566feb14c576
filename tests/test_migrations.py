"""Alembic is the only way the schema changes: migrations run up, down and up again on
both backends, and the migrated schema matches the models (``alembic check``)."""

from __future__ import annotations

import pytest
import sqlalchemy as sa

from alcove.db import make_engine, migrate
from alcove.models import Base


def _tables(url: str) -> set[str]:
    eng = make_engine(url)
    try:
        return set(sa.inspect(eng).get_table_names())
    finally:
        eng.dispose()


def _round_trip(url: str) -> None:
    assert migrate.current_revision(url) is None
    migrate.upgrade(url, "head")
    assert migrate.current_revision(url) == migrate.head_revision()
    assert set(Base.metadata.tables) <= _tables(url)
    assert migrate.schema_diff(url) == []
    migrate.downgrade(url, "base")
    assert migrate.current_revision(url) is None
    assert _tables(url) <= {"alembic_version"}
    migrate.upgrade(url, "head")
    assert migrate.schema_diff(url) == []


def test_sqlite_upgrade_downgrade_upgrade(tmp_path) -> None:
    _round_trip(f"sqlite:///{tmp_path / 'm.db'}")


@pytest.mark.integration
def test_postgresql_upgrade_downgrade_upgrade(empty_pg_url: str) -> None:
    _round_trip(empty_pg_url)


def test_single_head_and_linear_history() -> None:
    from alembic.script import ScriptDirectory

    script = ScriptDirectory.from_config(migrate.alembic_config())
    assert len(script.get_heads()) == 1, "multiple Alembic heads: merge them"


def test_sqlite_pragmas(tmp_path) -> None:
    eng = make_engine(f"sqlite:///{tmp_path / 'p.db'}")
    with eng.connect() as c:
        assert c.exec_driver_sql("PRAGMA journal_mode").scalar().lower() == "wal"
        assert c.exec_driver_sql("PRAGMA foreign_keys").scalar() == 1
        assert c.exec_driver_sql("PRAGMA busy_timeout").scalar() >= 5000
    eng.dispose()
