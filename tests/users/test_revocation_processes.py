"""Token revocation across real API processes (``alcove serve``, uvicorn) sharing one real
Redis (the broker) and PostgreSQL: a token revoked, logged out or ended by a password change
at one process is refused by the other at once, although the other has just verified it (and
keeps verified tokens in a per-process cache)."""

from __future__ import annotations

import uuid
from collections.abc import Iterator
from dataclasses import dataclass

import httpx
import pytest

from tests.helpers import make_account
from tests.procs import api_processes

pytestmark = pytest.mark.integration


@dataclass
class Api:
    url: str

    def call(self, method: str, path: str, token: str, json: object = None) -> httpx.Response:
        headers = {"Authorization": f"Bearer {token}"}
        return httpx.request(method, f"{self.url}/api/v1{path}", headers=headers, json=json, timeout=30)

    def me(self, token: str) -> int:
        return self.call("GET", "/me", token).status_code

    def login(self, email: str, password: str) -> str:
        r = httpx.post(f"{self.url}/api/v1/auth/login", json={"email": email, "password": password}, timeout=30)
        assert r.status_code == 200, r.text
        return r.json()["access_token"]


@pytest.fixture(scope="module")
def apis(
    api_settings: None, pg_url: str, redis_url: str, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[tuple[Api, Api]]:
    prefix = f"revocation-test-{uuid.uuid4().hex[:8]}:"
    with api_processes({"a": {}, "b": {}}, pg_url, redis_url, tmp_path_factory, prefix) as started:
        yield Api(started["a"][0]), Api(started["b"][0])


def _verified_by_both(a: Api, b: Api, *tokens: str) -> None:
    """Each token works at both processes (used three times each: the first use records
    last_used_at, later ones are answered from the process's verified-token cache)."""
    for token in tokens:
        assert [api.me(token) for api in (a, b, a, b, a, b)] == [200] * 6


def test_a_token_revoked_at_one_process_is_refused_by_the_other_at_once(apis: tuple[Api, Api]) -> None:
    a, b = apis
    me = make_account("member", "revoke-across")
    r = a.call("POST", "/me/tokens", me.token, json={"name": "script"})
    assert r.status_code == 201, r.text
    script = r.json()
    _verified_by_both(a, b, script["token"])
    assert a.call("DELETE", f"/me/tokens/{script['id']}", me.token).status_code == 204
    assert b.me(script["token"]) == 401
    assert b.me(me.token) == 200  # the other token of that user is untouched


def test_a_logout_at_one_process_is_refused_by_the_other_at_once(apis: tuple[Api, Api]) -> None:
    a, b = apis
    me = make_account("member", "logout-across")
    session = a.login(me.email, me.password)
    _verified_by_both(a, b, session)
    assert a.call("POST", "/auth/logout", session).status_code == 204
    assert b.me(session) == 401


def test_tokens_ended_by_a_password_change_at_one_process_are_refused_by_the_other_at_once(
    apis: tuple[Api, Api],
) -> None:
    a, b = apis
    me = make_account("member", "password-across")
    session = b.login(me.email, me.password)
    _verified_by_both(a, b, session, me.token)
    body = {"new_password": "a brand new password", "current_password": me.password}
    assert a.call("PATCH", "/me", me.token, json=body).status_code == 200
    assert [b.me(session), b.me(me.token)] == [401, 401]
