"""Process-wide engines and session factories, configured from :mod:`alcove.settings`.

* :func:`get_engine` / :func:`get_sessionmaker`: the normal engine (deferred ``BEGIN`` on
  SQLite) for requests and reads.
* :func:`get_write_sessionmaker`: on SQLite its transactions start with ``BEGIN
  IMMEDIATE`` (jobs that read then write); on PostgreSQL it is the normal factory.
* :func:`open_transaction`: ``with open_transaction() as s:`` one transaction, committed when
  the block ends, rolled back on error, tried once (reads, and writes that must not repeat).
* :func:`run_transaction`: ``run_transaction(work)`` runs a function in a committed write
  transaction, run again on "database is locked" / serialization failures (so ``work`` must be
  safe to repeat); :func:`alcove.db.retry.run_transaction_on` is the same on a given session factory.

Workers forked by Celery must call :func:`dispose_engines` in the child
(``worker_process_init``) so they do not share pooled connections with the parent.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TypeVar

from sqlalchemy import Engine
from sqlalchemy.orm import Session, sessionmaker

from alcove.db.engine import is_sqlite, make_engine
from alcove.db.retry import run_transaction_on

T = TypeVar("T")

_lock = threading.Lock()
_engines: dict[tuple[str, bool], Engine] = {}
_factories: dict[tuple[str, bool], sessionmaker[Session]] = {}


def _url(url: str | None) -> str:
    if url:
        return url
    from alcove.settings import get_settings

    return get_settings().database_url


def get_engine(url: str | None = None, *, immediate: bool = False) -> Engine:
    key = (_url(url), immediate and is_sqlite(_url(url)))
    with _lock:
        eng = _engines.get(key)
        if eng is None:
            eng = _engines[key] = make_engine(key[0], immediate=key[1])
        return eng


def get_sessionmaker(url: str | None = None, *, immediate: bool = False) -> sessionmaker[Session]:
    key = (_url(url), immediate and is_sqlite(_url(url)))
    with _lock:
        f = _factories.get(key)
    if f is None:
        f = sessionmaker(bind=get_engine(key[0], immediate=key[1]), expire_on_commit=False)
        with _lock:
            f = _factories.setdefault(key, f)
    return f


def get_write_sessionmaker(url: str | None = None) -> sessionmaker[Session]:
    return get_sessionmaker(url, immediate=True)


@contextmanager
def open_transaction(url: str | None = None, *, immediate: bool = False) -> Iterator[Session]:
    """A session in a transaction: commit on success, roll back on error."""
    factory = get_sessionmaker(url, immediate=immediate)
    with factory() as session, session.begin():
        yield session


def run_transaction(work: Callable[[Session], T], *, url: str | None = None, attempts: int = 8) -> T:
    """Run ``work(session)`` in one committed write transaction, retried when the database
    is busy. ``work`` must not commit and must be safe to run again."""
    return run_transaction_on(get_write_sessionmaker(url), work, attempts=attempts)


def dispose_engines(close: bool = False) -> None:
    """Forget pooled connections (call in forked children with ``close=False``)."""
    with _lock:
        for eng in _engines.values():
            eng.dispose(close=close)
        if close:
            _engines.clear()
            _factories.clear()
