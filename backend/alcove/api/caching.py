"""Serving polled routes cheaply: serialized JSON bodies cached per process with weak
ETags (a bodiless 304 when the client has the answer), a small expiring map, and lean
single-SELECT reads on their own pooled connection."""

from __future__ import annotations

import hashlib
import threading
import time
from collections.abc import Callable
from typing import Any

import sqlalchemy as sa
from cachetools import LRUCache, TLRUCache
from fastapi import Request, Response
from starlette.concurrency import run_in_threadpool

from alcove.db import get_engine

#: ``responses=`` entry of a route answering 304 to a matching ``If-None-Match``.
NOT_MODIFIED: dict[int | str, dict[str, Any]] = {
    304: {"description": "not modified (the `If-None-Match` ETag still matches)"}
}


class ResponseCache:
    """A small thread-safe LRU (``cachetools.LRUCache``) of serialized JSON bodies. Keys carry
    what makes an entry stale (content hashes, row counts, the campaign's ``updated_at``), so
    entries are never invalidated explicitly; a hot dashboard poll costs the access check and
    one count."""

    def __init__(self, max_entries: int = 256) -> None:
        self.max_entries = max_entries
        self._data: LRUCache[Any, bytes] = LRUCache(maxsize=max_entries)
        self._lock = threading.Lock()

    def get(self, key: Any) -> bytes | None:
        with self._lock:
            return self._data.get(key)

    def get_or_build(self, key: Any, build: Callable[[], bytes]) -> bytes:
        with self._lock:
            body = self._data.get(key)
        if body is not None:
            return body
        body = build()  # outside the lock: a slow build must not hold up other requests
        with self._lock:
            self._data[key] = body
        return body

    def clear(self) -> None:
        with self._lock:
            self._data.clear()


RESPONSES = ResponseCache()


async def cached_json(request: Request, key: tuple[Any, ...], build: Callable[[], bytes]) -> Response:
    """The cached body for ``key`` (built in the thread pool on a miss) with a weak ETag
    derived from the key; 304 without a body when the client already has it."""
    etag = 'W/"' + hashlib.blake2b(repr(key).encode(), digest_size=12).hexdigest() + '"'
    headers = {"ETag": etag, "Cache-Control": "no-store"}  # an account's data: kept by no cache
    if etag in request.headers.get("if-none-match", ""):
        return Response(status_code=304, headers=headers)
    body = RESPONSES.get(key)
    if body is None:
        body = await run_in_threadpool(RESPONSES.get_or_build, key, build)
    return Response(body, media_type="application/json", headers=headers)


class TtlCache:
    """Small thread-safe map whose entries expire, each after its own time to live (per API
    process): a ``cachetools.TLRUCache``, least recently used entries evicted first when full."""

    def __init__(self, max_entries: int = 4096) -> None:
        self.max_entries = max_entries
        # values are (ttl_s, value): the entry expires ttl_s after it was put
        self._data: TLRUCache[Any, tuple[float, Any]] = TLRUCache(
            maxsize=max_entries, ttu=lambda _key, value, now: now + value[0], timer=time.monotonic
        )
        self._lock = threading.Lock()

    def get(self, key: Any) -> Any:
        with self._lock:
            hit = self._data.get(key)
        return None if hit is None else hit[1]

    def put(self, key: Any, value: Any, ttl_s: float) -> None:
        if ttl_s <= 0:
            return
        with self._lock:
            self._data[key] = (ttl_s, value)

    def clear(self) -> None:
        with self._lock:
            self._data.clear()


def read(query: Callable[..., Any], *args: Any) -> Any:
    """``query(conn, *args)`` on a connection of :func:`read_engine`."""
    for attempt in (1, 2):
        try:
            with read_engine().connect() as conn:
                return query(conn, *args)
        except sa.exc.DBAPIError as err:
            # no pre-ping on this pool: a connection the server closed (restart, idle
            # timeout) fails here once, is discarded, and the query runs again on a new one
            if attempt == 2 or not err.connection_invalidated:
                raise
    raise AssertionError("unreachable")


_READ_ENGINES: dict[sa.Engine, sa.Engine] = {}
_read_lock = threading.Lock()


def read_engine() -> sa.Engine:
    """An engine for the single-SELECT reads of the polled routes. On PostgreSQL: its own
    small pool in autocommit mode without pre-ping (a SELECT needs no transaction; returning
    the connection costs no ROLLBACK and taking it no extra round trip). On SQLite: the
    request engine."""
    engine = key = get_engine()
    proxy = _READ_ENGINES.get(key)
    if proxy is None:
        with _read_lock:
            proxy = _READ_ENGINES.get(key)
            if proxy is None:
                if engine.dialect.name == "postgresql":
                    from alcove.db.engine import make_engine

                    proxy = make_engine(
                        engine.url,
                        pool_pre_ping=False,
                        pool_size=4,
                        max_overflow=8,
                        pool_recycle=1800,
                        isolation_level="AUTOCOMMIT",
                    )
                else:
                    proxy = engine
                _READ_ENGINES[key] = proxy
    return proxy
