"""Names are trimmed and a name made only of spaces is refused at the field ``name``: such a
name listed as an empty, unclickable row and showed as ``"    (v1)"`` in menus. The schema says
so: at most 200 characters as sent, one of them not whitespace."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from tests.helpers import Account, small_task_spec

API = "/api/v1"
BLANK = ["", "    ", " \t\n "]


def refused_at_name(r) -> None:
    assert r.status_code == 422, r.text
    assert [e["field"] for e in r.json()["detail"]] == ["name"], r.json()


@pytest.fixture(scope="module")
def task_and_oracle(client: TestClient, owner: Account) -> tuple[int, int]:
    h = owner.headers
    task = client.post(f"{API}/tasks", json={"name": "names-task", "spec": small_task_spec()}, headers=h)
    oracle = client.post(f"{API}/oracles", json={"name": "names-oracle", "type": "aux-penalty"}, headers=h)
    assert task.status_code == 201 and oracle.status_code == 201, (task.text, oracle.text)
    return task.json()["id"], oracle.json()["id"]


@pytest.mark.parametrize("name", BLANK)
def test_a_blank_name_is_refused_at_its_field(client, owner, task_and_oracle, name) -> None:
    h = owner.headers
    task_id, oracle_id = task_and_oracle
    refused_at_name(client.post(f"{API}/tasks", json={"name": name, "spec": small_task_spec()}, headers=h))
    refused_at_name(client.put(f"{API}/tasks/{task_id}", json={"name": name}, headers=h))
    refused_at_name(client.post(f"{API}/oracles", json={"name": name, "type": "aux-penalty"}, headers=h))
    refused_at_name(client.put(f"{API}/oracles/{oracle_id}", json={"name": name}, headers=h))
    refused_at_name(client.post(f"{API}/surrogate-configs", json={"name": name}, headers=h))
    body = {"name": name, "task_id": task_id, "oracle_id": oracle_id}
    refused_at_name(client.post(f"{API}/campaigns", json=body, headers=h))
    refused_at_name(client.post(f"{API}/me/tokens", json={"name": name}, headers=h))
    refused_at_name(client.post(f"{API}/tasks/presets/head-headrest-2phase/copy", json={"name": name}, headers=h))


def test_names_are_stored_trimmed(client, owner, task_and_oracle) -> None:
    h = owner.headers
    task_id, oracle_id = task_and_oracle
    r = client.post(f"{API}/tasks", json={"name": "  padded task \t", "spec": small_task_spec()}, headers=h)
    assert r.status_code == 201 and r.json()["name"] == "padded task", r.text
    r = client.put(f"{API}/oracles/{oracle_id}", json={"name": " names-oracle "}, headers=h)
    assert r.status_code == 200 and r.json()["name"] == "names-oracle", r.text
    body = {"name": "  padded campaign ", "task_id": task_id, "oracle_id": oracle_id}
    r = client.post(f"{API}/campaigns", json=body, headers=h)
    assert r.status_code == 201, r.text
    assert client.get(f"{API}/campaigns/{r.json()['id']}", headers=h).json()["campaign"]["name"] == "padded campaign"
    r = client.post(f"{API}/me/tokens", json={"name": " notebook "}, headers=h)
    assert r.status_code == 201 and r.json()["name"] == "notebook", r.text


def test_the_schema_states_the_rule_and_the_length_counts_as_sent(client, owner) -> None:
    schema = client.get(f"{API}/openapi.json").json()["components"]["schemas"]["TaskIn"]["properties"]["name"]
    assert {k: schema[k] for k in ("type", "maxLength", "pattern")} == {
        "type": "string",
        "maxLength": 200,
        "pattern": r"\S",
    }
    h = owner.headers
    # 200 characters and padding: longer than the schema allows, refused as it says
    r = client.post(f"{API}/surrogate-configs", json={"name": " " + "n" * 200}, headers=h)
    refused_at_name(r)
    r = client.post(f"{API}/surrogate-configs", json={"name": " " + "n" * 199}, headers=h)
    assert r.status_code == 201 and r.json()["name"] == "n" * 199, r.text
