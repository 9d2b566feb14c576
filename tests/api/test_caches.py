"""The per-process caches (on ``cachetools``) keep their contract: sizes, least recently used
eviction, per-entry times to live, dropping tokens, and safe use from many threads."""

from __future__ import annotations

import threading
import time
from types import SimpleNamespace

from alcove.api.caching import ResponseCache, TtlCache


def test_response_cache_is_an_lru_of_its_size() -> None:
    cache = ResponseCache(max_entries=3)
    for k in "abc":
        assert cache.get_or_build(k, lambda k=k: k.encode()) == k.encode()
    assert cache.get("a") == b"a"  # a is now the most recently used
    cache.get_or_build("d", lambda: b"d")  # evicts b, the least recently used
    assert cache.get("b") is None and [cache.get(k) for k in "acd"] == [b"a", b"c", b"d"]
    built: list[str] = []
    assert cache.get_or_build("a", lambda: built.append("a") or b"other") == b"a" and not built
    cache.clear()
    assert cache.get("a") is None


def test_ttl_cache_entries_expire_each_after_its_own_time() -> None:
    cache = TtlCache(max_entries=10)
    cache.put("short", 1, 0.05)
    cache.put("long", 2, 60)
    cache.put("never", 3, 0)  # a non-positive time to live stores nothing
    assert (cache.get("short"), cache.get("long"), cache.get("never")) == (1, 2, None)
    time.sleep(0.1)
    assert (cache.get("short"), cache.get("long")) == (None, 2)
    for i in range(20):  # full: the least recently used go first, not everything at once
        cache.put(i, i, 60)
    assert cache.get(19) == 19 and cache.get(0) is None


def test_token_cache_reads_its_time_to_live_when_an_entry_is_put_and_drops_by_token_or_user() -> None:
    from alcove.users.service import _TokenCache

    cache = _TokenCache(ttl_s=60)
    token = lambda i: SimpleNamespace(id=i)  # noqa: E731
    user = lambda i: SimpleNamespace(id=i)  # noqa: E731
    cache.put("k1", token(1), user(10))
    cache.put("k2", token(2), user(10))
    cache.put("k3", token(3), user(30))
    cache.ttl_s = 0.05
    cache.put("k4", token(4), user(40))
    time.sleep(0.1)
    assert cache.get("k4") is None and cache.get("k1")[0].id == 1
    cache.drop(token_id=3)
    assert cache.get("k3") is None and cache.get("k2") is not None
    cache.drop(user_id=10)
    assert cache.get("k1") is None and cache.get("k2") is None


def test_caches_are_safe_from_many_threads() -> None:
    responses, ttl = ResponseCache(max_entries=16), TtlCache(max_entries=16)
    errors: list[BaseException] = []

    def hammer(seed: int) -> None:
        try:
            for i in range(3000):
                key = (seed * 7 + i) % 40
                responses.get_or_build(key, lambda key=key: str(key).encode())
                assert responses.get(key) in (None, str(key).encode())
                ttl.put(key, key, 0.001 if i % 2 else 60)
                assert ttl.get(key) in (None, key)
        except BaseException as err:  # reported below
            errors.append(err)

    threads = [threading.Thread(target=hammer, args=(n,)) for n in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors[:3]
    assert len(responses._data) <= 16 and len(ttl._data) <= 16


def test_parsed_task_cache_never_returns_another_tasks_spec_for_a_reused_version_id(sqlite_session) -> None:
    """SQLite reuses a rolled-back row's id: the parsed-task cache is keyed by the spec itself,
    so the second task with the first one's version id is parsed anew, not served from the cache."""
    from alcove.models import User
    from alcove.science.ocp.task_spec import TASK_PRESETS, TaskSpec
    from alcove.tasks import service

    owner = User(email="cache-owner@example.org", role="member")
    sqlite_session.add(owner)
    sqlite_session.flush()
    base = TaskSpec.model_validate(TASK_PRESETS["head-headrest-2phase"])
    specs = [base.model_copy(update={"name": name}) for name in ("first", "second")]
    loaded, ids = [], []
    for spec in specs:
        attempt = sqlite_session.begin_nested()
        _, version = service.create(sqlite_session, owner, name=spec.name, description="", spec=spec)
        sqlite_session.flush()
        loaded.append(service.load_task(sqlite_session, version.id))
        ids.append(version.id)
        attempt.rollback()
    assert ids[0] == ids[1]  # the case the cache must survive
    assert [task.name for task in loaded] == ["first", "second"]
