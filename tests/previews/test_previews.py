"""Editor previews: "solve once" for a task and "test on a sample trajectory" for an oracle.

Without a worker (the session's embedded broker only stores the message): 202 + pending,
owner-only (404 for others), unsaved edits validated like a save (422 naming the field),
at most 3 pending per user (429). The job itself, run in this process: a duplicate delivery
is a no-op, the solve converges with the auxiliary contact and the oracle's force is zero
while the head is clear of the headrest. Through a real worker process (PostgreSQL + Redis):
both previews end ``succeeded``, and a command oracle (the administrator's command, which
replays with the built-in aux-penalty model) gives the built-in oracle's forces."""

from __future__ import annotations

import shutil
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from tests.helpers import Account, make_account, small_task_spec, unique

API = "/api/v1"
EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "command-oracle"


def _task_and_oracle(client, who: Account) -> tuple[int, int]:
    task = client.post(f"{API}/tasks", json={"name": "pv", "spec": small_task_spec()}, headers=who.headers)
    oracle = client.post(f"{API}/oracles/presets/aux-penalty/copy", headers=who.headers)
    assert task.status_code == 201 and oracle.status_code == 201, (task.text, oracle.text)
    return task.json()["id"], oracle.json()["id"]


def test_previews_are_accepted_private_validated_and_limited(client) -> None:
    me, someone = make_account("member", "pv"), make_account("member", "pv-other")
    task_id, oracle_id = _task_and_oracle(client, me)

    r = client.post(f"{API}/tasks/{task_id}/previews", json={"intervals": 6}, headers=me.headers)
    assert r.status_code == 202, r.text
    p = r.json()
    assert (
        p["status"] == "pending"
        and p["kind"] == "task"
        and p["result"] is None
        and p["options"] == {"intervals": 6, "intervals_per_phase": [6, 6]}
        and not p["draft"]
    )
    assert client.get(f"{API}/previews/{p['id']}", headers=me.headers).json()["status"] == "pending"
    assert client.get(f"{API}/previews/{p['id']}", headers=someone.headers).status_code == 404
    assert (
        client.post(f"{API}/tasks/{task_id}/previews", headers=someone.headers).status_code == 404
    )  # not shared with them
    assert client.post(f"{API}/oracles/{oracle_id}/previews", headers=someone.headers).status_code == 404

    bad = small_task_spec()
    bad["phases"][0]["duration"] = -1
    r = client.post(f"{API}/tasks/{task_id}/previews", json={"spec": bad}, headers=me.headers)
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "spec.phases.0.duration", r.text
    r = client.post(f"{API}/oracles/{oracle_id}/previews", json={"params": {"k": -5}}, headers=me.headers)
    assert r.status_code == 422 and r.json()["detail"][0]["field"].startswith("params."), r.text
    assert client.post(f"{API}/tasks/{task_id}/previews", json={"intervals": 0}, headers=me.headers).status_code == 422
    assert client.post(f"{API}/tasks/{task_id}/previews", json={"version": 9}, headers=me.headers).status_code == 422

    draft = client.post(f"{API}/oracles/{oracle_id}/previews", json={"params": {}, "dt": 0.01}, headers=me.headers)
    assert draft.status_code == 202 and draft.json()["draft"] and draft.json()["kind"] == "oracle"
    third = client.post(f"{API}/tasks/{task_id}/previews", headers=me.headers)
    assert third.status_code == 202
    limited = client.post(f"{API}/tasks/{task_id}/previews", headers=me.headers)
    assert limited.status_code == 429 and "at most 3" in limited.json()["detail"] and limited.headers["Retry-After"]
    assert client.post(f"{API}/tasks/{task_id}/previews", headers=someone.headers).status_code == 404
    listed = client.get(f"{API}/previews", headers=me.headers).json()
    assert [x["id"] for x in listed] == [third.json()["id"], draft.json()["id"], p["id"]]
    assert client.get(f"{API}/previews", headers=someone.headers).json() == []


def test_the_jobs_compute_the_science_and_ignore_duplicates(client) -> None:
    from alcove.db import open_transaction
    from alcove.models import Preview
    from alcove.previews.worker import run_preview

    me = make_account("member", "pv-job")
    task_id, oracle_id = _task_and_oracle(client, me)
    tp = client.post(f"{API}/tasks/{task_id}/previews", headers=me.headers).json()[
        "id"
    ]  # the task's own grid: 8 per phase
    op = client.post(f"{API}/oracles/{oracle_id}/previews", json={"dt": 0.01}, headers=me.headers).json()["id"]
    assert run_preview(tp, "test@host") == "succeeded"
    assert run_preview(tp, "test@host") == "skipped"  # a redelivered message does nothing
    assert run_preview(op, "test@host") == "succeeded"

    task = client.get(f"{API}/previews/{tp}", headers=me.headers).json()
    assert task["status"] == "succeeded" and task["worker_name"] == "test@host" and task["finished_at"]
    res = task["result"]
    assert res["converged"] and res["status"] == "Solve_Succeeded" and res["intervals"] == 16 and res["iterations"] > 0
    assert res["intervals_per_phase"] == [8, 8] and res["grid"] == "8 + 8 intervals (the task's own grid)"
    t, q, tau = np.array(res["t"]), np.array(res["q"]), np.array(res["tau"])
    assert t.shape == (17,) and q.shape == tau.shape == (17, 1) and np.all(np.diff(t) > 0)
    assert np.asarray(res["wrench"]).shape == (17, 6)
    spec = small_task_spec()
    assert t[-1] == pytest.approx(sum(ph["duration"] for ph in spec["phases"]))

    oracle = client.get(f"{API}/previews/{op}", headers=me.headers).json()["result"]
    assert oracle["ok"] and len(oracle["t"]) == len(oracle["fx"]) == 101
    force = np.linalg.norm(np.array([oracle["fx"], oracle["fy"], oracle["fz"]]).T, axis=1)
    first = oracle["diagnostics"]["first_contact_t"]
    t = np.array(oracle["t"])
    assert (
        np.all(force[t < first - 1e-9] == 0.0)
        and force.max() == pytest.approx(oracle["peak_force_n"])
        and force.max() > 0
    )
    with open_transaction() as s:
        assert s.get(Preview, tp).attempts == 1


def test_a_task_preview_solves_on_the_tasks_own_grid_capped(client) -> None:
    """Without ``intervals`` each phase keeps its own intervals (at most the preview cap);
    the solve's grid has the phase boundary on a node and says which grid it used."""
    from alcove.previews.service import MAX_PREVIEW_INTERVALS
    from alcove.previews.worker import run_preview

    me = make_account("member", "pv-grid")
    spec = small_task_spec()
    spec["phases"][0]["intervals"], spec["phases"][1]["intervals"] = 6, 4
    task_id = client.post(f"{API}/tasks", json={"name": "pv-grid", "spec": spec}, headers=me.headers).json()["id"]
    p = client.post(f"{API}/tasks/{task_id}/previews", headers=me.headers).json()
    assert p["options"] == {"intervals": None, "intervals_per_phase": [6, 4]}
    assert run_preview(p["id"], "test@host") == "succeeded"
    res = client.get(f"{API}/previews/{p['id']}", headers=me.headers).json()["result"]
    t = np.array(res["t"])
    assert (
        res["intervals"] == 10
        and res["intervals_per_phase"] == [6, 4]
        and len(t) == 11
        and "the task's own grid" in res["grid"]
    )
    assert t[6] == pytest.approx(spec["phases"][0]["duration"]) and t[-1] == pytest.approx(
        spec["phases"][0]["duration"] + spec["phases"][1]["duration"]
    )
    # a finer task than a preview may solve is capped (said in the summary); "intervals" still overrides
    big = small_task_spec()
    big["phases"][1]["intervals"] = MAX_PREVIEW_INTERVALS + 50
    capped = client.post(f"{API}/tasks/{task_id}/previews", json={"spec": big}, headers=me.headers).json()
    assert capped["options"]["intervals_per_phase"] == [8, MAX_PREVIEW_INTERVALS]
    asked = client.post(
        f"{API}/tasks/{task_id}/previews", json={"spec": big, "intervals": 5}, headers=me.headers
    ).json()
    assert asked["options"] == {"intervals": 5, "intervals_per_phase": [5, 5]}
    from alcove.previews.service import grid_summary

    assert (
        grid_summary(big, [8, MAX_PREVIEW_INTERVALS], None)
        == f"8 + {MAX_PREVIEW_INTERVALS} intervals (the task's 8 + {MAX_PREVIEW_INTERVALS + 50}, "
        f"capped at {MAX_PREVIEW_INTERVALS} per phase for a preview)"
    )
    assert grid_summary(big, [5, 5], 5).startswith("5 + 5 intervals (5 per phase, as asked")


def test_a_preview_no_worker_takes_fails_with_the_reason_and_frees_its_slot(client) -> None:
    from datetime import timedelta

    import sqlalchemy as sa

    from alcove.db import run_transaction
    from alcove.models import JobOutbox, Preview, utcnow
    from alcove.previews.service import STALE_AFTER
    from alcove.previews.worker import run_preview

    me = make_account("member", "pv-stale")
    task_id, oracle_id = _task_and_oracle(client, me)
    ids = [client.post(f"{API}/tasks/{task_id}/previews", headers=me.headers).json()["id"] for _ in range(2)]
    ids.append(client.post(f"{API}/oracles/{oracle_id}/previews", headers=me.headers).json()["id"])
    assert client.post(f"{API}/tasks/{task_id}/previews", headers=me.headers).status_code == 429
    old = utcnow() - STALE_AFTER - timedelta(seconds=5)
    # the first waited too long in the queue; the oracle one was taken by a worker that died
    run_transaction(lambda s: s.execute(sa.update(Preview).where(Preview.id == ids[0]).values(created_at=old)))
    run_transaction(  # its job reached the job queue that long ago (sent, never taken)
        lambda s: s.execute(sa.update(JobOutbox).where(JobOutbox.subject == f"preview/{ids[0]}").values(sent_at=old))
    )
    run_transaction(
        lambda s: s.execute(
            sa.update(Preview).where(Preview.id == ids[2]).values(status="running", started_at=old, attempts=1)
        )
    )

    assert client.get(f"{API}/previews/{ids[1]}", headers=me.headers).json()["status_detail"] == (
        "waiting for a worker on queue 'ocp'"
    )
    stale = client.get(f"{API}/previews/{ids[0]}", headers=me.headers).json()
    assert stale["status"] == "failed" and "no worker took it" in stale["error"] and "'ocp'" in stale["error"], stale
    assert (
        client.get(f"{API}/previews/{ids[0]}", headers=me.headers).json()["status"] == "failed"
    )  # stored, not only answered
    listed = {x["id"]: x for x in client.get(f"{API}/previews", headers=me.headers).json()}
    assert (
        listed[ids[2]]["status"] == "failed"
        and "no worker finished it" in listed[ids[2]]["error"]
        and "'oracle'" in listed[ids[2]]["error"]
    )
    assert listed[ids[1]]["status"] == "pending"  # a fresh one is left alone
    assert run_preview(ids[0], "late@host") == "skipped"  # a late delivery does not revive it
    assert client.post(f"{API}/tasks/{task_id}/previews", headers=me.headers).status_code == 202


def test_a_running_preview_whose_worker_died_fails_within_seconds_and_a_slow_one_is_left_alone(client) -> None:
    """Its worker's heartbeat is older than ALCOVE_WORKER_DEAD_SECONDS (or the worker shut
    down): failed with the worker's name and the reason when read, not after STALE_AFTER; a
    preview whose worker still beats keeps running however long it takes."""
    from datetime import timedelta

    import sqlalchemy as sa

    from alcove.db import run_transaction
    from alcove.jobs.heartbeat import beat, mark_stopped
    from alcove.models import Preview, WorkerHeartbeat, utcnow
    from alcove.settings import get_settings
    from tests.procs import unique

    me = make_account("member", "pv-dead")
    task_id, _ = _task_and_oracle(client, me)
    ids = [client.post(f"{API}/tasks/{task_id}/previews", headers=me.headers).json()["id"] for _ in range(3)]
    names = [unique("pv-w") + "@host" for _ in ids]
    for n in names:
        beat(n, starting=True)
    long_ago = utcnow() - timedelta(minutes=3)  # much less than STALE_AFTER
    for pid, n in zip(ids, names, strict=True):
        run_transaction(
            lambda s, pid=pid, n=n: s.execute(
                sa.update(Preview)
                .where(Preview.id == pid)
                .values(status="running", started_at=long_ago, worker_name=n, attempts=1)
            )
        )
    silent = utcnow() - timedelta(seconds=get_settings().worker_dead_seconds + 5)
    run_transaction(
        lambda s: s.execute(
            sa.update(WorkerHeartbeat).where(WorkerHeartbeat.name == names[0]).values(last_seen_at=silent)
        )
    )
    mark_stopped(names[1])

    got = {x["id"]: x for x in client.get(f"{API}/previews", headers=me.headers).json()}
    assert got[ids[0]]["status"] == "failed", got[ids[0]]
    assert f"the worker running it ({names[0]}) stopped beating" in got[ids[0]]["error"]
    assert got[ids[1]]["status"] == "failed" and f"({names[1]}) shut down" in got[ids[1]]["error"]
    assert got[ids[2]]["status"] == "running"  # its worker beats: a slow preview is not a dead one
    assert client.get(f"{API}/previews/{ids[0]}", headers=me.headers).json()["status"] == "failed"  # stored


# ----------------------------------------------------------------------------- through a worker process


@pytest.fixture
def live(tmp_path: Path, fresh_pg_url: str, redis_url: str, api_settings: None, monkeypatch: pytest.MonkeyPatch):
    from fastapi.testclient import TestClient

    from alcove.app import create_app
    from alcove.jobs import reset_sender
    from alcove.settings import get_settings
    from tests.procs import alcove_env, running, wait_until, worker_ready
    from tests.procs import unique as unique_name

    settings = {
        "database_url": fresh_pg_url,  # workers take up every unfinished job in their database
        "broker_url": redis_url,
        "broker_key_prefix": unique_name("alcove-pv") + ":",
        "data_dir": str(tmp_path / "data"),
    }
    for k, v in settings.items():
        monkeypatch.setenv(f"ALCOVE_{k.upper()}", v)
    get_settings.cache_clear()
    reset_sender()
    with running(
        ["worker", "--queues", "ocp,oracle", "--concurrency", "1", "--name", unique_name("pv")],
        alcove_env(**settings),
        tmp_path / "worker.log",
    ) as worker:
        wait_until(lambda: worker_ready(worker), 90, "worker ready", worker)
        yield TestClient(create_app(get_settings().model_copy(update={"static_dir": tmp_path}))), worker
    get_settings.cache_clear()
    reset_sender()


@pytest.mark.integration
@pytest.mark.slow
def test_previews_run_on_a_worker(live) -> None:
    client, worker = live
    me, admin = make_account("member", "pv-live"), make_account("admin", "pv-admin")
    task_id, oracle_id = _task_and_oracle(client, me)
    name = unique("replay")
    entry = {
        "name": name,
        "argv": [sys.executable, str(EXAMPLES / "replay_with_alcove.py"), "aux-penalty"],
        "timeout_s": 120,
    }
    assert client.post(f"{API}/admin/command-oracles", json=entry, headers=admin.headers).status_code == 201
    command = client.post(f"{API}/oracles", json={"name": "ext", "type": name, "params": {}}, headers=me.headers)
    assert command.status_code == 201, command.text

    ids = [
        client.post(f"{API}/tasks/{task_id}/previews", json={"intervals": 8}, headers=me.headers).json()["id"],
        client.post(f"{API}/oracles/{oracle_id}/previews", json={"dt": 0.01}, headers=me.headers).json()["id"],
        client.post(f"{API}/oracles/{command.json()['id']}/previews", json={"dt": 0.01}, headers=me.headers).json()[
            "id"
        ],
    ]
    deadline, done = time.monotonic() + 240, {}
    while time.monotonic() < deadline and len(done) < len(ids):
        for i in ids:
            p = client.get(f"{API}/previews/{i}", headers=me.headers).json()
            if p["status"] in ("succeeded", "failed"):
                done[i] = p
        time.sleep(0.5)
    assert len(done) == 3, worker.output()[-4000:]
    task, builtin, external = (done[i] for i in ids)
    assert all(p["status"] == "succeeded" for p in done.values()), [(p["status"], p["error"]) for p in done.values()]
    assert task["result"]["converged"] and task["worker_name"] != "test@host"
    np.testing.assert_allclose(external["result"]["t"], builtin["result"]["t"], atol=1e-9)
    np.testing.assert_allclose(
        external["result"]["fx"], builtin["result"]["fx"], rtol=1e-4, atol=1e-6 * builtin["result"]["peak_force_n"]
    )


@pytest.mark.integration
@pytest.mark.slow
@pytest.mark.skipif(shutil.which("redis-server") is None, reason="needs the redis-server program")
def test_a_preview_asked_for_while_redis_is_down_runs_when_it_is_back(
    tmp_path: Path, fresh_pg_url: str, api_settings: None, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Redis down: the preview answers 202 and says it waits for the job queue (not a wrong
    reason, and it does not go stale); Redis back: the API's outbox relay sends it and a
    worker runs it once."""
    from datetime import UTC, datetime

    from fastapi.testclient import TestClient

    from alcove.app import create_app
    from alcove.jobs import reset_sender
    from alcove.jobs.outbox import reset_broker_client
    from alcove.settings import get_settings
    from tests.procs import PrivateRedis, alcove_env, db_rows, running, wait_until, worker_ready
    from tests.procs import unique as unique_name

    redis_server = PrivateRedis(tmp_path)  # not started: the broker is down
    settings = {
        "database_url": fresh_pg_url,
        "broker_url": redis_server.url,
        "data_dir": str(tmp_path / "data"),
        "outbox_relay_seconds": "0.5",
    }
    for k, v in settings.items():
        monkeypatch.setenv(f"ALCOVE_{k.upper()}", v)
    get_settings.cache_clear()
    reset_sender()
    reset_broker_client()
    me = make_account("member", "pv-down")
    try:
        with TestClient(create_app(get_settings().model_copy(update={"static_dir": tmp_path}))) as client:
            task_id, _ = _task_and_oracle(client, me)
            t0 = time.perf_counter()
            r = client.post(f"{API}/tasks/{task_id}/previews", headers=me.headers)
            answered = time.perf_counter() - t0
            assert r.status_code == 202, r.text
            pid = r.json()["id"]
            for got in (r.json(), client.get(f"{API}/previews/{pid}", headers=me.headers).json()):
                assert got["status"] == "pending" and got["error"] is None, got
                assert got["status_detail"].startswith("waiting for the job queue"), got
            listed = {x["id"]: x for x in client.get(f"{API}/previews", headers=me.headers).json()}
            assert listed[pid]["status_detail"].startswith("waiting for the job queue")
            time.sleep(1.5)  # several relay passes meet the broker down: the job keeps waiting
            assert db_rows(fresh_pg_url, "SELECT sent_at FROM job_outbox WHERE subject = :s", s=f"preview/{pid}") == [
                (None,)
            ]

            redis_server.start()
            back = datetime.now(UTC)
            sent = wait_until(
                lambda: db_rows(
                    fresh_pg_url,
                    "SELECT sent_at FROM job_outbox WHERE subject = :s AND sent_at IS NOT NULL",
                    s=f"preview/{pid}",
                ),
                30,
                "the preview's job sent by the API's relay",
            )[0][0]
            print(
                f"\nRECOVERY preview asked for while Redis was down: answered in {answered * 1e3:.0f} ms, "
                f"sent {(sent - back).total_seconds():.1f} s after Redis was back"
            )
            assert client.get(f"{API}/previews/{pid}", headers=me.headers).json()["status_detail"] == (
                "waiting for a worker on queue 'ocp'"
            )
            with running(
                ["worker", "--queues", "ocp", "--concurrency", "1", "--name", unique_name("pvd")],
                alcove_env(**settings),
                tmp_path / "worker.log",
            ) as worker:
                wait_until(lambda: worker_ready(worker), 90, "worker ready", worker)
                done = wait_until(
                    lambda: (
                        (g := client.get(f"{API}/previews/{pid}", headers=me.headers).json())["status"]
                        in ("succeeded", "failed")
                        and g
                    ),
                    120,
                    "the preview to finish",
                    worker,
                )
            assert done["status"] == "succeeded" and done["result"]["converged"], done
            assert db_rows(fresh_pg_url, "SELECT attempts FROM previews WHERE id = :p", p=pid) == [(1,)]
            assert db_rows(
                fresh_pg_url,
                "SELECT send_count, delivered_at IS NOT NULL FROM job_outbox WHERE subject = :s",
                s=f"preview/{pid}",
            ) == [(1, True)]
    finally:
        redis_server.stop()
        get_settings.cache_clear()
        reset_sender()
        reset_broker_client()


def test_solve_once_takes_a_chain_model() -> None:
    """The one-off solve of the task editor (aux contact) on the 2-DOF head-neck preset."""
    from alcove.previews.worker import solve_task_once

    spec = {**small_task_spec(), "model": {"preset": "head-neck-2dof"}}
    out = solve_task_once(spec, [50] * len(spec["phases"]))
    assert out["converged"], out["status"]
    q = np.asarray(out["q"])
    assert q.shape == (50 * len(spec["phases"]) + 1, 2)
    # the aux contact's wrench at the nodes (the editor's force plot and arrow): a normal force
    # pushing the head away (fx >= 0), nothing out of the plane, zero where the head is clear
    from alcove.science.ocp.task_spec import ModelSpec

    w = np.asarray(out["wrench"])
    assert w.shape == (len(q), 6)
    assert np.all(w[:, [1, 2, 3, 5]] == 0) and np.all(w[:, 0] >= 0)
    chain = ModelSpec.model_validate({"preset": "head-neck-2dof"}).chain
    assert chain is not None
    gap = np.array([chain.head_gap(row) for row in q])
    clear = gap > 2e-3  # threshold: well beyond the contact's smoothing widths (about 0.1 mm)
    assert clear.any() and np.all(w[clear, 0] < 1e-6)
    assert w[:, 0].max() > 1.0 and gap.min() < 0  # the head presses into the cushion: a force
