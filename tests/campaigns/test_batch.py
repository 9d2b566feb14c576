"""Batch acquisition: an iteration fans out into q ocp and q oracle jobs and fans back in.

* in this process (the real protocol, no broker): the q scenarios are the seeded draws of slots
  0..q-1, each solved and replayed in its own slot; the q datasets are appended as ONE pool
  version; the in-loop RMSE is stored per pick and the iteration's is their mean; duplicate
  deliveries of finished slots are no-ops;
* real Celery workers on PostgreSQL + Redis (a schema of their own): a worker SIGKILLed in one of
  three oracle jobs costs that job only; Redis restarted between the fan-out and the fan-in loses
  nothing; two campaigns sharing one oracle worker (each capped at one oracle job) both advance.
"""

from __future__ import annotations

import shutil
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import sqlalchemy as sa

from alcove.campaigns import candidate_queries, repository
from alcove.campaigns.run import protocol
from alcove.campaigns.views import detail, picks
from alcove.db import open_transaction
from alcove.db.arrays import get_arrays
from alcove.models import Dataset, OcpSolution
from alcove.pool import repository as pool_repo
from tests.procs import PrivateRedis, db_rows, start_worker, stop_all, unique
from tests.procs import wait_until as wait_for

TASK = "head-headrest-scenarios"
Q = 3
BATCH = {"strategy": "random-scenarios", "batch": Q, "validation_motions": 0}
LIGHT: dict[str, Any] = {"preliminary": {"samples": 200, "chunks": 2}, "surrogate": {"max_epochs": 20}}


def test_a_batch_iteration_solves_q_seeded_scenarios_and_appends_them_as_one_pool_version(
    sqlite_campaign_db: str, make_campaign
) -> None:
    from alcove.science.ocp import scenarios
    from alcove.science.ocp.task_spec import task_preset

    seed = 11
    cid, jobs = make_campaign(task=TASK, seed=seed, settings=BATCH, stopping={"max_iterations": 1}, **LIGHT)
    count_datasets = sa.select(sa.func.count()).select_from(Dataset).where(Dataset.campaign_id == cid)
    protocol.drive_inline(cid, jobs)
    task = task_preset(TASK)
    with open_transaction() as s:
        assert repository.get_campaign(s, cid).status == "completed"
        k = 1
        it = repository.get_iteration(s, cid, k)
        assert it.status == "succeeded"
        steps = {(st.step, st.slot): st for st in it.steps}
        # q ocp and q oracle jobs, one evaluate and one append, each run once
        assert sorted(steps) == sorted(
            [("train", 0), ("evaluate", 0), ("append", 0)] + [(step, j) for step in ("ocp", "oracle") for j in range(Q)]
        )
        assert all(st.status == "succeeded" and st.attempts == 1 for st in steps.values())
        cands = candidate_queries.candidates(s, it.id)
        assert [c.slot for c in cands] == [c.pick for c in cands] == list(range(Q))
        for c in cands:
            # slot j solved the draw (campaign seed, k, j): its trajectory starts at the drawn state
            assert c.scenario == scenarios.draw(task, seed, k, c.slot).to_json()
            ds = s.get(Dataset, c.dataset_id)
            a = get_arrays(s, ds.content_sha256)
            np.testing.assert_allclose(a["q"][0, 0], c.scenario["values"]["initial.q.0"], atol=1e-8)
            assert ds.meta["headrest_offset"] == c.scenario["values"]["model.headrest_offset"]
        assert len({str(c.scenario["values"]) for c in cands}) == Q
        # the q datasets, in pick order, are what pool version k adds to version k-1: one version
        pv, prev = pool_repo.version_of(s, cid, k), pool_repo.version_of(s, cid, k - 1)
        assert [d.id for d in pool_repo.oracle_datasets(s, it.id)] == [c.dataset_id for c in cands]
        assert pv.n_datasets == prev.n_datasets + Q
        added = sorted(m.dataset_id for m in pv.members if m.added_in_this_version)
        assert added == sorted(c.dataset_id for c in cands)
        # the in-loop RMSE per pick, and the iteration's as their mean
        m = repository.metrics_of(s, cid, k)
        rmse = [c.force_rmse for c in cands]
        assert all(r is not None and r > 0 for r in rmse)
        assert m.force_rmse == pytest.approx(float(np.mean(rmse)), rel=1e-12)
        assert m.moment_rmse == pytest.approx(float(np.mean([c.moment_rmse for c in cands])), rel=1e-12)
        # the API's iteration list shows the oracle calls and the picks
        listed = {i.index: i for i in detail.list_iterations(s, cid)}
        assert listed[1].oracle_calls == Q and [c.pick for c in listed[1].candidates] == list(range(Q))
        n_datasets = s.scalar(count_datasets)
    # duplicate deliveries of finished slots (and of the fan-in's evaluate and append) are no-ops
    for step, slot in (("ocp", 1), ("oracle", 2), ("oracle", 0), ("evaluate", 0), ("append", 0)):
        assert protocol.run_step(cid, 1, step, 1, slot=slot)["status"] == "duplicate"
    with open_transaction() as s:
        assert s.scalar(count_datasets) == n_datasets


def test_ensemble_disagreement_replays_the_most_disputed_candidates_and_stops_when_none_is(
    sqlite_campaign_db: str, make_campaign
) -> None:
    """C = 4 candidates solved in four ocp jobs and scored by the ensemble's force std over their
    contact phase (the solution's trust diagnostic); with no minimum distance the q = 2 picks are
    the two highest scores, replayed in two oracle jobs and appended as one pool version. A
    threshold above every score stops the campaign after an iteration that asked the oracle nothing."""
    settings = {"strategy": "ensemble-disagreement", "batch": 2, "candidates": 4, "min_distance": 0.0}
    cid, jobs = make_campaign(task=TASK, seed=3, settings={**BATCH, **settings}, stopping={"max_iterations": 1})
    protocol.drive_inline(cid, jobs)
    with open_transaction() as s:
        assert repository.get_campaign(s, cid).status == "completed"
        it = repository.get_iteration(s, cid, 1)
        cands = candidate_queries.candidates(s, it.id)
        assert [c.slot for c in cands] == [0, 1, 2, 3] and all(c.converged for c in cands)
        for c in cands:
            sol = s.get(OcpSolution, c.ocp_solution_id)
            assert c.score == (sol.stats["trust"]["max_std_contact"] or 0.0) and c.score >= 0
        ranked = sorted(cands, key=lambda c: (-c.score, c.slot))
        assert [c.slot for c in sorted((c for c in cands if c.pick is not None), key=lambda c: c.pick)] == [
            c.slot for c in ranked[:2]
        ]
        assert all(c.dataset_id is not None for c in ranked[:2]) and all(c.dataset_id is None for c in ranked[2:])
        pv, prev = pool_repo.version_of(s, cid, 1), pool_repo.version_of(s, cid, 0)
        assert pv.n_datasets == prev.n_datasets + 2
        assert {(st.step, st.slot) for st in it.steps if st.step in ("ocp", "oracle")} == {
            *(("ocp", j) for j in range(4)),
            ("oracle", 0),
            ("oracle", 1),
        }
        top = ranked[0].score
        assert top > 0  # the two-member ensemble disagrees somewhere in contact
        dataset_forces = {c.slot: get_arrays(s, s.get(Dataset, c.dataset_id).content_sha256)["f"] for c in ranked[:2]}
    _what_the_user_sees(cid, ranked, dataset_forces)

    stop = {**settings, "candidates": 2}
    cid, jobs = make_campaign(
        task=TASK, seed=3, settings={**BATCH, **stop}, stopping={"max_iterations": 3, "min_disagreement": top * 2 + 1}
    )
    protocol.drive_inline(cid, jobs)
    with open_transaction() as s:
        c = repository.get_campaign(s, cid)
        assert (c.status, c.stop_reason) == ("completed", "min_disagreement")
        it = repository.get_iteration(s, cid, 1)
        assert it.oracle_calls == 0 and all(c.pick is None for c in candidate_queries.candidates(s, it.id))
        assert {st.step: st.status for st in it.steps if st.step in ("evaluate", "append")} == {
            "evaluate": "skipped",
            "append": "succeeded",
        }
        assert pool_repo.version_of(s, cid, 1).n_datasets == pool_repo.version_of(s, cid, 0).n_datasets
        why = picks.iteration_candidates(s, cid, 1)
        assert [c.why.code for c in why.candidates] == ["below-threshold"] * 2 and why.min_disagreement > top


def _what_the_user_sees(cid: int, ranked: list[Any], forces: dict[int, np.ndarray]) -> None:
    """The API of the candidates tab: every candidate ranked with why (q = 2, min_distance 0:
    the top score, then the next by distance, the rest not in the top q), each pick's curves
    (the oracle's forces of its dataset; its RMSE recomputed from them is the stored one), each
    candidate's OCP trajectory, and the series' oracle calls for the x axis."""
    from fastapi.testclient import TestClient

    from alcove.app import create_app
    from alcove.models import ApiToken, Campaign, TokenKind, User
    from alcove.settings import get_settings

    with open_transaction() as s:  # a token of the campaign's owner
        token, secret = ApiToken.issue(s.get(User, s.get(Campaign, cid).owner_id), kind=TokenKind.personal, name="t")
        s.add(token)
    headers = {"Authorization": f"Bearer {secret}"}
    settings = get_settings().model_copy(update={"static_dir": Path(get_settings().data_dir) / "no-frontend"})
    api = TestClient(create_app(settings))
    base = f"/api/v1/campaigns/{cid}/iterations/1"
    r = api.get(f"{base}/candidates", headers=headers)
    assert r.status_code == 200, r.text
    body = r.json()
    assert (body["strategy"], body["batch"], body["n_candidates"], body["min_distance"]) == (
        "ensemble-disagreement",
        2,
        4,
        0.0,
    )
    by_slot = {c["slot"]: c for c in body["candidates"]}
    assert [by_slot[c.slot]["rank"] for c in ranked] == [1, 2, 3, 4]
    assert [by_slot[c.slot]["why"]["code"] for c in ranked] == ["picked-top", "picked-far", "batch-full", "batch-full"]
    assert by_slot[ranked[1].slot]["why"]["nearest_pick"] == 0 and by_slot[ranked[0].slot]["pick"] == 0
    for pick, c in enumerate(ranked[:2]):
        curves = api.get(f"{base}/picks/{pick}/curves", headers=headers).json()
        assert (curves["pick"], curves["slot"]) == (pick, c.slot)
        f_true, f_pred, f_std = (np.array(curves[key]) for key in ("f_true", "f_pred", "f_std"))
        np.testing.assert_array_equal(f_true, forces[c.slot])
        assert f_std.shape == f_pred.shape and (f_std >= 0).all() and f_std.max() > 0  # two members disagree
        rmse = float(np.sqrt(np.mean(np.sum((f_pred[:, :3] - f_true[:, :3]) ** 2, axis=1))))
        assert rmse == pytest.approx(c.force_rmse, rel=1e-9)
    assert api.get(f"{base}/picks/2/curves", headers=headers).status_code == 404
    for c in ranked:  # every candidate's OCP solution, over the scenario it solved
        traj = api.get(f"{base}/candidates/{c.slot}/trajectory", headers=headers).json()
        assert traj["slot"] == c.slot and traj["scenario"] == c.scenario
        assert traj["q"][0][0] == pytest.approx(c.scenario["values"]["initial.q.0"], abs=1e-8)
    series = api.get(f"/api/v1/campaigns/{cid}/metrics", headers=headers).json()
    row = next(r for r in series if r["iteration_index"] == 1)
    assert row["oracle_calls"] == row["cumulative_oracle_calls"] == 2 and row["cumulative_wall_time_s"] > 0
    assert [(p["slot"], p["force_rmse"]) for p in row["picks"]] == [(c.slot, c.force_rmse) for c in ranked[:2]]


def test_the_cost_axes_add_up_oracle_calls_and_iteration_wall_time_until_each_evaluation() -> None:
    """Hand-worked: iteration 1 (1 call, 0..10 s, evaluated at 8 s), 2 (3 calls, 12..27 s,
    evaluated at 22 s: 10 s before it + 10 s of its own; the 2 s pause between them not counted),
    3 (failed: no call, no end, no metrics row: nothing of its own)."""
    from datetime import datetime, timedelta

    t0 = datetime(2026, 1, 1)
    at = [t0 + timedelta(seconds=x) for x in (0, 10, 8, 12, 27, 22, 30)]
    costs = [
        picks.Cost(1, 1, at[0], at[1], at[2]),
        picks.Cost(2, 3, at[3], at[4], at[5]),
        picks.Cost(3, 0, at[6], None, None),
    ]
    assert picks.cumulative_costs(costs) == {1: (1, 1, 8.0), 2: (3, 4, 20.0), 3: (0, 4, 25.0)}
    # iteration 0 with 2 oracle calls (pool version 0's press-family replays), 100 s of preliminary
    # work: its calls count for every later iteration, its wall time does not
    zero = picks.Cost(0, 2, t0 - timedelta(seconds=100), t0, None)
    assert picks.cumulative_costs([zero, *costs]) == {0: (2, 2, 0.0), 1: (1, 3, 8.0), 2: (3, 6, 20.0), 3: (0, 6, 25.0)}


def test_retrying_a_batch_slot_that_failed_the_campaign_runs_the_slots_it_cancelled_too(
    sqlite_campaign_db: str, make_campaign, faults
) -> None:
    """Policy stop: ocp slot 0 does not converge and fails the campaign, which cancels the queued
    slot 1. A retry runs slot 0 again and slot 1 with it; the iteration then fans in as usual."""
    from alcove.campaigns import service
    from alcove.jobs.faults import inject

    cid, jobs = make_campaign(
        task=TASK,
        seed=5,
        settings={**BATCH, "batch": 2},
        stopping={"max_iterations": 1},
        policies={"ocp_on_failure": "stop"},
        fault={"ocp": {"ipopt_max_iter": 1, "slots": [0]}},
        **LIGHT,
    )
    protocol.drive_inline(cid, jobs)
    with open_transaction() as s:
        c = repository.get_campaign(s, cid)
        assert c.status == "failed"
        it = repository.get_iteration(s, cid, 1)
        assert {(st.step, st.slot): st.status for st in it.steps if st.step == "ocp"} == {
            ("ocp", 0): "failed",
            ("ocp", 1): "cancelled",
        }
        inject(cid, None)
        c, jobs = service.retry_step(s, cid)
        assert sorted((j.step.value, j.slot, j.attempt) for j in jobs) == [("ocp", 0, 2), ("ocp", 1, 1)]
    protocol.drive_inline(cid, jobs)
    with open_transaction() as s:
        assert repository.get_campaign(s, cid).status == "completed"
        it = repository.get_iteration(s, cid, 1)
        assert all(st.status == "succeeded" for st in it.steps)
        assert pool_repo.version_of(s, cid, 1).n_datasets == pool_repo.version_of(s, cid, 0).n_datasets + 2


# ----------------------------------------------------------------------------- real workers


@pytest.fixture
def pg_url(fresh_pg_url: str) -> str:
    """Worker processes take up every unfinished step of their database: a schema of our own."""
    return fresh_pg_url


ENDED = "SELECT status, stop_reason FROM campaigns WHERE id = :c AND status IN ('completed', 'failed', 'cancelled')"
SLOTS = (
    "SELECT s.step, s.slot, s.status, s.attempts, s.worker_name FROM iteration_steps s "
    "JOIN iterations i ON i.id = s.iteration_id WHERE s.campaign_id = :c AND i.index = :k ORDER BY s.step, s.slot"
)


def slots(url: str, cid: int, k: int = 1) -> dict[tuple[str, int], tuple[Any, ...]]:
    return {(r[0], r[1]): r[2:] for r in db_rows(url, SLOTS, c=cid, k=k)}


def start(make_campaign: Any, seed: int, fault: dict[str, Any] | None = None, **settings: Any) -> int:
    """A one-iteration batch campaign started the way the API does (the first job through the outbox)."""
    from alcove.campaigns import service
    from alcove.db import run_transaction
    from alcove.jobs.campaign import send_committed, stage

    cid, _ = make_campaign(
        task=TASK,
        seed=seed,
        settings={**BATCH, **settings},
        stopping={"max_iterations": 1},
        fault=fault,
        start=False,
        **LIGHT,  # what these tests check needs no accurate model
    )
    send_committed(run_transaction(lambda s: stage(s, service.start(s, cid)[1])))
    return cid


def appended_once(url: str, cid: int, q: int) -> None:
    """Pool version 1 = version 0 + the q oracle datasets, and nothing else was stored."""
    oracle = db_rows(url, "SELECT count(*) FROM datasets WHERE campaign_id = :c AND origin = 'oracle'", c=cid)
    assert oracle == [(q,)]
    versions = db_rows(
        url,
        "SELECT version, n_datasets FROM pool_versions WHERE campaign_id = :c ORDER BY version",
        c=cid,
    )
    assert [v for v, _ in versions] == [0, 1] and versions[1][1] == versions[0][1] + q
    added = db_rows(
        url,
        "SELECT count(*) FROM pool_version_members m JOIN pool_versions p ON p.id = m.pool_version_id "
        "WHERE p.campaign_id = :c AND p.version = 1 AND m.added_in_this_version",
        c=cid,
    )
    assert added == [(q,)]


def test_a_worker_killed_in_one_of_three_oracle_jobs_costs_that_job_only(
    pg_redis_default_lease: dict[str, str], pg_url: str, tmp_path: Path, make_campaign: Any
) -> None:
    """Three oracle jobs fan out to two workers; the one replaying pick 1 (its first attempt slowed to 4 s) is
    SIGKILLed: the other worker replays pick 1 again (attempt 2) once the dead worker's heartbeat is
    stale, picks 0 and 2 keep their first and only run, and the fan-in appends the three datasets
    as one pool version. Duplicate messages of every finished step then change nothing."""
    from alcove.jobs.campaign import StepJob, enqueue

    cid = start(make_campaign, 31, {"oracle": {"sleep_s": 4, "sleep_attempts": 1, "slots": [1]}})
    # a dead worker is noticed after 4 s (production: 10 s): still the heartbeat, never the 120 s lease
    env = {
        **pg_redis_default_lease,
        "ALCOVE_WORKER_DEAD_SECONDS": "4",
        "ALCOVE_WORKER_HEARTBEAT_SECONDS": "1",
        "ALCOVE_RECONCILE_SECONDS": "1",
    }
    workers = {n: start_worker(env, tmp_path / f"{n}.log", n) for n in (unique("b") for _ in range(2))}

    def alive() -> Any:
        return next(p for p in workers.values() if p.alive())

    try:
        first = wait_for(
            lambda: (r := slots(pg_url, cid).get(("oracle", 1))) and r[0] == "running" and r, 240, "pick 1", alive()
        )
        time.sleep(1.0)
        workers[first[2].split("@")[0]].kill()
        wait_for(lambda: db_rows(pg_url, ENDED, c=cid), 240, "the campaign to end", alive())
        got = slots(pg_url, cid)
        enqueue(
            [StepJob(campaign_id=cid, iteration=1, step=st, attempt=1, slot=j) for (st, j) in got]
            + [StepJob(campaign_id=cid, iteration=1, step="oracle", attempt=2, slot=1)]
        )
        time.sleep(3.0)  # the duplicates arrive and are refused
    finally:
        stop_all(workers.values())
    assert db_rows(pg_url, ENDED, c=cid) == [("completed", "max_iterations")]
    assert slots(pg_url, cid) == got
    assert {k: v[:2] for k, v in got.items()} == {
        **{("ocp", j): ("succeeded", 1) for j in range(Q)},
        ("oracle", 0): ("succeeded", 1),
        ("oracle", 1): ("succeeded", 2),  # the killed job, and only it, ran again
        ("oracle", 2): ("succeeded", 1),
        ("train", 0): ("succeeded", 1),
        ("evaluate", 0): ("succeeded", 1),
        ("append", 0): ("succeeded", 1),
    }
    requeued = db_rows(
        pg_url, "SELECT step, data FROM campaign_events WHERE campaign_id = :c AND kind = 'step_requeued'", c=cid
    )
    assert [(st, d["slot"], d["why"]) for st, d in requeued] == [("oracle", 1, "dead")]
    runs = db_rows(pg_url, "SELECT slot, status FROM oracle_runs WHERE campaign_id = :c ORDER BY slot", c=cid)
    assert runs == [(0, "ok"), (1, "ok"), (2, "ok")]  # the killed attempt never reached its commit
    appended_once(pg_url, cid, Q)


@pytest.mark.skipif(shutil.which("redis-server") is None, reason="needs the redis-server program")
def test_a_redis_restart_between_fan_out_and_fan_in_loses_nothing(
    pg_redis_default_lease: dict[str, str],
    pg_url: str,
    tmp_path: Path,
    make_campaign: Any,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Redis stops while pick 1 (slowed to 4 s) is being replayed and stays down until that job
    has committed: whatever else was queued in Redis is lost, and the jobs the completions made
    necessary (the other picks, the fan-in's evaluate) wait in the outbox. Redis comes back empty;
    the outbox sends them again: every slot runs once, the fan-in once, nothing is redone."""
    from alcove.jobs import reset_sender
    from alcove.jobs.outbox import reset_broker_client
    from alcove.settings import get_settings

    redis_server = PrivateRedis(tmp_path)
    redis_server.start()
    monkeypatch.setenv("ALCOVE_BROKER_URL", redis_server.url)
    get_settings.cache_clear()
    reset_sender()
    reset_broker_client()
    env = {**pg_redis_default_lease, "ALCOVE_BROKER_URL": redis_server.url}
    cid = start(make_campaign, 32, {"oracle": {"sleep_s": 4, "slots": [1]}})
    procs = [start_worker(env, tmp_path / f"{n}.log", n) for n in (unique("r"), unique("r"))]
    try:
        wait_for(lambda: slots(pg_url, cid).get(("oracle", 1), ("",))[0] == "running", 240, "pick 1 running", procs[0])
        time.sleep(1.0)
        redis_server.stop()
        wait_for(lambda: slots(pg_url, cid)[("oracle", 1)][0] != "running", 60, "pick 1 to commit without Redis")
        redis_server.start()
        wait_for(lambda: db_rows(pg_url, ENDED, c=cid), 240, "the campaign to end", procs[0])
    finally:
        stop_all(procs)
        redis_server.stop()
    assert db_rows(pg_url, ENDED, c=cid) == [("completed", "max_iterations")]
    assert {k: v[:2] for k, v in slots(pg_url, cid).items()} == {
        **{(st, j): ("succeeded", 1) for st in ("ocp", "oracle") for j in range(Q)},
        **{(st, 0): ("succeeded", 1) for st in ("train", "evaluate", "append")},
    }
    appended_once(pg_url, cid, Q)


def test_two_campaigns_sharing_one_oracle_worker_both_advance(
    pg_redis_default_lease: dict[str, str], pg_url: str, tmp_path: Path, make_campaign: Any
) -> None:
    """Two batch campaigns (q = 3, each capped at one oracle job at a time) on one oracle worker
    of one process: their oracle jobs interleave (neither waits for all of the other's), the cap
    holds (never two oracle jobs of one campaign queued or running), and both complete."""
    env = pg_redis_default_lease
    cids = [start(make_campaign, seed, max_concurrent_oracle_jobs=1) for seed in (41, 42)]
    procs = [start_worker(env, tmp_path / "main.log", unique("m"), queues="default,train,ocp")]
    most = dict.fromkeys(cids, 0)
    queued_oracle = (
        "SELECT count(*) FROM iteration_steps WHERE campaign_id = :c AND step = 'oracle' AND status = 'queued'"
    )
    try:
        # the oracle worker starts once both campaigns wait on it: how fast one campaign's ocp jobs
        # run beside the other's replays must not decide the order, only the queue's fairness
        def both_wait() -> bool:
            for cid in cids:
                most[cid] = max(most[cid], db_rows(pg_url, queued_oracle, c=cid)[0][0])
            return all(n >= 1 for n in most.values())

        wait_for(
            both_wait,
            timeout=240,
            what="both campaigns queue an oracle job",
            proc=procs[0],
        )
        procs.append(start_worker(env, tmp_path / "oracle.log", unique("o"), queues="oracle"))
        deadline = time.monotonic() + 300
        while not all(db_rows(pg_url, ENDED, c=cid) for cid in cids):
            assert time.monotonic() < deadline, "the campaigns did not end"
            assert all(p.alive() for p in procs)
            for cid in cids:
                busy = db_rows(
                    pg_url,
                    "SELECT count(*) FROM iteration_steps WHERE campaign_id = :c AND step = 'oracle' "
                    "AND status IN ('queued', 'running')",
                    c=cid,
                )[0][0]
                most[cid] = max(most[cid], busy)
            time.sleep(0.05)
    finally:
        stop_all(procs)
    for cid in cids:
        assert db_rows(pg_url, ENDED, c=cid) == [("completed", "max_iterations")]
        appended_once(pg_url, cid, Q)
    assert most == dict.fromkeys(cids, 1)
    order = [
        c
        for (c,) in db_rows(
            pg_url,
            "SELECT campaign_id FROM oracle_runs WHERE campaign_id IN (:a, :b) ORDER BY started_at",
            a=cids[0],
            b=cids[1],
        )
    ]
    assert sorted(order) == sorted(cids * Q)
    # each campaign's first replay came before the other's last one: neither waited for all of the other's
    last = {cid: max(i for i, c in enumerate(order) if c == cid) for cid in cids}
    a, b = cids
    assert order.index(a) < last[b] and order.index(b) < last[a], order
