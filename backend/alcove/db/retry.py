"""Retry of transactions that lost a race for the database.

On SQLite a concurrent writer surfaces as ``OperationalError: database is locked`` (after
the busy timeout) or ``SQLITE_BUSY_SNAPSHOT``; on PostgreSQL as a serialization failure or
deadlock. All of them mean "run the whole transaction again", never "answer 500".
"""

from __future__ import annotations

import functools
import logging
import random
import time
from collections.abc import Callable
from typing import ParamSpec, TypeVar, overload

from sqlalchemy import exc
from sqlalchemy.orm import Session, sessionmaker

log = logging.getLogger(__name__)

P = ParamSpec("P")
T = TypeVar("T")

_SQLITE_MARKERS = ("database is locked", "database table is locked", "database schema is locked", "sqlite_busy")
_PG_RETRY_SQLSTATES = {"40001", "40P01", "55P03"}  # serialization_failure, deadlock_detected, lock_not_available


def is_retryable_db_error(err: BaseException) -> bool:
    """True for 'database is locked' (SQLite) and serialization failures/deadlocks (PostgreSQL)."""
    if isinstance(err, exc.DBAPIError):
        orig = err.orig
        sqlstate = getattr(orig, "sqlstate", None) or getattr(orig, "pgcode", None)
        if sqlstate in _PG_RETRY_SQLSTATES:
            return True
        if isinstance(err, exc.OperationalError):
            msg = str(orig).lower()
            return any(m in msg for m in _SQLITE_MARKERS)
    return False


@overload
def retry_on_locked(
    fn: Callable[P, T], *, attempts: int = ..., base_delay: float = ..., max_delay: float = ...
) -> Callable[P, T]: ...


@overload
def retry_on_locked(
    fn: None = None, *, attempts: int = ..., base_delay: float = ..., max_delay: float = ...
) -> Callable[[Callable[P, T]], Callable[P, T]]: ...


def retry_on_locked(
    fn: Callable[P, T] | None = None, *, attempts: int = 8, base_delay: float = 0.05, max_delay: float = 2.0
) -> Callable[P, T] | Callable[[Callable[P, T]], Callable[P, T]]:
    """Decorator: call ``fn`` again (with jittered exponential backoff) when it raises a
    retryable database error. ``fn`` must run a whole transaction (open, work, commit)."""

    def wrap(f: Callable[P, T]) -> Callable[P, T]:
        @functools.wraps(f)
        def inner(*args: P.args, **kwargs: P.kwargs) -> T:
            for attempt in range(1, attempts + 1):
                try:
                    return f(*args, **kwargs)
                except exc.DBAPIError as err:
                    if attempt == attempts or not is_retryable_db_error(err):
                        raise
                    delay = min(max_delay, base_delay * 2 ** (attempt - 1)) * (0.5 + random.random())
                    log.warning(
                        "database busy (%s); retry %d/%d in %.2fs", type(err.orig).__name__, attempt, attempts, delay
                    )
                    time.sleep(delay)
            raise AssertionError("unreachable")

        return inner

    return wrap(fn) if fn is not None else wrap


def run_transaction_on(factory: sessionmaker[Session], work: Callable[[Session], T], *, attempts: int = 8) -> T:
    """Run ``work(session)`` in a fresh session and commit; on a retryable error roll back
    and run it again. ``work`` must not commit and must be safe to repeat."""

    @retry_on_locked(attempts=attempts)
    def once() -> T:
        with factory() as session, session.begin():
            return work(session)

    return once()
