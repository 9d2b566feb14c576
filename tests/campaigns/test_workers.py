"""Campaigns through real Celery worker processes.

* the embedded default (SQLite + filesystem broker): ``alcove campaign run`` end to end;
* PostgreSQL + Redis: SIGKILL of the worker in the middle of an oracle job, then a new
  worker: the campaign completes and its pool holds exactly the rows of an uninterrupted
  run with the same seed; the same when Redis restarts (losing its messages) mid-campaign,
  and when the API process is killed and restarted (the new one pauses and resumes it).
"""

from __future__ import annotations

import json
import shutil
import subprocess
import time
import uuid
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import sqlalchemy as sa

from tests.procs import (
    CLI,
    PrivateRedis,
    Proc,
    alcove_env,
    db_rows,
    free_port,
    http_ok,
    pid_alive,
    start_worker,
    stop_all,
    unique,
)
from tests.procs import wait_until as wait_for

pytestmark = [pytest.mark.integration, pytest.mark.slow]


@pytest.fixture
def pg_url(fresh_pg_url: str) -> str:
    """This module's tests start worker processes: each gets a schema of its own (see fresh_pg_url)."""
    return fresh_pg_url


QUICK_YAML = """
preliminary: {samples: 400, chunks: 4}
settings: {ocp_intervals: 20, replay_dt: 0.01, validation_motions: 2, validation_reference_motions: 0}
surrogate: {max_epochs: 60, ensemble_size: 2}
"""


def env_for(**settings: Any) -> dict[str, str]:
    return alcove_env(**settings, broker_polling_interval="0.05")


def rows(url: str, sql: str, **params: Any) -> list[tuple]:
    return db_rows(url, sql, **params)


def maybe_rows(url: str, sql: str, **params: Any) -> list[tuple]:
    """``rows``, or nothing while the database is still being created and migrated."""
    try:
        return rows(url, sql, **params)
    except sa.exc.OperationalError:
        return []


def pool_hashes(url: str, cid: int) -> list[tuple[int, str, int]]:
    return rows(
        url, "SELECT version, content_hash, n_samples FROM pool_versions WHERE campaign_id = :c ORDER BY version", c=cid
    )


def test_alcove_campaign_run_on_the_embedded_default(tmp_path: Path) -> None:
    cfg = tmp_path / "quick.yaml"
    # the suite's best-possible line from 4 reference replays, computed by the spawned worker
    cfg.write_text(QUICK_YAML.replace("validation_reference_motions: 0", "validation_reference_motions: 4"))
    env = env_for(data_dir=tmp_path / "data")
    r = subprocess.run(
        [
            *CLI,
            "campaign",
            "run",
            "--oracle",
            "aux-penalty",
            "--iterations",
            "2",
            "--config",
            str(cfg),
            "--json",
            "--seed",
            "5",
            "--worker-log",
            str(tmp_path / "worker.log"),
        ],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr[-3000:] + (tmp_path / "worker.log").read_text()[-3000:]
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert (out["status"], out["stop_reason"], out["iterations_finished"]) == ("completed", "max_iterations", 2)
    assert [m["iteration_index"] for m in out["metrics"]] == [1, 2] and all(
        m["force_rmse"] >= 0 for m in out["metrics"]
    )
    # the paper's strategy (the default) solves the task as written: no scenario per iteration
    assert [m["scenario"] for m in out["metrics"]] == [None, None]
    # the held-out validation suite was replayed by the spawned worker and every model version evaluated on it
    assert out["validation_suite"]["status"] == "complete" and out["validation_suite"]["motions_done"] == 2 + 4
    assert out["validation_suite"]["n_reference_motions"] == 4 and out["validation_suite"]["best_possible_computed"]
    ((line,),) = [out["best_possible"]]
    assert line["oracle_calls"] == 4 and np.isfinite(line["force_rmse"]) and line["force_rmse"] > 0
    assert line["force_rmse"] ** 2 == pytest.approx(line["fx_rmse"] ** 2 + line["fz_rmse"] ** 2, rel=1e-9)
    assert all(m["validation_force_rmse"] > 0 and m["validation_moment_rmse"] > 0 for m in out["metrics"])
    assert out["last"]["validation_force_rmse"] == out["metrics"][-1]["validation_force_rmse"]
    # per component, in the loop and on the suite: the vector RMSE squared is the sum of its components'
    last = out["last"]
    for prefix in ("", "validation_"):
        fx, fy, fz = (last[f"{prefix}{c}_rmse"] for c in ("fx", "fy", "fz"))
        assert fx > 0 and fz >= 0 and last[f"{prefix}my_rmse"] > 0
        force = last[f"{prefix}force_rmse"]
        assert abs(force**2 - (fx**2 + fy**2 + fz**2)) <= 1e-9 * force**2  # threshold: float rounding
    assert last["fx_rmse_contact"] is not None and last["validation_fx_rmse_contact"] is not None
    url = f"sqlite:///{tmp_path / 'data' / 'alcove.db'}"
    cid = out["campaign_id"]
    assert [v for v, _, _ in pool_hashes(url, cid)] == [0, 1, 2]
    assert rows(
        url,
        "SELECT version, parent_model_id IS NULL FROM model_versions WHERE campaign_id = :c ORDER BY version",
        c=cid,
    ) == [(1, 1), (2, 0)]
    # every step ran in the spawned worker, not in the CLI process
    workers = {
        w for (w,) in rows(url, "SELECT DISTINCT worker_name FROM iteration_steps WHERE campaign_id = :c", c=cid)
    }
    assert len(workers) == 1 and workers.pop().startswith("campaign-run-")
    # the other commands on the same database
    st = subprocess.run(
        [*CLI, "campaign", "status", str(cid), "--json"], env=env, capture_output=True, text=True, timeout=60
    )
    assert json.loads(st.stdout)["campaign"]["status"] == "completed"
    st = subprocess.run([*CLI, "campaign", "status", str(cid)], env=env, capture_output=True, text=True, timeout=60)
    assert " · validation F " in st.stdout and "validation suite" in st.stdout
    assert "6/6 motions replayed (4 for the best-possible line)" in st.stdout
    assert f"spread over the suite's range): 4 calls {line['force_rmse']:.3g} N" in st.stdout
    ex = subprocess.run(
        [*CLI, "campaign", "export", str(cid), "--out", str(tmp_path / "export"), "--format", "csv", "--no-models"],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert ex.returncode == 0, ex.stderr
    assert (tmp_path / "export" / "pool" / "version-0002.csv").exists() and (
        tmp_path / "export" / "metrics.csv"
    ).exists()
    bad = subprocess.run([*CLI, "campaign", "resume", str(cid)], env=env, capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and "cannot resume a campaign that is completed" in bad.stderr


def test_campaign_run_without_a_worker_names_the_queue_it_waits_on(tmp_path: Path) -> None:
    """`campaign run --no-worker` with no worker says which queue no live worker serves (also under
    --json, without a terminal) instead of waiting silently, and goes on once workers appear."""
    cfg = tmp_path / "quick.yaml"
    cfg.write_text(QUICK_YAML)
    env = env_for(data_dir=tmp_path / "data", worker_watch_seconds=1)  # checked every 1 s, not 5 s
    run = Proc(
        [
            "campaign",
            "run",
            "--oracle",
            "aux-penalty",
            "--iterations",
            "1",
            "--config",
            str(cfg),
            "--json",
            "--no-worker",
        ],
        env,
        tmp_path / "run.log",
    )
    workers: list[Proc] = []
    try:
        wait_for(
            lambda: (
                "waiting: no live worker serves queue 'default' (step preliminary); "
                "start one with `alcove worker --queues default`" in run.output()
            ),
            60,
            "the notice for the default queue",
            run,
        )
        workers.append(start_worker(env, tmp_path / "w-default.log", unique("w-default"), queues="default"))
        wait_for(
            lambda: "waiting: no live worker serves queue 'train' (step train)" in run.output(),
            120,
            "the notice for the train queue",
            run,
        )
        assert "queue 'ocp'" not in run.output()  # nothing is said of a queue the campaign has not reached
        workers.append(start_worker(env, tmp_path / "w-rest.log", unique("w-rest"), queues="train,ocp,oracle"))
        wait_for(lambda: not run.alive(), 180, "the end of the campaign")
        assert run.p.returncode == 0, run.output()[-3000:]
        out = json.loads([line for line in run.output().splitlines() if line.startswith("{")][-1])
        assert (out["status"], out["iterations_finished"]) == ("completed", 1)
    finally:
        stop_all([run, *workers])


# ----------------------------------------------------------------------------- PostgreSQL + Redis


def quick_campaign(
    make_campaign: Any, seed: int, iterations: int, fault: dict | None = None, start: bool = True
) -> tuple[int, list]:
    return make_campaign(seed=seed, stopping={"max_iterations": iterations}, fault=fault, start=start)


def reference_pool(make_campaign: Any, seed: int, iterations: int, url: str) -> list[tuple[int, str, int]]:
    from alcove.campaigns.run import protocol

    cid, jobs = quick_campaign(make_campaign, seed, iterations)
    protocol.drive_inline(cid, jobs)
    return pool_hashes(url, cid)


def test_sigkill_of_a_worker_during_an_oracle_job_loses_and_duplicates_nothing(
    pg_redis: dict[str, str], pg_url: str, tmp_path: Path, make_campaign: Any
) -> None:
    from alcove.jobs.campaign import enqueue

    expected = reference_pool(make_campaign, seed=11, iterations=3, url=pg_url)
    cid, jobs = quick_campaign(
        make_campaign, 11, 3, fault={"oracle": {"sleep_s": 3, "sleep_attempts": 1, "iterations": [2]}}
    )
    w1 = start_worker(pg_redis, tmp_path / "w1.log", f"w1-{uuid.uuid4().hex[:4]}")
    try:
        enqueue(jobs)
        enqueue(jobs)  # a duplicate delivery of the first step: the second message does nothing
        wait_for(
            lambda: rows(
                pg_url,
                "SELECT 1 FROM iteration_steps s JOIN iterations i ON i.id = s.iteration_id "
                "WHERE s.campaign_id = :c AND i.index = 2 AND s.step = 'oracle' AND s.status = 'running'",
                c=cid,
            ),
            180,
            "the oracle job of iteration 2",
            w1,
        )
        time.sleep(0.5)
        w1.kill()
    finally:
        w1.stop()
    w2 = start_worker(pg_redis, tmp_path / "w2.log", f"w2-{uuid.uuid4().hex[:4]}")
    try:
        wait_for(
            lambda: rows(
                pg_url,
                "SELECT 1 FROM campaigns WHERE id = :c AND status IN ('completed', 'failed', 'cancelled')",
                c=cid,
            ),
            180,
            "the campaign to end",
            w2,
        )
    finally:
        w2.stop()
    assert rows(pg_url, "SELECT status, stop_reason FROM campaigns WHERE id = :c", c=cid) == [
        ("completed", "max_iterations")
    ]
    assert pool_hashes(pg_url, cid) == expected
    # the oracle step of iteration 2 was requeued by the reconciler and ran once more, on the new worker
    ((attempts, worker),) = rows(
        pg_url,
        "SELECT s.attempts, s.worker_name FROM iteration_steps s JOIN iterations i ON i.id = s.iteration_id "
        "WHERE s.campaign_id = :c AND i.index = 2 AND s.step = 'oracle'",
        c=cid,
    )
    assert attempts == 2 and worker.startswith("w2-")
    assert rows(
        pg_url, "SELECT count(*) FROM campaign_events WHERE campaign_id = :c AND kind = 'step_requeued'", c=cid
    ) == [(1,)]
    assert rows(pg_url, "SELECT count(*) FROM datasets WHERE campaign_id = :c AND origin = 'oracle'", c=cid) == [(3,)]
    assert rows(
        pg_url,
        "SELECT count(*) FROM campaign_events "
        "WHERE campaign_id = :c AND kind = 'step_started' AND step = 'preliminary'",
        c=cid,
    ) == [(1,)]
    assert rows(pg_url, "SELECT count(*) FROM datasets WHERE campaign_id = :c AND origin = 'preliminary'", c=cid) == [
        (4,)
    ]
    assert "duplicate" in w1.output() + w2.output()
    # N iterations with metrics and curves, N model versions, all lineage links
    assert rows(
        pg_url,
        "SELECT iteration_index, curves_sha256 IS NOT NULL, model_version_id IS NOT NULL, dataset_id IS NOT NULL "
        "FROM iteration_metrics WHERE campaign_id = :c ORDER BY iteration_index",
        c=cid,
    ) == [(k, True, True, True) for k in (1, 2, 3)]
    lineage = rows(
        pg_url,
        "SELECT m.version, p.version, pm.version FROM model_versions m "
        "JOIN pool_versions p ON p.id = m.pool_version_id "
        "LEFT JOIN model_versions pm ON pm.id = m.parent_model_id WHERE m.campaign_id = :c ORDER BY m.version",
        c=cid,
    )
    assert lineage == [(1, 0, None), (2, 1, 1), (3, 2, 2)]
    assert rows(
        pg_url,
        "SELECT p.version, pp.version FROM pool_versions p LEFT JOIN pool_versions pp ON pp.id = p.parent_id "
        "WHERE p.campaign_id = :c ORDER BY p.version",
        c=cid,
    ) == [(0, None), (1, 0), (2, 1), (3, 2)]


@pytest.mark.skipif(shutil.which("redis-server") is None, reason="needs the redis-server program")
def test_a_redis_restart_mid_campaign_loses_no_step(
    pg_redis: dict[str, str], pg_url: str, tmp_path: Path, make_campaign: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    from alcove.jobs import reset_sender
    from alcove.jobs.campaign import enqueue
    from alcove.jobs.outbox import reset_broker_client
    from alcove.settings import get_settings

    redis_server = PrivateRedis(tmp_path)
    redis_server.start()
    monkeypatch.setenv("ALCOVE_BROKER_URL", redis_server.url)
    get_settings.cache_clear()
    reset_sender()
    reset_broker_client()
    env = {**pg_redis, "ALCOVE_BROKER_URL": redis_server.url}
    expected = reference_pool(make_campaign, seed=12, iterations=2, url=pg_url)
    cid, jobs = quick_campaign(make_campaign, 12, 2, fault={"train": {"sleep_s": 2, "iterations": [2]}})
    w = start_worker(env, tmp_path / "w.log", f"wr-{uuid.uuid4().hex[:4]}")
    try:
        enqueue(jobs)
        wait_for(
            lambda: rows(
                pg_url,
                "SELECT 1 FROM iteration_steps s JOIN iterations i ON i.id = s.iteration_id "
                "WHERE s.campaign_id = :c AND i.index = 2 AND s.step = 'train' AND s.status = 'running'",
                c=cid,
            ),
            180,
            "the train job of iteration 2",
            w,
        )
        redis_server.stop()  # the next message (ocp of iteration 2) is sent while Redis is down or lost with it
        time.sleep(3)
        redis_server.start()
        wait_for(
            lambda: rows(
                pg_url,
                "SELECT 1 FROM campaigns WHERE id = :c AND status IN ('completed', 'failed', 'cancelled')",
                c=cid,
            ),
            240,
            "the campaign to end",
            w,
        )
    finally:
        w.stop()
        redis_server.stop()
    assert rows(pg_url, "SELECT status FROM campaigns WHERE id = :c", c=cid) == [("completed",)]
    assert pool_hashes(pg_url, cid) == expected


def test_killing_the_controlling_process_leaves_a_campaign_that_a_new_worker_finishes(tmp_path: Path) -> None:
    """SIGKILL of `alcove campaign run` (the API-side process): its worker shuts down with
    it; the campaign lives in the database and a worker started later completes it."""
    cfg = tmp_path / "quick.yaml"
    cfg.write_text(QUICK_YAML)
    plan = tmp_path / "faults.json"  # the (only) campaign's second training is slow
    plan.write_text(json.dumps({"campaigns": {"*": {"train": {"sleep_s": 2, "iterations": [2]}}}}))
    env = env_for(data_dir=tmp_path / "data", job_lease_seconds=4, testing="true", fault_plan=plan)
    url = f"sqlite:///{tmp_path / 'data' / 'alcove.db'}"
    cli = subprocess.Popen(
        [
            *CLI,
            "campaign",
            "run",
            "--oracle",
            "aux-penalty",
            "--iterations",
            "3",
            "--config",
            str(cfg),
            "--json",
            "--worker-log",
            str(tmp_path / "spawned.log"),
        ],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        wait_for(
            lambda: maybe_rows(
                url,
                "SELECT 1 FROM iteration_steps s JOIN iterations i ON i.id = s.iteration_id "
                "WHERE i.\"index\" = 2 AND s.step = 'train' AND s.status = 'running'",
            ),
            180,
            "the train job of iteration 2",
        )
        pids = [p for (p,) in rows(url, "SELECT pid FROM worker_heartbeats")]
        cli.kill()
        cli.wait(timeout=10)
        wait_for(lambda: not any(pid_alive(p) for p in pids), 60, "the spawned worker to exit with its parent")
    finally:
        if cli.poll() is None:
            cli.kill()
    ((cid, status),) = rows(url, "SELECT id, status FROM campaigns")
    assert status == "running"
    w = start_worker(env, tmp_path / "w.log", f"later-{uuid.uuid4().hex[:4]}")
    try:
        wait_for(
            lambda: rows(url, "SELECT 1 FROM campaigns WHERE status IN ('completed', 'failed', 'cancelled')"),
            180,
            "the campaign to end",
            w,
        )
    finally:
        w.stop()
    assert rows(url, "SELECT status, stop_reason FROM campaigns") == [("completed", "max_iterations")]
    assert [v for v, _, _ in pool_hashes(url, cid)] == [0, 1, 2, 3]
    assert rows(url, "SELECT count(*), count(DISTINCT iteration_id) FROM datasets WHERE origin = 'oracle'") == [(3, 3)]


def test_an_api_restart_mid_campaign_changes_nothing_and_the_new_api_controls_it(
    pg_redis: dict[str, str], pg_url: str, tmp_path: Path, make_campaign: Any
) -> None:
    """SIGKILL of the API process (`alcove up --no-worker`) while a campaign it started runs: the
    workers carry on (the state is in the database, the next message is sent by the job
    that finished), a restarted API pauses and resumes it, and the pool is exactly the
    pool of an uninterrupted run with the same seed."""
    import httpx

    from alcove.campaigns.presets import local_user
    from alcove.db import run_transaction
    from alcove.users import service as users

    expected = reference_pool(make_campaign, seed=13, iterations=3, url=pg_url)
    # iteration 2's train is the moment of the kill; iteration 3's OCP holds the campaign open (15 s) while the
    # new API starts (7.4 s on a slow machine, where the rest of the campaign took less), so the pause below
    # always meets a running campaign
    fault = {"train": {"sleep_s": 2, "iterations": [2]}, "ocp": {"sleep_s": 15, "iterations": [3]}}
    cid, _ = quick_campaign(make_campaign, 13, 3, fault=fault, start=False)
    token = run_transaction(lambda s: users.create_token(s, local_user(s), "api-restart-test", None)[1])
    port = free_port()
    base, headers = f"http://127.0.0.1:{port}/api/v1", {"Authorization": f"Bearer {token}"}
    env = {**pg_redis, "ALCOVE_API_HOST": "127.0.0.1", "ALCOVE_API_PORT": str(port)}

    def serve(log: str) -> Any:
        api = Proc(["up", "--no-worker", "--no-migrate"], env, tmp_path / log)  # the API process alone
        wait_for(lambda: http_ok(f"{base}/health"), 60, "the API", api)
        return api

    def at(iteration: int, step: str, status: str) -> list[tuple]:
        return rows(
            pg_url,
            "SELECT 1 FROM iteration_steps s JOIN iterations i ON i.id = s.iteration_id "
            "WHERE s.campaign_id = :c AND i.index = :k AND s.step = :st AND s.status = :status",
            c=cid,
            k=iteration,
            st=step,
            status=status,
        )

    w = start_worker(pg_redis, tmp_path / "w.log", f"wa-{uuid.uuid4().hex[:4]}")
    api = serve("api1.log")
    try:
        assert httpx.post(f"{base}/campaigns/{cid}/start", headers=headers, timeout=30).status_code == 200
        wait_for(lambda: at(2, "train", "running"), 180, "the train job of iteration 2", w)
        api.kill()  # no shutdown of any kind
        killed = datetime.now(UTC)
        api = serve("api2.log")
        back = datetime.now(UTC)
        (finished,) = rows(
            pg_url,
            "SELECT count(*) FROM iteration_steps WHERE campaign_id = :c AND finished_at > :t",
            c=cid,
            t=killed,
        )
        print(
            f"\nRECOVERY API SIGKILL mid-campaign: a new API answered {(back - killed).total_seconds():.1f} s later; "
            f"meanwhile the workers finished {finished[0]} step(s) (nothing waits for the API)"
        )
        r = httpx.post(f"{base}/campaigns/{cid}/pause", headers=headers, timeout=30)
        assert r.status_code == 200 and r.json()["campaign"]["status"] in ("pausing", "paused"), r.text
        wait_for(
            lambda: rows(pg_url, "SELECT 1 FROM campaigns WHERE id = :c AND status = 'paused'", c=cid),
            120,
            "the pause",
            w,
        )
        assert httpx.post(f"{base}/campaigns/{cid}/resume", headers=headers, timeout=30).status_code == 200
        wait_for(
            lambda: rows(
                pg_url,
                "SELECT 1 FROM campaigns WHERE id = :c AND status IN ('completed', 'failed', 'cancelled')",
                c=cid,
            ),
            180,
            "the campaign to end",
            w,
        )
        assert (
            httpx.get(f"{base}/campaigns/{cid}", headers=headers, timeout=30).json()["campaign"]["status"]
            == "completed"
        )
    finally:
        stop_all([api, w])
    assert rows(pg_url, "SELECT status, stop_reason FROM campaigns WHERE id = :c", c=cid) == [
        ("completed", "max_iterations")
    ]
    assert pool_hashes(pg_url, cid) == expected
    assert rows(pg_url, "SELECT count(*) FROM datasets WHERE campaign_id = :c AND origin = 'oracle'", c=cid) == [(3,)]
