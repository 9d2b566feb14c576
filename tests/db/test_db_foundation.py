"""Engines and sessions: SQLite lock contention becomes a retry, PostgreSQL URLs use
psycopg 3, and the first admin is created once."""

from __future__ import annotations

import sqlite3
import threading
import time
from pathlib import Path

import pytest
import sqlalchemy as sa

from alcove import models as m
from alcove.db import (
    get_sessionmaker,
    is_retryable_db_error,
    make_engine,
    normalize_url,
    retry_on_locked,
    run_transaction_on,
)
from alcove.db.bootstrap import ensure_first_admin


def test_postgres_urls_use_psycopg3() -> None:
    assert normalize_url("postgresql://u@h/db").drivername == "postgresql+psycopg"
    assert normalize_url("postgres://u@h/db").drivername == "postgresql+psycopg"
    assert normalize_url("sqlite:///x.db").drivername == "sqlite"


def test_retryable_errors() -> None:
    locked = sa.exc.OperationalError("x", {}, sqlite3.OperationalError("database is locked"))
    other = sa.exc.OperationalError("x", {}, sqlite3.OperationalError("no such table: y"))
    assert is_retryable_db_error(locked) and not is_retryable_db_error(other)


def test_locked_sqlite_becomes_a_retry(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'lock.db'}"
    eng = make_engine(url, connect_args={"timeout": 0.05})
    with eng.begin() as c:
        c.exec_driver_sql("CREATE TABLE t (x INTEGER)")
    # the busy timeout of our own connections is set by PRAGMA; shorten it for this test
    sa.event.listen(eng, "connect", lambda dbapi, rec: dbapi.execute("PRAGMA busy_timeout = 50"))
    eng.dispose()

    holder = sqlite3.connect(tmp_path / "lock.db", isolation_level=None, check_same_thread=False)
    holder.execute("BEGIN IMMEDIATE")
    holder.execute("INSERT INTO t VALUES (1)")
    release = threading.Timer(0.4, lambda: holder.execute("COMMIT"))
    release.start()
    calls = []

    @retry_on_locked(attempts=20, base_delay=0.02, max_delay=0.1)
    def write() -> None:
        calls.append(1)
        with eng.begin() as c:
            c.exec_driver_sql("INSERT INTO t VALUES (2)")

    t0 = time.monotonic()
    write()
    release.join()
    assert len(calls) > 1, "the first attempt should have hit the lock"
    assert time.monotonic() - t0 < 10
    with eng.connect() as c:
        assert sorted(r[0] for r in c.exec_driver_sql("SELECT x FROM t")) == [1, 2]
    holder.close()
    eng.dispose()


def test_non_retryable_errors_are_raised_at_once(tmp_path: Path) -> None:
    eng = make_engine(f"sqlite:///{tmp_path / 'e.db'}")
    calls = []

    @retry_on_locked(attempts=5)
    def bad() -> None:
        calls.append(1)
        with eng.begin() as c:
            c.exec_driver_sql("SELECT * FROM missing")

    with pytest.raises(sa.exc.OperationalError):
        bad()
    assert calls == [1]
    eng.dispose()


def test_concurrent_writers_on_sqlite_all_commit(tmp_path: Path) -> None:
    """Several threads incrementing one counter through run_transaction_on: none lost."""
    url = f"sqlite:///{tmp_path / 'c.db'}"
    with make_engine(url).begin() as c:
        c.exec_driver_sql("CREATE TABLE counter (n INTEGER)")
        c.exec_driver_sql("INSERT INTO counter VALUES (0)")
    factory = get_sessionmaker(url, immediate=True)

    def bump() -> None:
        for _ in range(20):
            run_transaction_on(factory, lambda s: s.execute(sa.text("UPDATE counter SET n = n + 1")))

    threads = [threading.Thread(target=bump) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    with factory() as s:
        assert s.execute(sa.text("SELECT n FROM counter")).scalar() == 80


def test_first_admin_is_created_once(db_session) -> None:
    # the session database is shared with tests that commit users: start (inside this
    # rolled-back transaction) from a state without any admin
    db_session.execute(sa.update(m.User).where(m.User.role == "admin").values(role="member"))
    n_users = db_session.scalar(sa.select(sa.func.count()).select_from(m.User))
    u = ensure_first_admin(db_session, "Boss@Example.org", "pw-long-enough")
    assert u is not None and u.email == "boss@example.org" and u.role == "admin" and u.check_password("pw-long-enough")
    assert ensure_first_admin(db_session, "other@example.org", "x") is None
    assert db_session.scalar(sa.select(sa.func.count()).select_from(m.User)) == n_users + 1
