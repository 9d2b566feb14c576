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


def test_0004_drops_fault_injection_from_stored_run_settings(tmp_path) -> None:
    """A campaign stored before 0004 carries ``fault_injection`` in its run settings: after
    the upgrade its config version validates against today's schema and keeps every other
    setting; a downgrade puts an empty ``fault_injection`` back."""
    from sqlalchemy.orm import Session

    from alcove.campaigns import presets, service
    from alcove.campaigns.schemas import CampaignCreate, RunSettings
    from alcove.campaigns.transitions import config_from_version
    from alcove.models import CampaignConfigVersion

    url = f"sqlite:///{tmp_path / 'm.db'}"
    migrate.upgrade(url, "head")
    eng = make_engine(url)
    with Session(eng) as s:
        u = presets.local_user(s)
        data = CampaignCreate(
            name="old",
            task_version_id=presets.task_version_from_preset(s, u.id, "head-headrest-2phase"),
            oracle_version_id=presets.oracle_version_for(s, u.id, "aux-penalty"),
            surrogate_config_version_id=presets.surrogate_config_version_for(s, u.id, None),
            settings=RunSettings(ocp_intervals=30),
        )
        service.create_campaign(s, u.id, data)
        s.commit()
    migrate.downgrade(url, "0003")
    ccv = sa.table("campaign_config_versions", sa.column("id", sa.Integer), sa.column("settings", sa.JSON))
    with eng.begin() as c:
        ((row_id, settings),) = c.execute(sa.select(ccv.c.id, ccv.c.settings)).all()
        assert settings["fault_injection"] == {}
        old = {**settings, "fault_injection": {"train": {"sleep_s": 2}}}
        c.execute(sa.update(ccv).where(ccv.c.id == row_id).values(settings=old))
    migrate.upgrade(url, "0004")
    with Session(eng) as s:
        row = s.get(CampaignConfigVersion, row_id)
        assert row.settings == {k: v for k, v in old.items() if k != "fault_injection"}
        assert config_from_version(row).settings.ocp_intervals == 30
    migrate.downgrade(url, "0003")
    with eng.connect() as c:
        (settings,) = c.execute(sa.select(ccv.c.settings).where(ccv.c.id == row_id)).one()
    assert settings["fault_injection"] == {} and settings["ocp_intervals"] == 30
    eng.dispose()
