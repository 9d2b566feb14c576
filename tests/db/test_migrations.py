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


def old_campaign_data(s, user_id: int, **fields):
    """A paper campaign's create body (aux-penalty, the default surrogate) named "old"."""
    from alcove.campaigns import presets
    from alcove.campaigns.schemas import CampaignCreate

    return CampaignCreate(
        name="old",
        task_version_id=presets.task_version_from_preset(s, user_id, "head-headrest-2phase"),
        oracle_version_id=presets.oracle_version_for(s, user_id, "aux-penalty"),
        surrogate_config_version_id=presets.surrogate_config_version_for(s, user_id, None),
        **fields,
    )


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
    from alcove.campaigns.config import RunSettings, config_from_version
    from alcove.models import CampaignConfigVersion

    url = f"sqlite:///{tmp_path / 'm.db'}"
    migrate.upgrade(url, "head")
    eng = make_engine(url)
    with Session(eng) as s:
        u = presets.local_user(s)
        data = old_campaign_data(s, u.id, settings=RunSettings(ocp_intervals=30))
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


def test_0007_converts_stored_rmse_to_the_error_vector_definition(tmp_path) -> None:
    """Before 0007 the force RMSE averaged the squared error over fx, fy, fz: a stored value is
    sqrt(3) times smaller than the error vector's RMSE. The upgrade converts iteration metrics,
    model test RMSEs and stopping-rule targets (so a campaign stops where it did), recomputes the
    in-contact RMSE from the stored curves; the downgrade converts back."""
    import math

    import numpy as np
    from sqlalchemy.orm import Session

    from alcove.campaigns import presets, service
    from alcove.campaigns.config import StoppingRules
    from alcove.db.arrays import put_arrays
    from alcove.models import CampaignConfigVersion, Iteration, IterationMetrics

    url = f"sqlite:///{tmp_path / 'm.db'}"
    migrate.upgrade(url, "head")
    eng = make_engine(url)
    # two samples: in contact with error (3, 0, 4) and moment error (0, 2, 0); out of contact, exact
    f_true = np.array([[10.0, 0, 20, 0, 1, 0], [0, 0, 0, 0, 0, 0]])
    f_pred = np.array([[13.0, 0, 24, 0, 3, 0], [0, 0, 0, 0, 0, 0]])
    old_force, old_moment = math.sqrt(25 / 6), math.sqrt(4 / 6)  # the component-mean definition
    with Session(eng) as s:
        u = presets.local_user(s)
        data = old_campaign_data(s, u.id, stopping=StoppingRules(max_iterations=5, target_force_rmse=2.0))
        c = service.create_campaign(s, u.id, data)
        s.flush()
        ccv = s.scalars(sa.select(CampaignConfigVersion)).one()
        it = Iteration(campaign_id=c.id, index=1, config_version_id=ccv.id, status="succeeded")
        s.add(it)
        s.flush()
        curves = put_arrays(s, {"t": np.arange(2.0), "f_true": f_true, "f_pred": f_pred})
        s.add(
            IterationMetrics(
                campaign_id=c.id,
                iteration_id=it.id,
                iteration_index=1,
                force_rmse=old_force,
                moment_rmse=old_moment,
                extra={"model_test_rmse": {"force": 1.0, "moment": None}},
                curves_sha256=curves,
            )
        )
        s.commit()
    migrate.downgrade(url, "0004")
    metrics = sa.table(
        "iteration_metrics",
        sa.column("force_rmse", sa.Float),
        sa.column("moment_rmse", sa.Float),
        sa.column("extra", sa.JSON),
    )
    rules = sa.table("campaign_config_versions", sa.column("stopping_rules", sa.JSON))
    with eng.begin() as conn:  # the values as an old release stored them
        old_extra = {"model_test_rmse": {"force": 1.0, "moment": None}}
        conn.execute(sa.update(metrics).values(force_rmse=old_force, moment_rmse=old_moment, extra=old_extra))
        conn.execute(sa.update(rules).values(stopping_rules={"max_iterations": 5, "target_force_rmse": 2.0}))
    migrate.upgrade(url, "head")
    with Session(eng) as s:
        m = s.scalars(sa.select(IterationMetrics)).one()
        # threshold: float rounding of the conversion; hand-computed: sqrt(25 / 2), sqrt(4 / 2)
        assert m.force_rmse == pytest.approx(math.sqrt(12.5), rel=1e-14)
        assert m.moment_rmse == pytest.approx(math.sqrt(2.0), rel=1e-14)
        assert m.force_rmse_contact == pytest.approx(5.0, rel=1e-14)  # the one sample in contact
        assert m.moment_rmse_contact == pytest.approx(2.0, rel=1e-14)
        assert m.calibration is None and m.metrics_definition == "vector"
        assert m.extra["model_test_rmse"] == {"force": pytest.approx(math.sqrt(3)), "moment": None}
        stored = s.scalars(sa.select(CampaignConfigVersion)).one().stopping_rules
        assert stored["target_force_rmse"] == pytest.approx(2.0 * math.sqrt(3)) and stored["max_iterations"] == 5
    migrate.downgrade(url, "0004")
    with eng.connect() as conn:
        (frmse, mrmse) = conn.execute(sa.select(metrics.c.force_rmse, metrics.c.moment_rmse)).one()
        (back,) = conn.execute(sa.select(rules.c.stopping_rules)).one()
    assert frmse == pytest.approx(old_force, rel=1e-14) and mrmse == pytest.approx(old_moment, rel=1e-14)
    assert back["target_force_rmse"] == pytest.approx(2.0, rel=1e-14)
    eng.dispose()


def test_0019_marks_earlier_validation_rows_as_calibration_not_recorded(tmp_path) -> None:
    """A validation-suite evaluation stored before 0019 never computed the calibration: after the
    upgrade its calibration is null with ``calibration_recorded`` false (not mistaken for a single
    model's null, which is recorded); a row written afterwards is recorded by default."""
    import numpy as np
    from sqlalchemy.orm import Session

    from alcove import models as m
    from alcove.campaigns import presets, service
    from alcove.db import arrays

    url = f"sqlite:///{tmp_path / 'm.db'}"
    migrate.upgrade(url, "head")
    eng = make_engine(url)
    with Session(eng) as s:
        u = presets.local_user(s)
        data = old_campaign_data(s, u.id)
        c = service.create_campaign(s, u.id, data)
        s.flush()
        it = m.Iteration(campaign_id=c.id, index=0, config_version_id=c.config_versions[0].id)
        s.add(it)
        s.flush()
        pv = m.PoolVersion(campaign_id=c.id, iteration_id=it.id, version=0, content_hash="0" * 64)
        s.add(pv)
        s.flush()
        w = arrays.put_arrays(s, {"W0": np.zeros((6, 19))})
        common = {"campaign_id": c.id, "pool_version_id": pv.id, "seed": 1, "architecture": {}, "normalisation": {}}
        common.update(weights_sha256=w, code_version="0", library_versions={})
        mv_ids = []
        for k in (1, 2):
            mv = m.ModelVersion(version=k, **common)
            s.add(mv)
            s.flush()
            mv_ids.append(mv.id)
        suite = m.ValidationSuite(
            oracle_version_id=data.oracle_version_id, spec_hash="0" * 64, spec={}, preset={}, n_motions=1
        )
        s.add(suite)
        s.commit()
        suite_id = suite.id
    migrate.downgrade(url, "0018")
    row = {
        "suite_id": suite_id,
        "force_rmse": 2.5,
        "moment_rmse": 0.5,
        "components": {},
        "per_motion": [],
        "n_samples": 10,
    }
    vm = sa.table(
        "validation_metrics",
        *(sa.column(k) for k in ("model_version_id", "suite_id", "force_rmse", "moment_rmse", "n_samples")),
        sa.column("components", sa.JSON),
        sa.column("per_motion", sa.JSON),
    )
    with eng.begin() as conn:
        conn.execute(sa.insert(vm).values(model_version_id=mv_ids[0], **row))
    migrate.upgrade(url, "head")
    with Session(eng) as s:
        s.add(m.ValidationMetrics(model_version_id=mv_ids[1], **row))  # today's writer (K = 1: null, recorded)
        s.commit()
        got = s.execute(
            sa.select(m.ValidationMetrics.model_version_id, m.ValidationMetrics.calibration_recorded).order_by(
                m.ValidationMetrics.model_version_id
            )
        ).all()
    eng.dispose()
    assert [tuple(r) for r in got] == [(mv_ids[0], False), (mv_ids[1], True)]


def test_0025_names_the_shared_normal_force_in_stored_surrogate_specs(tmp_path) -> None:
    """A surrogate spec stored without ``normal_force`` meant the shared net; the default is now
    "own", so the upgrade writes "shared" into it (and its spec_hash follows the spec); a spec
    that names its normal force is left as it is."""
    from sqlalchemy.orm import Session

    from alcove.campaigns import presets
    from alcove.models import SurrogateConfigVersion
    from alcove.models.definitions import spec_hash

    url = f"sqlite:///{tmp_path / 'm.db'}"
    migrate.upgrade(url, "head")
    eng = make_engine(url)
    with Session(eng) as s:
        u = presets.local_user(s)
        unnamed = presets.surrogate_config_version_for(s, u.id, {"ensemble_size": 2})
        named = presets.surrogate_config_version_for(s, u.id, {"ensemble_size": 3, "normal_force": "own"})
        s.commit()
    migrate.downgrade(url, "0024")
    scv = sa.table("surrogate_config_versions", sa.column("id", sa.Integer), sa.column("spec", sa.JSON))
    with eng.begin() as c:
        (spec,) = c.execute(sa.select(scv.c.spec).where(scv.c.id == unnamed)).one()
        old = {k: v for k, v in spec.items() if k != "normal_force"}
        c.execute(sa.update(scv).where(scv.c.id == unnamed).values(spec=old))
    migrate.upgrade(url, "head")
    with Session(eng) as s:
        first, second = s.get(SurrogateConfigVersion, unnamed), s.get(SurrogateConfigVersion, named)
        assert first.spec == {**old, "normal_force": "shared"} and first.spec_hash == spec_hash(first.spec)
        assert second.spec["normal_force"] == "own" and second.spec_hash == spec_hash(second.spec)
    eng.dispose()
