"""Login, personal tokens (shown once, stored hashed, revocable), /me, admin. Login throttling:
test_login_throttle.py."""

from __future__ import annotations

import pytest
import sqlalchemy as sa

from tests.helpers import Account, make_account


def test_login_gives_a_bearer_token_that_authenticates(client, owner: Account) -> None:
    r = client.post("/api/v1/auth/login", json={"email": owner.email.upper(), "password": owner.password})
    assert r.status_code == 200, r.text
    token = r.json()["access_token"]
    me = client.get("/api/v1/me", headers={"Authorization": f"Bearer {token}"})
    assert me.status_code == 200 and me.json()["email"] == owner.email and me.json()["role"] == "member"
    assert client.post("/api/v1/auth/logout", headers={"Authorization": f"Bearer {token}"}).status_code == 204
    assert client.get("/api/v1/me", headers={"Authorization": f"Bearer {token}"}).status_code == 401


def test_wrong_password_and_unknown_email_get_the_same_401(client, owner: Account) -> None:
    a = client.post("/api/v1/auth/login", json={"email": owner.email, "password": "wrong"})
    b = client.post("/api/v1/auth/login", json={"email": "nobody@example.org", "password": "wrong"})
    assert a.status_code == b.status_code == 401 and a.json() == b.json()
    assert client.post("/api/v1/auth/login", json={"email": owner.email, "password": owner.password}).status_code == 200


def test_missing_or_bad_tokens_are_401_with_www_authenticate(client) -> None:
    for headers in ({}, {"Authorization": "Bearer alc_nonsense"}, {"Authorization": "Basic Zm9vOmJhcg=="}):
        r = client.get("/api/v1/me", headers=headers)
        assert r.status_code == 401 and r.headers.get("www-authenticate") == "Bearer"


def test_personal_tokens_are_shown_once_stored_hashed_and_revocable(client, owner: Account) -> None:
    from alcove.db import open_transaction
    from alcove.models import ApiToken

    r = client.post("/api/v1/me/tokens", json={"name": "notebook", "expires_in_days": 30}, headers=owner.headers)
    assert r.status_code == 201, r.text
    created = r.json()
    secret = created["token"]
    assert secret.startswith(created["token_prefix"])
    listed = client.get("/api/v1/me/tokens", headers=owner.headers).json()
    row = next(t for t in listed if t["id"] == created["id"])
    assert "token" not in row and not row["revoked"]
    with open_transaction() as s:
        stored = s.scalar(sa.select(ApiToken).where(ApiToken.id == created["id"]))
        assert secret not in (stored.token_hash, stored.token_prefix, stored.name)
    headers = {"Authorization": f"Bearer {secret}"}
    for _ in range(3):  # the token is now also in the API's short-lived token cache
        assert client.get("/api/v1/me", headers=headers).json()["id"] == owner.id
    assert client.delete(f"/api/v1/me/tokens/{created['id']}", headers=owner.headers).status_code == 204
    assert client.get("/api/v1/me", headers=headers).status_code == 401
    assert next(t for t in client.get("/api/v1/me/tokens", headers=owner.headers).json() if t["id"] == created["id"])[
        "revoked"
    ]


def test_admin_manages_users_members_may_not(client, admin: Account, other: Account) -> None:
    body = {"email": "New.Person@Example.org", "password": "long enough pw", "role": "member"}
    assert client.post("/api/v1/users", json=body, headers=other.headers).status_code == 403
    r = client.post("/api/v1/users", json=body, headers=admin.headers)
    assert r.status_code in (201, 409), r.text
    if r.status_code == 201:
        assert r.json()["email"] == "new.person@example.org"
    again = client.post("/api/v1/users", json=body, headers=admin.headers)
    assert again.status_code == 409
    short = client.post("/api/v1/users", json={**body, "password": "short"}, headers=admin.headers)
    assert short.status_code == 422 and short.json()["detail"][0]["field"] == "password"
    assert client.patch(f"/api/v1/users/{admin.id}", json={"role": "member"}, headers=admin.headers).status_code == 409


def test_changing_my_password_needs_the_current_one(client) -> None:
    me = make_account("member", "pw")
    r = client.patch(
        "/api/v1/me", json={"new_password": "another long one", "current_password": "wrong"}, headers=me.headers
    )
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "current_password"
    r = client.patch(
        "/api/v1/me",
        json={"new_password": "another long one", "current_password": me.password, "display_name": "Pat"},
        headers=me.headers,
    )
    assert r.status_code == 200 and r.json()["display_name"] == "Pat"
    assert (
        client.post("/api/v1/auth/login", json={"email": me.email, "password": "another long one"}).status_code == 200
    )


def test_deactivating_a_user_shuts_out_their_tokens_at_once(client, admin: Account) -> None:
    user = make_account("member", "leaver")
    for _ in range(3):
        assert client.get("/api/v1/me", headers=user.headers).status_code == 200
    assert client.patch(f"/api/v1/users/{user.id}", json={"is_active": False}, headers=admin.headers).status_code == 200
    assert client.get("/api/v1/me", headers=user.headers).status_code == 401
    assert client.post("/api/v1/auth/login", json={"email": user.email, "password": user.password}).status_code == 401


def test_without_redis_a_token_revoked_by_another_process_is_refused_at_once(client) -> None:
    """No shared revocation generation (the broker is not Redis): nothing is cached, every
    request reads its token from the database, so a revocation written by another process
    (here: straight to the database) is refused at the next request."""
    from alcove.db import open_transaction
    from alcove.models import ApiToken, utcnow
    from tests.helpers import make_account

    me = make_account("member", "revoked")
    for _ in range(3):
        assert client.get("/api/v1/me", headers=me.headers).status_code == 200
    with open_transaction() as s:
        s.query(ApiToken).filter_by(user_id=me.id).update({"revoked_at": utcnow()})
    r = client.get("/api/v1/me", headers=me.headers)
    assert r.status_code == 401 and r.headers["WWW-Authenticate"] == "Bearer"


class _Generation:
    """A revocation generation of this process only (the tests' stand-in for Redis)."""

    def __init__(self) -> None:
        self.value = 7

    def current(self) -> int | None:
        return self.value

    def bump(self) -> None:
        self.value += 1


@pytest.fixture
def shared_generation(monkeypatch: pytest.MonkeyPatch) -> _Generation:
    from alcove.users import revocation

    generation = _Generation()
    monkeypatch.setattr(revocation, "_generation", [generation])
    return generation


def test_a_cached_token_is_trusted_only_under_the_generation_it_was_verified_in(
    client, shared_generation: _Generation
) -> None:
    from alcove.db import open_transaction
    from alcove.models import ApiToken, utcnow
    from alcove.users import service

    me = make_account("member", "generation")
    for _ in range(2):  # the first use records last_used_at, the next one is cached
        assert client.get("/api/v1/me", headers=me.headers).status_code == 200
    with open_transaction() as s:
        assert service.cached_authentication(s, me.token) is not None
        s.query(ApiToken).filter_by(user_id=me.id).update({"revoked_at": utcnow()})  # as another process
    assert client.get("/api/v1/me", headers=me.headers).status_code == 200  # the cache, same generation
    shared_generation.bump()  # what that process does after its commit
    assert client.get("/api/v1/me", headers=me.headers).status_code == 401


def test_cached_principals_are_private_detached_copies(client, shared_generation: _Generation) -> None:
    from sqlalchemy import inspect

    from alcove.db import open_transaction
    from alcove.models import User
    from alcove.users import service

    me = make_account("member", "copies")
    for _ in range(2):  # the first use records last_used_at, the next one is cached
        assert client.get("/api/v1/me", headers=me.headers).status_code == 200
    with open_transaction() as s:
        token, user = service.cached_authentication(s, me.token)
        again, _ = service.cached_authentication(s, me.token)
        fresh = s.get(User, me.id)
        assert inspect(user).detached and not inspect(user).modified and token is not again
        assert {a.key: getattr(user, a.key) for a in inspect(User).column_attrs} == {
            a.key: getattr(fresh, a.key) for a in inspect(User).column_attrs
        }
        user.display_name = "changed here only"
        assert service.cached_authentication(s, me.token)[1].display_name != "changed here only"
        merged = s.merge(user)  # a route changes a user by merging its copy
        assert merged.display_name == "changed here only"
        s.rollback()


def _session_headers(client, email: str, password: str) -> dict[str, str]:
    r = client.post("/api/v1/auth/login", json={"email": email, "password": password})
    assert r.status_code == 200, r.text
    return {"Authorization": f"Bearer {r.json()['access_token']}"}


def _personal_headers(client, headers: dict[str, str]) -> dict[str, str]:
    r = client.post("/api/v1/me/tokens", json={"name": "script"}, headers=headers)
    assert r.status_code == 201, r.text
    return {"Authorization": f"Bearer {r.json()['token']}"}


def _works(client, headers: dict[str, str]) -> bool:
    r = client.get("/api/v1/me", headers=headers)
    assert r.status_code in (200, 401), r.text
    return r.status_code == 200


def test_a_password_change_ends_every_session_and_personal_token_of_that_user(client) -> None:
    me, bystander = make_account("member", "pw-change"), make_account("member", "bystander")
    sessions = [_session_headers(client, me.email, me.password) for _ in range(2)]
    personal = [me.headers, _personal_headers(client, me.headers)]
    for headers in [*sessions, *personal, bystander.headers]:
        for _ in range(2):  # used, and so also in the API's verified-token cache
            assert _works(client, headers)
    body = {"new_password": "a brand new password", "current_password": me.password}
    assert client.patch("/api/v1/me", json=body, headers=sessions[0]).status_code == 200
    assert [_works(client, h) for h in [*sessions, *personal]] == [False] * 4
    assert _works(client, bystander.headers)
    fresh = _session_headers(client, me.email, "a brand new password")
    listed = client.get("/api/v1/me/tokens", params={"include_sessions": True}, headers=fresh).json()
    assert [t["revoked"] for t in listed].count(False) == 1  # the new login's only


def test_a_password_change_keeps_personal_tokens_only_when_asked(client) -> None:
    me = make_account("member", "pw-keep")
    session = _session_headers(client, me.email, me.password)
    personal = [me.headers, _personal_headers(client, me.headers)]
    body = {"new_password": "a brand new password", "current_password": me.password, "keep_personal_tokens": True}
    assert client.patch("/api/v1/me", json=body, headers=session).status_code == 200
    assert not _works(client, session)
    assert [_works(client, h) for h in personal] == [True, True]


def test_keep_personal_tokens_goes_with_a_new_password_only(client) -> None:
    me = make_account("member", "pw-keep-alone")
    r = client.patch("/api/v1/me", json={"display_name": "x", "keep_personal_tokens": True}, headers=me.headers)
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "keep_personal_tokens", r.text
    assert _works(client, me.headers)


def test_an_admin_password_reset_ends_every_token_of_that_user(client, admin: Account) -> None:
    user = make_account("member", "pw-reset")
    session = _session_headers(client, user.email, user.password)
    personal = [user.headers, _personal_headers(client, user.headers)]
    for headers in [session, *personal]:
        assert _works(client, headers) and _works(client, headers)
    r = client.patch(f"/api/v1/users/{user.id}", json={"password": "reset by the admin"}, headers=admin.headers)
    assert r.status_code == 200, r.text
    assert [_works(client, h) for h in [session, *personal]] == [False] * 3
    assert _works(client, admin.headers)
    assert _works(client, _session_headers(client, user.email, "reset by the admin"))
    # a change that is not a password leaves the tokens alone
    again = _session_headers(client, user.email, "reset by the admin")
    renamed = client.patch(f"/api/v1/users/{user.id}", json={"display_name": "Sam"}, headers=admin.headers)
    assert renamed.status_code == 200
    assert _works(client, again)
