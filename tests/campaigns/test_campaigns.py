"""Campaign routes on synthesized data (no worker): polling with ?after=, the response
cache following new rows, curves, state conflicts, references to others' objects,
preliminary-data upload validation."""

from __future__ import annotations

import io
import time

import numpy as np
import pytest

from tests.helpers import Account, make_account, small_task_spec, unique

API = "/api/v1"


@pytest.fixture(scope="module")
def finished(owner: Account) -> int:
    from alcove.db import open_transaction
    from tests.synthetic import synthesize_campaign

    with open_transaction() as s:
        return synthesize_campaign(s, owner.id, iterations=3, name="api-campaigns").id


def add_iteration(cid: int, k: int) -> None:
    """What the engine's evaluate step writes for a new iteration (visible to polls once the
    API's short revision reuse has passed)."""
    from alcove.db import open_transaction
    from alcove.db.arrays import put_arrays
    from alcove.models import Campaign, Iteration, IterationMetrics
    from tests.synthetic import curve_arrays

    with open_transaction() as s:
        c = s.get(Campaign, cid)
        it = Iteration(campaign_id=cid, index=k, config_version_id=c.config_versions[-1].id, status="succeeded")
        s.add(it)
        s.flush()
        s.add(
            IterationMetrics(
                campaign_id=cid,
                iteration_id=it.id,
                iteration_index=k,
                force_rmse=0.5,
                moment_rmse=0.05,
                curves_sha256=put_arrays(s, curve_arrays(k, 11, np.random.default_rng(k))),
            )
        )
    from alcove.campaigns.views.router import REVISION_TTL_S

    time.sleep(REVISION_TTL_S + 0.05)


def test_metrics_poll_returns_only_new_iterations_and_follows_new_rows(client, owner: Account, finished: int) -> None:
    url = f"{API}/campaigns/{finished}/metrics"
    full = client.get(url, headers=owner.headers).json()
    assert [m["iteration_index"] for m in full] == [1, 2, 3]
    assert [m["iteration_index"] for m in client.get(url, params={"after": 1}, headers=owner.headers).json()] == [2, 3]
    assert client.get(url, params={"after": 3}, headers=owner.headers).json() == []
    add_iteration(finished, 4)  # a cached answer must not hide it
    assert [m["iteration_index"] for m in client.get(url, params={"after": 3}, headers=owner.headers).json()] == [4]
    assert [m["iteration_index"] for m in client.get(url, headers=owner.headers).json()] == [1, 2, 3, 4]
    assert client.get(url, params={"after": -2}, headers=owner.headers).status_code == 422


def test_curves_match_the_reported_rmse(client, owner: Account, finished: int) -> None:
    metrics = {
        m["iteration_index"]: m for m in client.get(f"{API}/campaigns/{finished}/metrics", headers=owner.headers).json()
    }
    curves = client.get(f"{API}/campaigns/{finished}/iterations/2/curves", headers=owner.headers).json()
    err = np.array(curves["f_pred"]) - np.array(curves["f_true"])
    error_vector_rmse = np.sqrt(np.mean(np.sum(err[:, :3] ** 2, axis=1)))  # docs/concepts.md
    assert error_vector_rmse == pytest.approx(metrics[2]["force_rmse"])
    assert client.get(f"{API}/campaigns/{finished}/iterations/0/curves", headers=owner.headers).status_code == 404
    assert client.get(f"{API}/campaigns/{finished}/iterations/99/curves", headers=owner.headers).status_code == 404


def test_list_filters_and_detail(client, owner: Account, finished: int) -> None:
    rows = client.get(f"{API}/campaigns", params={"status": "completed", "owner": "me"}, headers=owner.headers).json()
    row = next(r for r in rows if r["id"] == finished)
    assert (
        row["task"] == "head-headrest-2phase" and row["oracle_type"] == "aux-penalty" and row["force_rmse"] is not None
    )
    assert all(r["status"] == "completed" for r in rows)
    assert finished not in {
        r["id"] for r in client.get(f"{API}/campaigns", params={"status": "running"}, headers=owner.headers).json()
    }
    assert client.get(f"{API}/campaigns", params={"status": "nonsense"}, headers=owner.headers).status_code == 422
    detail = client.get(f"{API}/campaigns/{finished}", headers=owner.headers).json()
    assert detail["campaign"]["status"] == "completed" and detail["latest_metrics"]["iteration_index"] >= 3
    pools = client.get(f"{API}/campaigns/{finished}/pool-versions", headers=owner.headers).json()
    assert [p["version"] for p in pools] == [0, 1, 2, 3] and pools[3]["parent_id"] == pools[2]["id"]


def test_invalid_transitions_are_409(client, owner: Account, finished: int) -> None:
    assert client.post(f"{API}/campaigns/{finished}/resume", headers=owner.headers).status_code == 409
    assert client.post(f"{API}/campaigns/{finished}/start", headers=owner.headers).status_code == 409


def test_a_shared_campaign_is_readable_but_not_controllable(client, owner: Account, finished: int) -> None:
    viewer = make_account("member", "viewer")
    assert client.get(f"{API}/campaigns/{finished}/metrics", headers=viewer.headers).status_code == 404
    r = client.post(
        f"{API}/shares",
        json={"object_type": "campaign", "object_id": finished, "email": viewer.email},
        headers=owner.headers,
    )
    assert r.status_code == 201
    assert client.get(f"{API}/campaigns/{finished}/metrics", headers=viewer.headers).status_code == 200
    assert client.post(f"{API}/campaigns/{finished}/cancel", headers=viewer.headers).status_code == 403
    fork = client.post(
        f"{API}/campaigns/{finished}/fork", json={"iteration": 2, "name": "my fork"}, headers=viewer.headers
    )
    assert (
        fork.status_code == 201
        and fork.json()["campaign"]["owner_id"] == viewer.id
        and fork.json()["campaign"]["source_iteration"] == 2
    )


def test_campaign_bodies_cannot_reference_others_objects(client, owner: Account, other: Account) -> None:
    task = client.post(f"{API}/tasks", json={"name": "t", "spec": small_task_spec()}, headers=owner.headers).json()
    oracle = client.post(f"{API}/oracles/presets/aux-penalty/copy", headers=owner.headers).json()
    mine = client.post(f"{API}/oracles/presets/aux-penalty/copy", headers=other.headers).json()
    r = client.post(
        f"{API}/campaigns", json={"name": "x", "task_id": task["id"], "oracle_id": mine["id"]}, headers=other.headers
    )
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "task_id"
    upload = client.post(
        f"{API}/preliminary-datasets",
        files={
            "file": ("p.csv", b"t,q_0,qd_0,fx,fy,fz,mx,my,mz\n0,0.3,0,1,0,0,0,0,0\n0.1,0.3,0,1,0,0,0,0,0\n", "text/csv")
        },
        data={"chunks": "1"},
        headers=owner.headers,
    )
    assert upload.status_code == 201, upload.text
    ids = upload.json()["dataset_ids"]
    r = client.post(
        f"{API}/campaigns",
        json={"name": "x", "task_id": task["id"], "oracle_id": oracle["id"], "preliminary": {"dataset_ids": ids}},
        headers=owner.headers,
    )
    assert r.status_code == 201
    theirs = client.post(
        f"{API}/campaigns",
        json={
            "name": "x",
            "task_id": client.post(
                f"{API}/tasks", json={"name": "t", "spec": small_task_spec()}, headers=other.headers
            ).json()["id"],
            "oracle_id": mine["id"],
            "preliminary": {"dataset_ids": ids},
        },
        headers=other.headers,
    )
    assert theirs.status_code == 422 and theirs.json()["detail"][0]["field"] == "preliminary.dataset_ids.0"


@pytest.mark.parametrize(
    ("content", "field"),
    [
        (b"t,q_0,qd_0,fx,fy,fz,mx,my\n0,0.3,0,1,0,0,0,0\n", "file"),
        (b"t,q_0,qd_0,fx,fy,fz,mx,my,mz\n0,abc,0,1,0,0,0,0,0\n", "file"),
        (b"\xff\xfe\x00garbage", "file"),
    ],
)
def test_bad_uploads_are_422_naming_the_file(client, owner: Account, content: bytes, field: str) -> None:
    r = client.post(
        f"{API}/preliminary-datasets", files={"file": ("p.csv", io.BytesIO(content), "text/csv")}, headers=owner.headers
    )
    assert r.status_code == 422, r.text
    assert r.json()["detail"][0]["field"].startswith(field)


def test_event_stream_sends_server_sent_events_and_ends_for_a_finished_campaign(
    client, owner: Account, finished: int
) -> None:
    events = client.get(f"{API}/campaigns/{finished}/events", headers=owner.headers).json()
    assert events and events[0]["kind"] == "status"
    with client.stream(
        "GET", f"{API}/campaigns/{finished}/events/stream", params={"after": 0}, headers=owner.headers
    ) as r:
        assert r.status_code == 200 and r.headers["content-type"].startswith("text/event-stream")
        text = "".join(r.iter_text())
    kinds = [line[7:] for line in text.splitlines() if line.startswith("event: ")]
    ids = [int(line[4:]) for line in text.splitlines() if line.startswith("id: ")]
    assert ids[:-1] == [e["id"] for e in events] and kinds[-1] == "ready"
    with client.stream(
        "GET", f"{API}/campaigns/{finished}/events/stream", headers={**owner.headers, "Last-Event-ID": str(ids[-2])}
    ) as r:
        assert [line for line in r.iter_text().__next__().splitlines() if line.startswith("event: ")] == [
            "event: ready"
        ]


def test_list_items_carry_the_eta_of_the_detail(client, owner: Account) -> None:
    """A running campaign with 3 finished iterations of 9 s each and max_iterations 10:
    7 to go x 9 s = 63 s, in the list row and in the detail alike."""
    from alcove.campaigns import service as campaigns
    from alcove.campaigns.config import StoppingRules
    from alcove.campaigns.schemas import CampaignConfigUpdate
    from alcove.db import open_transaction
    from alcove.models import Campaign
    from tests.synthetic import synthesize_campaign

    with open_transaction() as s:
        cid = synthesize_campaign(s, owner.id, iterations=3, name="api-eta").id
        c = s.get(Campaign, cid)
        c.status, c.finished_at, c.stop_reason = "running", None, None
        s.flush()
        campaigns.update_config(s, cid, CampaignConfigUpdate(stopping=StoppingRules(max_iterations=10)))
    row = next(
        r
        for r in client.get(f"{API}/campaigns", params={"owner": "me"}, headers=owner.headers).json()
        if r["id"] == cid
    )
    detail = client.get(f"{API}/campaigns/{cid}", headers=owner.headers).json()
    assert row["eta_s"] == pytest.approx(63.0) and detail["eta_s"] == pytest.approx(63.0)
    assert (
        row["mean_iteration_s"] == pytest.approx(9.0) and row["latest_iteration"] == 3 and row["current_iteration"] == 3
    )
    assert row["max_iterations"] == 10


def test_retry_with_nothing_failed_is_409(client, owner: Account, finished: int) -> None:
    r = client.post(f"{API}/campaigns/{finished}/retry", headers=owner.headers)
    assert r.status_code == 409 and "nothing to retry" in r.json()["detail"]
    r = client.post(f"{API}/campaigns/{finished}/retry", json={"iteration": 2, "step": "ocp"}, headers=owner.headers)
    assert r.status_code == 409 and "ocp of iteration 2 has not failed" in r.json()["detail"]
    assert client.post(f"{API}/campaigns/999999/retry", headers=owner.headers).status_code == 404


def test_series_and_iterations_are_compact_unless_asked(client, owner: Account, finished: int) -> None:
    series = client.get(f"{API}/campaigns/{finished}/metrics", headers=owner.headers).json()
    assert series and all(m["extra"] is None for m in series)
    full = client.get(f"{API}/campaigns/{finished}/metrics", params={"extra": "true"}, headers=owner.headers).json()
    assert [m["iteration_index"] for m in full] == [m["iteration_index"] for m in series] and all(
        isinstance(m["extra"], dict) for m in full
    )
    its = client.get(f"{API}/campaigns/{finished}/iterations", headers=owner.headers).json()
    assert [i["index"] for i in its][:4] == [0, 1, 2, 3] and all(i["steps"] is None and i["status"] for i in its)
    assert [
        i["index"]
        for i in client.get(f"{API}/campaigns/{finished}/iterations", params={"after": 2}, headers=owner.headers).json()
    ][:1] == [3]
    with_steps = client.get(
        f"{API}/campaigns/{finished}/iterations", params={"steps": "true"}, headers=owner.headers
    ).json()
    assert {s["step"] for s in with_steps[1]["steps"]} == {"train", "ocp", "oracle", "evaluate", "append"}


def test_curves_carry_the_replayed_torque(client, owner: Account) -> None:
    """tau on the curves' grid is the replayed motion's torque interpolated linearly: a torque
    linear in time must come back exactly on any grid."""
    from alcove.db import open_transaction
    from alcove.db.arrays import put_arrays
    from alcove.models import IterationMetrics, OracleRun
    from tests.synthetic import synthesize_campaign

    with open_transaction() as s:
        cid = synthesize_campaign(s, owner.id, iterations=1, name="api-tau", curve_samples=21).id
        m = s.query(IterationMetrics).filter_by(campaign_id=cid, iteration_index=1).one()
        t = np.linspace(0.0, 1.0, 7)
        s.add(
            OracleRun(
                campaign_id=cid,
                iteration_id=m.iteration_id,
                oracle_version_id=_oracle_version(s, cid),
                attempt=1,
                status="ok",
                input_sha256=put_arrays(
                    s, {"t": t, "q": 0.3 + 0 * t[:, None], "qd": 0 * t[:, None], "tau": (2.0 - 3.0 * t)[:, None]}
                ),
            )
        )
    curves = client.get(f"{API}/campaigns/{cid}/iterations/1/curves", headers=owner.headers).json()
    tau = np.array(curves["tau"])
    assert tau.shape == (21, 1)
    np.testing.assert_allclose(tau[:, 0], 2.0 - 3.0 * np.array(curves["t"]), atol=1e-12)


def _oracle_version(s, cid: int) -> int:
    from alcove.models import Campaign

    return s.get(Campaign, cid).oracle_version_id


def test_polls_with_the_etag_get_a_bodiless_304_until_something_changes(client, owner: Account, other: Account) -> None:
    from alcove.db import open_transaction
    from tests.synthetic import synthesize_campaign

    with open_transaction() as s:
        cid = synthesize_campaign(s, owner.id, iterations=2, name="api-etag", curve_samples=11).id
    url = f"{API}/campaigns/{cid}/metrics"
    first = client.get(url, headers=owner.headers)
    etag = first.headers["ETag"]
    again = client.get(url, headers={**owner.headers, "If-None-Match": etag})
    assert again.status_code == 304 and again.content == b"" and again.headers["ETag"] == etag
    assert client.get(url, headers={"If-None-Match": etag}).status_code == 401  # still authenticated
    assert client.get(url, headers={**other.headers, "If-None-Match": etag}).status_code == 404  # and authorized
    assert (
        client.get(url, params={"after": 1}, headers={**owner.headers, "If-None-Match": etag}).status_code == 200
    )  # another query
    add_iteration(cid, 3)
    changed = client.get(url, headers={**owner.headers, "If-None-Match": etag})
    assert (
        changed.status_code == 200
        and [m["iteration_index"] for m in changed.json()] == [1, 2, 3]
        and changed.headers["ETag"] != etag
    )
    curves = client.get(f"{API}/campaigns/{cid}/iterations/2/curves", headers=owner.headers)
    assert (
        client.get(
            f"{API}/campaigns/{cid}/iterations/2/curves",
            headers={**owner.headers, "If-None-Match": curves.headers["ETag"]},
        ).status_code
        == 304
    )
    assert (
        client.get(
            f"{API}/campaigns/{cid}/iterations/1/curves",
            headers={**owner.headers, "If-None-Match": curves.headers["ETag"]},
        ).status_code
        == 200
    )


def test_the_polled_detail_is_a_304_until_anything_it_shows_changes(client, owner: Account, other: Account) -> None:
    from alcove.campaigns import repository as repo
    from alcove.campaigns import service as campaigns
    from alcove.campaigns.machine.apply import complete_step
    from alcove.campaigns.machine.state_machine import Outcome, StepRef
    from alcove.campaigns.presets import oracle_version_for, surrogate_config_version_for, task_version_from_preset
    from alcove.campaigns.schemas import CampaignCreate
    from alcove.db import open_transaction
    from alcove.models import StepName

    with open_transaction() as s:
        data = CampaignCreate(
            name="api-detail-etag",
            task_version_id=task_version_from_preset(s, owner.id, "head-headrest-2phase"),
            oracle_version_id=oracle_version_for(s, owner.id, "aux-penalty"),
            surrogate_config_version_id=surrogate_config_version_for(s, owner.id, None),
        )
        cid = campaigns.create_campaign(s, owner.id, data).id
        campaigns.start(s, cid)  # the preliminary step is queued (no job is sent)
    url = f"{API}/campaigns/{cid}"
    seen: list[str] = []

    def changed() -> dict:
        """The detail answers 200 with a new ETag to every ETag seen so far (a stale poll)."""
        r = client.get(url, headers={**owner.headers, "If-None-Match": seen[-1]} if seen else owner.headers)
        assert r.status_code == 200 and r.headers["ETag"] not in seen
        seen.append(r.headers["ETag"])
        again = client.get(url, headers={**owner.headers, "If-None-Match": seen[-1]})
        assert again.status_code == 304 and again.content == b"" and again.headers["ETag"] == seen[-1]
        return r.json()

    first = changed()
    assert first["current"]["steps"][0]["status"] == "queued" and first["can_edit"] is True
    refused = client.get(url, headers=other.headers)
    assert refused.status_code == 404
    for etag in seen:  # another user is refused as before, never a 304
        r = client.get(url, headers={**other.headers, "If-None-Match": etag})
        assert r.status_code == 404 and r.json() == refused.json()
    assert client.get(url, headers={"If-None-Match": seen[-1]}).status_code == 401

    with open_transaction() as s:  # a worker claims the step, then heartbeats
        step_id = repo.get_step(s, cid, 0, "preliminary").id
        assert repo.claim_step(s, step_id, 1, "token", "worker@host", 60.0)
    claimed = changed()["current"]["steps"][0]
    assert claimed["status"] == "running"
    with open_transaction() as s:
        assert repo.extend_lease(s, step_id, "token", 60.0) == (True, False)
    assert changed()["current"]["steps"][0]["heartbeat_at"] > claimed["heartbeat_at"]
    with open_transaction() as s:  # the step completes: iteration 1's training is queued
        complete_step(
            s,
            repo.get_campaign(s, cid),
            StepRef(0, StepName.preliminary),
            repo.get_step(s, cid, 0, "preliminary"),
            Outcome.succeeded,
        )
    done = changed()
    assert done["campaign"]["current_iteration"] == 1 and done["current"]["steps"][0]["step"] == "train"

    assert client.post(f"{url}/pause", headers=owner.headers).status_code == 200
    assert changed()["campaign"]["status"] in ("pausing", "paused")

    viewer = make_account("member", "detail-viewer")
    r = client.post(
        f"{API}/shares",
        json={"object_type": "campaign", "object_id": cid, "email": viewer.email},
        headers=owner.headers,
    )
    assert r.status_code == 201
    shared = client.get(
        url, headers={**viewer.headers, "If-None-Match": seen[-1]}
    )  # the owner's ETag: can_edit differs
    assert shared.status_code == 200 and shared.json()["can_edit"] is False and shared.headers["ETag"] != seen[-1]


def test_a_forks_metrics_can_include_the_inherited_iterations(client, owner: Account, finished: int) -> None:
    """A fork at iteration 2 of a 3-iteration campaign: with ``inherited=true`` its series
    starts with the source's iterations 1 and 2 (flagged, with the source's id); a fork of
    that fork at 1 inherits only iteration 1, through two levels."""
    fork = client.post(
        f"{API}/campaigns/{finished}/fork", json={"iteration": 2, "name": unique("fork")}, headers=owner.headers
    ).json()["id"]
    plain = client.get(f"{API}/campaigns/{fork}/metrics", headers=owner.headers).json()
    assert plain == []
    rows = client.get(f"{API}/campaigns/{fork}/metrics", params={"inherited": True}, headers=owner.headers).json()
    assert [(r["campaign_id"], r["iteration_index"], r["inherited"]) for r in rows] == [
        (finished, 1, True),
        (finished, 2, True),
    ]
    fork2 = client.post(
        f"{API}/campaigns/{fork}/fork", json={"iteration": 1, "name": unique("fork")}, headers=owner.headers
    )
    assert fork2.status_code == 201, fork2.text
    rows = client.get(
        f"{API}/campaigns/{fork2.json()['id']}/metrics", params={"inherited": True}, headers=owner.headers
    ).json()
    assert [(r["campaign_id"], r["iteration_index"]) for r in rows] == [(finished, 1)]
    own = client.get(f"{API}/campaigns/{finished}/metrics", params={"inherited": True}, headers=owner.headers).json()
    assert own and not any(r["inherited"] for r in own)


@pytest.mark.parametrize(
    ("settings", "stopping", "field"),
    [
        ({"batch": 2}, {}, "settings.batch"),  # strategy paper replays one trajectory
        ({"strategy": "ensemble-disagreement", "batch": 4, "candidates": 3}, {}, "settings.batch"),
        ({"strategy": "ensemble-disagreement", "candidates": 0}, {}, "settings.candidates"),
        ({"strategy": "random-scenarios", "max_concurrent_oracle_jobs": 0}, {}, "settings.max_concurrent_oracle_jobs"),
        ({"strategy": "ensemble-disagreement", "min_distance": -1}, {}, "settings.min_distance"),
        ({"strategy": "ensemble-disagreement"}, {"min_disagreement": 0}, "stopping.min_disagreement"),
    ],
)
def test_bad_batch_settings_are_422_naming_the_field(client, owner: Account, settings, stopping, field) -> None:
    task = client.post(f"{API}/tasks", json={"name": "t", "spec": small_task_spec()}, headers=owner.headers).json()
    oracle = client.post(f"{API}/oracles/presets/aux-penalty/copy", headers=owner.headers).json()
    body = {"name": "x", "task_id": task["id"], "oracle_id": oracle["id"], "settings": settings}
    if stopping:
        body["stopping"] = {"max_iterations": 2, **stopping}
    r = client.post(f"{API}/campaigns", json=body, headers=owner.headers)
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == field, r.text


def test_ensemble_disagreement_with_an_ensemble_of_one_is_422_naming_the_strategy(client, owner: Account) -> None:
    """An ensemble of one member has no disagreement: every candidate would score 0. Refused
    at creation, naming settings.strategy; K = 2 is accepted, and K = 1 with random-scenarios."""
    task = client.post(f"{API}/tasks", json={"name": "t", "spec": small_task_spec()}, headers=owner.headers).json()
    oracle = client.post(f"{API}/oracles/presets/aux-penalty/copy", headers=owner.headers).json()
    sizes = {}
    for k in (1, 2):
        sizes[k] = client.post(
            f"{API}/surrogate-configs", json={"name": f"k{k}", "spec": {"ensemble_size": k}}, headers=owner.headers
        ).json()["id"]
    body = {"name": "x", "task_id": task["id"], "oracle_id": oracle["id"]}
    ed = {"strategy": "ensemble-disagreement", "batch": 2, "candidates": 4}
    r = client.post(
        f"{API}/campaigns", json={**body, "surrogate_config_id": sizes[1], "settings": ed}, headers=owner.headers
    )
    assert r.status_code == 422, r.text
    detail = r.json()["detail"][0]
    assert detail["field"] == "settings.strategy" and "no disagreement" in detail["msg"], r.text
    ok = client.post(
        f"{API}/campaigns", json={**body, "surrogate_config_id": sizes[2], "settings": ed}, headers=owner.headers
    )
    assert ok.status_code == 201, ok.text
    single = client.post(
        f"{API}/campaigns",
        json={**body, "surrogate_config_id": sizes[1], "settings": {"strategy": "random-scenarios"}},
        headers=owner.headers,
    )
    assert single.status_code == 201, single.text
