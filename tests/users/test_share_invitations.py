"""Sharing does not tell a member whether an e-mail has an account: a share to an address
without one is an invitation, answered and listed exactly like a share to an account, that
grants nothing until an account is made with that address (which then gets it). Before, a
share to an unknown address answered 422 "no active user with this e-mail"."""

from __future__ import annotations

import uuid

from fastapi.testclient import TestClient

from tests.helpers import Account, make_account

API = "/api/v1"
FIELDS = ("created_at", "email", "id", "object_id", "object_type", "permission")


def new_task(client: TestClient, owner: Account) -> int:
    from tests.helpers import small_task_spec

    body = {"name": f"shared-{uuid.uuid4().hex[:6]}", "spec": small_task_spec()}
    r = client.post(f"{API}/tasks", json=body, headers=owner.headers)
    assert r.status_code == 201, r.text
    return r.json()["id"]


def share(client: TestClient, owner: Account, task_id: int, email: str, permission: str = "view"):
    body = {"object_type": "task", "object_id": task_id, "email": email, "permission": permission}
    return client.post(f"{API}/shares", json=body, headers=owner.headers)


def shape(r) -> tuple[int, tuple[str, ...]]:
    return r.status_code, tuple(sorted(r.json()))


def test_sharing_answers_alike_for_registered_unknown_and_inactive_addresses(client, owner, admin) -> None:
    task_id = new_task(client, owner)
    registered = make_account("member", "grantee")
    inactive = make_account("member", "inactive")
    r = client.patch(f"{API}/users/{inactive.id}", json={"is_active": False}, headers=admin.headers)
    assert r.status_code == 200
    unknown = f"nobody-{uuid.uuid4().hex[:8]}@example.org"
    answers = {email: share(client, owner, task_id, email) for email in (registered.email, inactive.email, unknown)}
    shapes = {shape(r) for r in answers.values()}
    assert shapes == {(201, FIELDS)}, [(r.status_code, r.text) for r in answers.values()]
    listed = client.get(
        f"{API}/shares", params={"object_type": "task", "object_id": task_id}, headers=owner.headers
    ).json()
    assert [(s["email"], s["permission"]) for s in listed] == [
        (registered.email, "view"),
        (inactive.email, "view"),
        (unknown, "view"),
    ]
    assert {tuple(sorted(s)) for s in listed} == {FIELDS}


def test_an_invitation_grants_nothing_until_the_account_is_made(client, owner, admin) -> None:
    task_id = new_task(client, owner)
    email = f"Later-{uuid.uuid4().hex[:8]}@Example.org"
    assert share(client, owner, task_id, email, "edit").status_code == 201
    assert share(client, owner, task_id, email, "view").status_code == 201  # sharing again: the permission
    r = client.post(
        f"{API}/users", json={"email": email, "password": "long enough pw", "role": "member"}, headers=admin.headers
    )
    assert r.status_code == 201, r.text
    login = client.post(f"{API}/auth/login", json={"email": email, "password": "long enough pw"})
    headers = {"Authorization": f"Bearer {login.json()['access_token']}"}
    got = client.get(f"{API}/tasks/{task_id}", headers=headers)
    assert got.status_code == 200 and not got.json()["can_edit"]
    listed = client.get(
        f"{API}/shares", params={"object_type": "task", "object_id": task_id}, headers=owner.headers
    ).json()
    assert [(s["email"], s["permission"]) for s in listed] == [(email.lower(), "view")]


def test_an_invitation_can_be_withdrawn(client, owner, admin) -> None:
    task_id = new_task(client, owner)
    email = f"withdrawn-{uuid.uuid4().hex[:8]}@example.org"
    invitation = share(client, owner, task_id, email).json()
    other = make_account("member", "not-the-owner")
    assert client.delete(f"{API}/shares/{invitation['id']}", headers=other.headers).status_code == 404
    assert client.delete(f"{API}/shares/{invitation['id']}", headers=owner.headers).status_code == 204
    r = client.post(
        f"{API}/users", json={"email": email, "password": "long enough pw", "role": "member"}, headers=admin.headers
    )
    assert r.status_code == 201
    login = client.post(f"{API}/auth/login", json={"email": email, "password": "long enough pw"})
    headers = {"Authorization": f"Bearer {login.json()['access_token']}"}
    assert client.get(f"{API}/tasks/{task_id}", headers=headers).status_code == 404


def test_bad_addresses_are_refused_naming_the_field(client, owner) -> None:
    task_id = new_task(client, owner)
    for email, reason in (("not an address", "pattern"), (owner.email.upper(), "you own this task")):
        r = share(client, owner, task_id, email)
        assert r.status_code == 422, r.text
        detail = r.json()["detail"][0]
        assert detail["field"] == "email" and (reason in detail["msg"] or reason in detail["type"]), detail
