"""Login throttling across real API processes (``alcove serve``, uvicorn) sharing one real
Redis (the broker) and PostgreSQL: failures at one process count at the other, and
``X-Forwarded-For`` moves a request to another address only where the peer is a trusted
proxy. Process ``plain`` trusts no proxy; process ``behind_proxy`` trusts 127.0.0.1 (as if a
reverse proxy on the same machine forwarded to it)."""

from __future__ import annotations

import uuid
from collections.abc import Iterator
from dataclasses import dataclass

import httpx
import pytest

from tests.helpers import make_account
from tests.procs import Proc, api_processes

pytestmark = pytest.mark.integration


@dataclass
class Api:
    url: str
    proc: Proc

    def login(self, email: str, password: str, forwarded_for: str | None = None) -> httpx.Response:
        headers = {"X-Forwarded-For": forwarded_for} if forwarded_for else {}
        return httpx.post(
            f"{self.url}/api/v1/auth/login", json={"email": email, "password": password}, headers=headers, timeout=30
        )


@dataclass
class Pair:
    plain: Api
    behind_proxy: Api
    redis_url: str
    prefix: str


@pytest.fixture(scope="module")
def apis(api_settings: None, pg_url: str, redis_url: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Pair]:
    prefix = f"throttle-test-{uuid.uuid4().hex[:8]}:"
    settings = {"plain": {"trusted_proxies": ""}, "behind_proxy": {"trusted_proxies": "127.0.0.1"}}
    with api_processes(settings, pg_url, redis_url, tmp_path_factory, prefix) as started:
        yield Pair(Api(*started["plain"]), Api(*started["behind_proxy"]), redis_url, prefix)


def test_failures_at_one_process_count_at_the_other(apis: Pair) -> None:
    me = make_account("member", "two-processes")
    statuses = [apis.plain.login(me.email, "wrong").status_code for _ in range(3)]
    statuses += [apis.behind_proxy.login(me.email, "wrong").status_code for _ in range(2)]
    assert statuses == [401] * 5
    for api in (apis.plain, apis.behind_proxy):
        r = api.login(me.email, me.password)
        assert r.status_code == 429 and r.headers["Retry-After"] == "1", api.url


def test_throttle_keys_are_namespaced_expiring_and_name_no_email(apis: Pair) -> None:
    import redis

    me = make_account("member", "keys")
    assert apis.plain.login(me.email, "wrong").status_code == 401
    client = redis.Redis.from_url(apis.redis_url)
    try:
        # (the prefix also holds the broker's keys of these API processes: their outbox relays
        # reach Redis; the login throttle's keys are those under alcove:login:)
        keys = [k.decode() for k in client.scan_iter(match=f"{apis.prefix}alcove:login:*")]
        assert keys and all(":login:pair:" in k or ":login:addr:" in k for k in keys), keys
        assert all(client.pttl(k) > 0 for k in keys)
        assert not any(me.email in k or "@" in k for k in keys)
    finally:
        client.close()


def test_forwarded_for_moves_a_request_only_behind_a_trusted_proxy(apis: Pair) -> None:
    """30 failures from 127.0.0.1 block that address (at both processes: the limit is in
    Redis). An X-Forwarded-For from the untrusted peer changes nothing (before: a blocked
    127.0.0.1 got 200 with X-Forwarded-For: 9.9.9.9, as uvicorn believed it); behind the
    trusted proxy it names the client, which is another address."""
    import redis

    client = redis.Redis.from_url(apis.redis_url)
    client.delete(f"{apis.prefix}alcove:login:addr:127.0.0.1")  # a fresh window (the tests above failed too)
    client.close()
    owner = make_account("member", "xff-real")
    for i in range(30):
        r = apis.plain.login(f"spray-{i}-{uuid.uuid4().hex[:6]}@example.org", "x", forwarded_for=f"9.9.{i}.9")
        assert r.status_code == 401, (i, r.text)
    blocked = apis.plain.login(owner.email, owner.password, forwarded_for="9.9.9.9")
    assert blocked.status_code == 429 and 0 < int(blocked.headers["Retry-After"]) <= 300
    assert apis.behind_proxy.login(owner.email, owner.password).status_code == 429  # 127.0.0.1 itself
    assert apis.behind_proxy.login(owner.email, owner.password, forwarded_for="9.9.9.9").status_code == 200
