"""Real worker processes, real brokers, results committed in the real databases.

* embedded default: SQLite + filesystem broker in a temporary ALCOVE_DATA_DIR;
* production: PostgreSQL (a private schema) + Redis (a private key prefix);
* `alcove up`: API and worker together; health answers, the smoke job round-trips,
  SIGTERM stops both.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from alcove.science.parallel import affinity_cpus
from tests.procs import (
    alcove_env,
    db_rows,
    free_port,
    http_ok,
    pid_alive,
    run_cli,
    running,
    smoke,
    unique,
    wait_until,
    worker_ready,
)

pytestmark = [pytest.mark.integration, pytest.mark.slow]


def test_embedded_worker_round_trip(tmp_path: Path) -> None:
    env = alcove_env(data_dir=tmp_path / "data", cpus_per_process="1")
    assert run_cli(["db", "upgrade"], env).returncode == 0
    with running(
        ["worker", "--queues", "default,train", "--concurrency", "1", "--name", "embedded-test"],
        env,
        tmp_path / "worker.log",
    ) as w:
        wait_until(lambda: worker_ready(w), 60, "worker ready", w)
        for queue in ("default", "train"):
            got = smoke(env, queue=queue)
            assert got["ok"] and got["worker_name"].startswith("embedded-test@")
            # the user's cap reaches the pool process (the OCP's interval threads, the training's threads)
            assert got["payload"]["cpus"] == 1
        url = f"sqlite:///{tmp_path / 'data' / 'alcove.db'}"
        assert len(db_rows(url, "SELECT token FROM smoke_checks")) == 2
        wait_until(
            lambda: db_rows(url, "SELECT name FROM worker_heartbeats WHERE stopped_at IS NULL"), 30, "heartbeat row"
        )
    # warm shutdown marks the worker stopped
    assert db_rows(url, "SELECT stopped_at IS NOT NULL FROM worker_heartbeats WHERE name LIKE 'embedded-test@%'") == [
        (1,)
    ]


def test_a_bad_cpu_cap_stops_the_worker_at_once_naming_the_variable(tmp_path: Path) -> None:
    env = alcove_env(data_dir=tmp_path / "data", cpus_per_process="two")
    r = run_cli(["worker", "--queues", "default", "--concurrency", "1"], env, timeout=60)
    assert r.returncode == 2
    assert "ALCOVE_CPUS_PER_PROCESS: must be a whole number >= 1, got 'two'" in r.stderr


def test_postgres_redis_worker_round_trip(tmp_path: Path, fresh_pg_url: str, redis_url: str) -> None:
    env = alcove_env(
        database_url=fresh_pg_url,
        broker_url=redis_url,
        broker_key_prefix=unique("alcove-test") + ":",
        data_dir=tmp_path / "data",
    )
    with running(
        ["worker", "--queues", "ocp,oracle,train,default", "--concurrency", "2", "--name", unique("pg-redis")],
        env,
        tmp_path / "worker.log",
    ) as w:
        wait_until(lambda: worker_ready(w), 60, "worker ready", w)
        results = [smoke(env, queue=q) for q in ("ocp", "oracle", "train", "default")]
        tokens = [r["token"] for r in results]
        # without a cap every pool process may use all the worker's CPUs (docs/ocp.md: sharing them out
        # gained nothing in the bench's batch iteration and slowed a lone job)
        assert {r["payload"]["cpus"] for r in results} == {affinity_cpus()}
        got = db_rows(fresh_pg_url, "SELECT token, worker_name FROM smoke_checks")
        assert {t for t, _ in got} >= set(tokens)
        assert "Connected to redis://" in w.output()
    assert not (tmp_path / "data" / "alcove.db").exists(), "the worker must not fall back to SQLite"


def test_duplicate_delivery_of_the_smoke_job_is_a_no_op(tmp_path: Path, fresh_pg_url: str, redis_url: str) -> None:
    env = alcove_env(
        database_url=fresh_pg_url,
        broker_url=redis_url,
        broker_key_prefix=unique("alcove-test") + ":",
        data_dir=tmp_path / "data",
    )
    with running(["worker", "--queues", "default", "--concurrency", "2"], env, tmp_path / "worker.log") as w:
        wait_until(lambda: worker_ready(w), 60, "worker ready", w)
        code = (
            "import sys, time\n"
            "from alcove.jobs import send_job, SMOKE_JOB\n"
            "from alcove.jobs.smoke import wait_for_smoke\n"
            "send_job(SMOKE_JOB, 'dup-' + sys.argv[1]); send_job(SMOKE_JOB, 'dup-' + sys.argv[1])\n"
            "assert wait_for_smoke('dup-' + sys.argv[1], 60)\n"
            "time.sleep(1.0)\n"
        )
        token = unique("t")
        import subprocess
        import sys

        r = subprocess.run([sys.executable, "-c", code, token], env=env, capture_output=True, text=True, timeout=120)
        assert r.returncode == 0, r.stderr
        wait_until(
            lambda: "succeeded" in w.output() and w.output().count("alcove.default.smoke[") >= 4,
            30,
            "both deliveries handled",
            w,
        )
    assert db_rows(fresh_pg_url, f"SELECT count(*) FROM smoke_checks WHERE token = 'dup-{token}'") == [(1,)]


def test_alcove_up_embedded(tmp_path: Path) -> None:
    port = free_port()
    env = alcove_env(
        data_dir=tmp_path / "data",
        api_port=str(port),
        admin_email="root@example.org",
        worker_concurrency="1",
        health_details_networks="127.0.0.1",  # the readiness details for this test
    )
    with running(["up", "--access-log"], env, tmp_path / "up.log") as up:
        base = f"http://127.0.0.1:{port}"
        health = wait_until(lambda: http_ok(f"{base}/api/v1/health"), 60, "health", up)
        assert health.json()["status"] == "ok"
        wait_until(lambda: '"GET /api/v1/health HTTP/1.1" 200' in up.output(), 10, "the access log line", up)
        ready = wait_until(lambda: http_ok(f"{base}/api/v1/health/ready"), 60, "readiness", up).json()
        assert ready["database"]["ok"] and ready["broker"]["ok"] and ready["workers_seen"] == 1
        assert set(ready["queues_served"]) == {"default", "ocp", "oracle", "train", "artifacts"}
        got = smoke(env)
        assert got["ok"]
        url = f"sqlite:///{tmp_path / 'data' / 'alcove.db'}"
        assert db_rows(url, "SELECT email, role FROM users") == [("root@example.org", "admin")]
        worker_pids = [int(p) for (p,) in db_rows(url, "SELECT pid FROM worker_heartbeats")]
        code = up.stop()
    assert code == 0, up.output()[-3000:]
    for pid in worker_pids:  # the bundled worker went down with `alcove up`
        assert not pid_alive(pid), f"worker {pid} survived `alcove up`"
    assert db_rows(url, "SELECT count(*) FROM worker_heartbeats WHERE stopped_at IS NULL") == [(0,)]
