"""The held-out validation suite through real Celery workers on PostgreSQL + Redis: two
campaigns on one oracle version share one suite, whose motions are replayed once each by
oracle jobs (in parallel on a 2-process oracle worker), never enter a pool, and every
model version of both campaigns gets its generalisation error."""

from __future__ import annotations

import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.procs import alcove_env, db_rows, start_worker, stop_all
from tests.procs import wait_until as wait_for

pytestmark = [pytest.mark.integration, pytest.mark.slow]


@pytest.fixture
def pg_url(fresh_pg_url: str) -> str:
    """This module's tests start worker processes: each gets a schema of its own (see fresh_pg_url)."""
    return fresh_pg_url


SETTINGS = {"ocp_intervals": 20, "replay_dt": 0.01, "validation_motions": 4, "validation_seed": 5}


@pytest.fixture
def pg_redis(pg_url: str, redis_url: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[dict[str, str]]:
    from alcove.db import dispose_engines
    from alcove.jobs import reset_sender
    from alcove.settings import get_settings

    settings = {
        "database_url": pg_url,
        "broker_url": redis_url,
        "broker_key_prefix": f"t-{uuid.uuid4().hex[:8]}:",
        "data_dir": str(tmp_path / "data"),
        "job_lease_seconds": "10",
    }
    for k, v in settings.items():
        monkeypatch.setenv(f"ALCOVE_{k.upper()}", v)
    get_settings.cache_clear()
    dispose_engines(close=True)
    reset_sender()
    yield alcove_env(**settings, broker_polling_interval="0.05")
    get_settings.cache_clear()
    dispose_engines(close=True)
    reset_sender()


def test_two_campaigns_share_one_suite_replayed_once_and_every_model_is_evaluated(
    pg_redis: dict[str, str], pg_url: str, tmp_path: Path, make_campaign: Any
) -> None:
    from alcove.jobs import send_job
    from alcove.jobs.campaign import enqueue
    from alcove.oracles.validation import MOTION_JOB

    a, jobs_a = make_campaign(seed=21, settings=SETTINGS, stopping={"max_iterations": 2})
    b, jobs_b = make_campaign(seed=22, settings=SETTINGS, stopping={"max_iterations": 2})
    steps = start_worker(pg_redis, tmp_path / "steps.log", f"steps-{uuid.uuid4().hex[:4]}", "default,ocp,train")
    oracle = start_worker(pg_redis, tmp_path / "oracle.log", f"oracle-{uuid.uuid4().hex[:4]}", "oracle", 2)
    try:
        enqueue(jobs_a + jobs_b)

        def all_evaluated() -> bool:
            done = db_rows(
                pg_url,
                "SELECT count(*) FROM campaigns WHERE id IN (:a, :b) AND status = 'completed'",
                a=a,
                b=b,
            )
            evaluated = db_rows(
                pg_url,
                "SELECT count(*) FROM model_versions mv JOIN validation_metrics v ON v.model_version_id = mv.id "
                "WHERE mv.campaign_id IN (:a, :b)",
                a=a,
                b=b,
            )
            return done == [(2,)] and evaluated == [(4,)]

        wait_for(all_evaluated, 300, "both campaigns and the validation of their 4 model versions", steps)
        ((motion_id,),) = db_rows(
            pg_url,
            "SELECT min(m.id) FROM validation_motions m JOIN campaigns c ON c.validation_suite_id = m.suite_id "
            "WHERE c.id = :a",
            a=a,
        )
        send_job(MOTION_JOB, motion_id)  # a duplicate delivery of a finished motion: a no-op
        wait_for(lambda: "duplicate" in oracle.output(), 60, "the duplicate motion job", oracle)
    finally:
        stop_all([steps, oracle])

    suites = db_rows(pg_url, "SELECT validation_suite_id FROM campaigns WHERE id IN (:a, :b)", a=a, b=b)
    assert len({s for (s,) in suites}) == 1 and suites[0][0] is not None  # one suite, shared
    (suite_id,) = suites[0]
    assert db_rows(pg_url, "SELECT status, n_motions FROM validation_suites WHERE id = :s", s=suite_id) == [
        ("complete", 4)
    ]
    # each motion replayed exactly once, by the oracle worker; one dataset each, in no pool
    motions = db_rows(
        pg_url,
        'SELECT status, attempts, worker_name, dataset_id FROM validation_motions WHERE suite_id = :s ORDER BY "index"',
        s=suite_id,
    )
    assert [(st, n) for st, n, _, _ in motions] == [("succeeded", 1)] * 4
    assert all(w.startswith("oracle-") for _, _, w, _ in motions)
    assert db_rows(
        pg_url,
        "SELECT count(*), count(DISTINCT d.content_sha256) FROM datasets d "
        "JOIN validation_motions m ON m.dataset_id = d.id WHERE m.suite_id = :s AND d.origin = 'validation'",
        s=suite_id,
    ) == [(4, 4)]
    assert db_rows(
        pg_url,
        "SELECT count(*) FROM pool_version_members m JOIN datasets d ON d.id = m.dataset_id "
        "WHERE d.origin = 'validation'",
    ) == [(0,)]
    # every model version of both campaigns has its generalisation error
    got = db_rows(
        pg_url,
        "SELECT mv.campaign_id, mv.version, v.suite_id, v.force_rmse, v.n_samples FROM model_versions mv "
        "JOIN validation_metrics v ON v.model_version_id = mv.id WHERE mv.campaign_id IN (:a, :b) "
        "ORDER BY mv.campaign_id, mv.version",
        a=a,
        b=b,
    )
    assert [(c, k, s) for c, k, s, _, _ in got] == [
        (a, 1, suite_id),
        (a, 2, suite_id),
        (b, 1, suite_id),
        (b, 2, suite_id),
    ]
    (n_samples,) = db_rows(
        pg_url,
        "SELECT sum(d.n_samples) FROM datasets d JOIN validation_motions m ON m.dataset_id = d.id "
        "WHERE m.suite_id = :s",
        s=suite_id,
    )[0]
    assert all(f > 0 and n == n_samples for *_, f, n in got)  # evaluated on all motions
