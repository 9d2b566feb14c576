"""Fixtures for campaign tests: settings pointed at a migrated database, quick campaigns."""

from __future__ import annotations

import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

#: a campaign small enough for tests: few LHS samples, coarse OCP grid, short training, two
#: held-out validation motions (the suite's own tests ask for more), an ensemble of two (the
#: smallest with a standard deviation; the default of 5 is tested in the surrogate tests), pool version
#: 0 from the auxiliary law alone whatever the oracle (the press-family start has its own tests)
QUICK: dict[str, Any] = {
    "preliminary": {"samples": 400, "chunks": 4, "family_motions": 0},
    "settings": {"ocp_intervals": 20, "replay_dt": 0.01, "validation_motions": 2, "validation_reference_motions": 0},
    "stopping": {"max_iterations": 2},
}
QUICK_SURROGATE = {"max_epochs": 60, "ensemble_size": 2}


def _use(monkeypatch: pytest.MonkeyPatch, tmp_path: Any, url: str, lease: int) -> None:
    from alcove.db import dispose_engines
    from alcove.jobs import reset_sender
    from alcove.settings import get_settings

    monkeypatch.setenv("ALCOVE_DATABASE_URL", url)
    monkeypatch.setenv("ALCOVE_DATA_DIR", str(tmp_path / "data"))
    monkeypatch.setenv("ALCOVE_JOB_LEASE_SECONDS", str(lease))
    monkeypatch.delenv("ALCOVE_BROKER_URL", raising=False)
    get_settings.cache_clear()
    dispose_engines(close=True)
    reset_sender()


@pytest.fixture
def campaign_db(db_url: str, monkeypatch: pytest.MonkeyPatch, tmp_path: Any) -> Iterator[str]:
    """Process settings pointed at each migrated backend in turn (SQLite, PostgreSQL)."""
    from alcove.db import dispose_engines
    from alcove.settings import get_settings

    _use(monkeypatch, tmp_path, db_url, lease=2)
    yield db_url
    get_settings.cache_clear()
    dispose_engines(close=True)


@pytest.fixture
def sqlite_campaign_db(sqlite_url: str, monkeypatch: pytest.MonkeyPatch, tmp_path: Any) -> Iterator[str]:
    from alcove.db import dispose_engines
    from alcove.settings import get_settings

    _use(monkeypatch, tmp_path, sqlite_url, lease=2)
    yield sqlite_url
    get_settings.cache_clear()
    dispose_engines(close=True)


def new_campaign(
    oracle: str = "aux-penalty",
    task: str = "head-headrest-2phase",
    surrogate: dict | None = None,
    start: bool = True,
    fault: dict[str, dict[str, Any]] | None = None,
    task_spec: dict[str, Any] | None = None,
    **overrides: Any,
):
    """Create (and start) a quick campaign; returns (campaign id, jobs to run). ``fault``:
    the faults its steps meet (needs the ``faults`` fixture: test processes only); ``task_spec``:
    the task as a spec (stored under the name ``task``) instead of the preset."""
    from alcove.campaigns import presets, service
    from alcove.campaigns.schemas import CampaignCreate
    from alcove.db import run_transaction

    cfg = {k: dict(v) for k, v in QUICK.items()}
    for key, value in overrides.items():
        if isinstance(value, dict) and key in cfg:
            cfg[key].update(value)
        else:
            cfg[key] = value

    def work(s: Any) -> tuple[int, list]:
        u = presets.local_user(s)
        data = CampaignCreate(
            name=cfg.pop("name", "test"),
            task_version_id=presets.task_version_from_preset(s, u.id, task, task_spec),
            oracle_version_id=presets.oracle_version_for(s, u.id, oracle),
            surrogate_config_version_id=presets.surrogate_config_version_for(
                s, u.id, {**QUICK_SURROGATE, **(surrogate or {})}
            ),
            **cfg,
        )
        c = service.create_campaign(s, u.id, data)
        if fault:
            from alcove.jobs.faults import inject

            inject(c.id, fault)
        if not start:
            return c.id, []
        return c.id, service.start(s, c.id)[1]

    return run_transaction(work)


@pytest.fixture
def faults(tmp_path: Any, monkeypatch: pytest.MonkeyPatch) -> Iterator[dict[str, str]]:
    """This process as a test process with a fault plan file (campaigns made with ``fault=``
    write to it); yields the settings a worker process needs to read the same plan."""
    from alcove.settings import get_settings

    env = {"ALCOVE_TESTING": "true", "ALCOVE_FAULT_PLAN": str(tmp_path / "faults.json")}
    for k, v in env.items():
        monkeypatch.setenv(k, v)
    get_settings.cache_clear()
    yield env
    get_settings.cache_clear()


@pytest.fixture
def make_campaign():
    """:func:`new_campaign` as a fixture (test modules cannot import conftest)."""
    return new_campaign


def _pg_redis(
    pg_url: str, redis_url: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, faults: dict[str, str], **extra: str
) -> Iterator[dict[str, str]]:
    from alcove.db import dispose_engines
    from alcove.jobs import reset_sender
    from alcove.jobs.outbox import reset_broker_client
    from alcove.settings import get_settings
    from tests.procs import alcove_env

    settings = {
        "database_url": pg_url,
        "broker_url": redis_url,
        "broker_key_prefix": f"t-{uuid.uuid4().hex[:8]}:",
        "data_dir": str(tmp_path / "data"),
        **extra,
    }
    for k, v in settings.items():
        monkeypatch.setenv(f"ALCOVE_{k.upper()}", v)
    get_settings.cache_clear()
    dispose_engines(close=True)
    reset_sender()
    reset_broker_client()
    yield {**alcove_env(**settings, broker_polling_interval="0.05"), **faults}
    get_settings.cache_clear()
    dispose_engines(close=True)
    reset_sender()
    reset_broker_client()


@pytest.fixture
def pg_redis(
    pg_url: str, redis_url: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, faults: dict[str, str]
) -> Iterator[dict[str, str]]:
    """This process and its workers on PostgreSQL + Redis (private key prefix), 3 s leases,
    all of them test processes reading one fault plan."""
    yield from _pg_redis(pg_url, redis_url, tmp_path, monkeypatch, faults, job_lease_seconds="3")


@pytest.fixture
def pg_redis_default_lease(
    pg_url: str, redis_url: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, faults: dict[str, str]
) -> Iterator[dict[str, str]]:
    """:func:`pg_redis` with the production lease (120 s) and heartbeat settings: whatever
    recovers within seconds there is the heartbeat or the outbox, not a lease running out."""
    yield from _pg_redis(pg_url, redis_url, tmp_path, monkeypatch, faults)
