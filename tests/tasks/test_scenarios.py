"""The scenario preview route: a few scenarios drawn from a task's ranges, for the task editor."""

from __future__ import annotations

from tests.helpers import Account

API = "/api/v1"


def preview(client, who: Account, task_id: int, **body):
    return client.post(f"{API}/tasks/{task_id}/scenarios/preview", json=body, headers=who.headers)


def test_a_preview_draws_reproducible_scenarios_within_the_ranges(client, owner: Account, other: Account) -> None:
    r = client.post(f"{API}/tasks/presets/head-headrest-scenarios/copy", json={"name": "scen"}, headers=owner.headers)
    assert r.status_code == 201, r.text
    task = r.json()
    first = preview(client, owner, task["id"], n=4, seed=3)
    assert first.status_code == 200, first.text
    out = first.json()
    assert [s["iteration"] for s in out["scenarios"]] == [1, 2, 3, 4]
    ranges = {r["parameter"]: (r["low"], r["high"]) for r in out["ranges"]}
    assert set(ranges) == {"initial.q.0", "initial.qd.0", "model.headrest_offset"}
    for sc in out["scenarios"]:
        assert set(sc["values"]) == set(ranges)
        for p, v in sc["values"].items():
            assert ranges[p][0] <= v <= ranges[p][1]
        assert sc["spec"]["ranges"] is None
        assert sc["spec"]["initial"]["q"] == [sc["values"]["initial.q.0"]]
        assert sc["spec"]["model"]["headrest_offset"] == sc["values"]["model.headrest_offset"]
    # the same seed draws the same scenarios, another seed others
    assert preview(client, owner, task["id"], n=4, seed=3).json() == out
    other_seed = preview(client, owner, task["id"], n=4, seed=4).json()
    assert other_seed["scenarios"][0]["values"] != out["scenarios"][0]["values"]
    # a draft from the editor is previewed instead of the stored spec; its errors name the field
    draft = {**task["spec"], "ranges": [{"parameter": "initial.q.0", "low": 0.15, "high": 0.9}]}
    bad = preview(client, owner, task["id"], n=2, spec=draft)
    assert bad.status_code == 422
    assert bad.json()["detail"][0]["field"] == "spec.ranges.0.high", bad.json()
    assert "joint range" in bad.json()["detail"][0]["msg"]
    # a normal range's draft previews with its shape; a shape field the distribution does not take is named
    shaped = {"parameter": "initial.q.0", "low": 0.15, "high": 0.3, "distribution": "normal", "mean": 0.2, "std": 0.01}
    ok = preview(client, owner, task["id"], n=3, spec={**task["spec"], "ranges": [shaped]})
    assert ok.status_code == 200, ok.text
    assert ok.json()["ranges"][0]["distribution"] == "normal"
    assert all(0.15 <= s["values"]["initial.q.0"] <= 0.3 for s in ok.json()["scenarios"])
    bad = preview(client, owner, task["id"], n=2, spec={**task["spec"], "ranges": [{**shaped, "mode": 0.2}]})
    assert bad.status_code == 422
    assert bad.json()["detail"][0]["field"] == "spec.ranges.0.mode", bad.json()
    assert "only with distribution triangular" in bad.json()["detail"][0]["msg"]
    assert preview(client, owner, task["id"], n=0).status_code == 422
    # private to who may see the task; authenticated only
    assert preview(client, other, task["id"]).status_code == 404
    assert client.post(f"{API}/tasks/{task['id']}/scenarios/preview", json={}).status_code == 401


def test_a_task_without_ranges_previews_as_itself(client, owner: Account) -> None:
    r = client.post(f"{API}/tasks/presets/head-headrest-2phase/copy", json={"name": "paper"}, headers=owner.headers)
    task = r.json()
    out = preview(client, owner, task["id"], n=2).json()
    assert out["ranges"] == []
    assert [s["values"] for s in out["scenarios"]] == [{}, {}]
    assert all(s["spec"] == task["spec"] for s in out["scenarios"])
