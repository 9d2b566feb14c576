"""A new campaign's request checked whole: ``POST /campaigns/check`` names every problem at
once (the schema's, the definitions it names, the rules across them), each at its field, and
creating a campaign refuses a schema-valid request with all of its other problems at once."""

from __future__ import annotations

from tests.helpers import Account, small_task_spec

API = "/api/v1"


def _definitions(client, owner: Account) -> tuple[int, int, int]:
    task = client.post(f"{API}/tasks", json={"name": "t", "spec": small_task_spec()}, headers=owner.headers).json()
    oracle = client.post(f"{API}/oracles/presets/aux-penalty/copy", headers=owner.headers).json()
    single = client.post(
        f"{API}/surrogate-configs", json={"name": "k1", "spec": {"ensemble_size": 1}}, headers=owner.headers
    ).json()
    return task["id"], oracle["id"], single["id"]


def _fields(answer: dict) -> dict[str, str]:
    return {e["field"]: e["msg"] for e in answer["errors"]}


def test_a_valid_request_is_valid_and_nothing_is_created(client, owner: Account) -> None:
    task, oracle, _ = _definitions(client, owner)
    before = len(client.get(f"{API}/campaigns", headers=owner.headers).json())
    r = client.post(
        f"{API}/campaigns/check",
        json={"name": " c ", "task_id": task, "oracle_id": oracle, "stopping": {"max_iterations": 2}},
        headers=owner.headers,
    )
    assert r.status_code == 200, r.text
    assert r.json()["valid"] is True and r.json()["errors"] == []
    assert r.json()["normalized"]["name"] == "c"
    assert len(client.get(f"{API}/campaigns", headers=owner.headers).json()) == before


def test_every_problem_at_once_schema_references_and_rules_across_them(client, owner: Account, other: Account) -> None:
    """Schema errors (an empty name, a number that is no number, a rule within a section) come
    with the problems of the definitions and across them, which the schema alone cannot see."""
    task, oracle, single = _definitions(client, owner)
    theirs = client.post(f"{API}/oracles/presets/aux-penalty/copy", headers=other.headers).json()["id"]
    body = {
        "name": "   ",
        "task_id": task,
        "oracle_id": theirs,
        "surrogate_config_id": single,
        "settings": {"strategy": "ensemble-disagreement", "batch": 2, "candidates": 4, "replay_dt": "abc"},
        "preliminary": {"samples": 1},
    }
    r = client.post(f"{API}/campaigns/check", json=body, headers=owner.headers)
    assert r.status_code == 200, r.text
    found = _fields(r.json())
    assert r.json()["valid"] is False
    assert {"name", "settings.replay_dt", "preliminary.samples", "oracle_id"} <= set(found), found
    assert "oracle" in found["oracle_id"]
    # the settings are not valid as a whole (replay_dt), so the strategy is not judged against them
    assert "settings.strategy" not in found
    # with the settings fixed, the strategy's problem with an ensemble of one joins the others
    body["settings"]["replay_dt"] = 0.0025
    found = _fields(client.post(f"{API}/campaigns/check", json=body, headers=owner.headers).json())
    assert {"name", "preliminary.samples", "oracle_id", "settings.strategy"} == set(found), found
    assert "no disagreement" in found["settings.strategy"]
    # creating it: the schema refuses first; a schema-valid request gets all the other problems at once
    body.update(name="c", preliminary={"samples": 300})
    created = client.post(f"{API}/campaigns", json={**body, "oracle_id": theirs}, headers=owner.headers)
    assert created.status_code == 422, created.text
    assert {e["field"] for e in created.json()["detail"]} == {"oracle_id", "settings.strategy"}
    body["oracle_id"] = oracle
    assert set(_fields(client.post(f"{API}/campaigns/check", json=body, headers=owner.headers).json())) == {
        "settings.strategy"
    }


def test_unknown_definitions_and_fields_are_named(client, owner: Account) -> None:
    r = client.post(
        f"{API}/campaigns/check",
        json={"name": "c", "task_id": 2_000_000_000, "oracle_id": "x", "colour": "red"},
        headers=owner.headers,
    )
    assert r.status_code == 200, r.text
    found = _fields(r.json())
    assert set(found) == {"task_id", "oracle_id", "colour"}, found
    assert client.post(f"{API}/campaigns/check", json=[1], headers=owner.headers).status_code == 422
    assert client.post(f"{API}/campaigns/check", json={"name": "c"}).status_code == 401
