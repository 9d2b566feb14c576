"""Uploaded preliminary data is checked before it is stored: every value within a plausible
range (joint angles within the model's joint range, velocities, forces and moments within
stated bounds), against the campaign's task model when it is used; errors name the column.
Before, ``q_0 = 1e308`` was stored and a model trained on it. An empty upload name is
refused (before: it silently became "upload")."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from tests.helpers import Account, small_task_spec

API = "/api/v1"
HEADER = "simulation,t,q_0,qd_0,fx,fy,fz,mx,my,mz\n"


def csv_rows(q: float = 0.2, qd: float = 0.5, fx: float = 10.0, mx: float = 0.1, rows: int = 4) -> bytes:
    body = "".join(f"s{i % 2},{i * 0.01},{q},{qd},{fx},0,1,{mx},0,0\n" for i in range(rows))
    return (HEADER + body).encode()


def upload(client: TestClient, who: Account, content: bytes, **data: object):
    files = {"file": ("p.csv", content, "text/csv")}
    return client.post(f"{API}/preliminary-datasets", files=files, data=data, headers=who.headers)


def field_error(r) -> tuple[str, str]:
    assert r.status_code == 422, r.text
    item = r.json()["detail"][0]
    return item["field"], item["msg"]


@pytest.mark.parametrize(
    ("values", "column", "unit"),
    [
        ({"q": 1e308}, "q_0", "rad"),
        ({"q": -2.0}, "q_0", "rad"),  # beyond 90 degrees from the vertical: no model allows it
        ({"qd": 1e5}, "qd_0", "rad/s"),
        ({"fx": -3e5}, "fx", "N"),
        ({"mx": 2e4}, "mx", "N m"),
    ],
)
def test_implausible_values_are_refused_naming_the_column(client, owner, values, column, unit) -> None:
    field, msg = field_error(upload(client, owner, csv_rows(**values)))
    assert field == f"file.{column}"
    assert "lies outside" in msg and unit in msg and "row 1" in msg


def test_plausible_data_is_stored(client, owner) -> None:
    r = upload(client, owner, csv_rows(), name="plausible")
    assert r.status_code == 201, r.text
    assert [d["name"] for d in r.json()["datasets"]] == ["plausible-s0", "plausible-s1"]


def test_an_empty_name_is_refused_and_a_missing_one_is_upload(client, owner) -> None:
    field, msg = field_error(upload(client, owner, csv_rows(), name=""))
    assert field == "name" and "empty" in msg
    field, _ = field_error(upload(client, owner, csv_rows(), name="   "))
    assert field == "name"
    field, msg = field_error(upload(client, owner, csv_rows(), name="has space"))
    assert field == "name"
    r = upload(client, owner, csv_rows())
    assert r.status_code == 201 and r.json()["datasets"][0]["name"].startswith("upload-")


@pytest.fixture(scope="module")
def task_id(client: TestClient, owner: Account) -> int:
    r = client.post(f"{API}/tasks", json={"name": "ranges", "spec": small_task_spec()}, headers=owner.headers)
    assert r.status_code == 201, r.text
    return r.json()["id"]


def test_values_are_checked_against_the_task_model_range(client, owner, task_id) -> None:
    """The default model's joint range is 0.032 to 0.432 rad: 1.0 rad is plausible for some
    model, not for this task's."""
    outside = csv_rows(q=1.0)
    field, msg = field_error(upload(client, owner, outside, task_id=task_id))
    assert field == "file.q_0" and "the task's joint range" in msg
    stored = upload(client, owner, outside)  # without a task: within what any model allows
    assert stored.status_code == 201, stored.text
    ids = stored.json()["dataset_ids"]
    oracle = client.post(f"{API}/oracles/presets/aux-penalty/copy", headers=owner.headers).json()
    body = {"name": "ranges", "task_id": task_id, "oracle_id": oracle["id"], "preliminary": {"dataset_ids": ids}}
    r = client.post(f"{API}/campaigns", json=body, headers=owner.headers)
    field, msg = field_error(r)
    assert field == "preliminary.dataset_ids.0" and "q_0" in msg and "task's joint range" in msg
    ok = upload(client, owner, csv_rows(q=0.2), task_id=task_id).json()["dataset_ids"]
    body["preliminary"] = {"dataset_ids": ok}
    assert client.post(f"{API}/campaigns", json=body, headers=owner.headers).status_code == 201


def test_another_members_task_is_not_a_range(client, owner, other, task_id) -> None:
    assert upload(client, other, csv_rows(), task_id=task_id).status_code == 404


def test_a_nul_character_in_the_file_is_a_clear_error(client, owner) -> None:
    field, msg = field_error(upload(client, owner, csv_rows().replace(b"s0", b"s\x000", 1)))
    assert field.startswith("file") and msg


def test_a_chain_task_is_refused_as_the_range_of_1dof_data() -> None:
    """Data sets are 1-DOF (q_0, qd_0) so far: a task with a chain model is refused by name, not
    checked against the 1-DOF defaults its model would otherwise still carry."""
    from alcove.errors import InvalidInput
    from alcove.pool.service import state_range_of_task

    with pytest.raises(InvalidInput, match="head-neck-1dof preset only"):
        state_range_of_task({**small_task_spec(), "model": {"preset": "head-neck-2dof"}})
