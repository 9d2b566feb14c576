"""Engines for the two supported databases.

* SQLite (embedded default): WAL journal, ``busy_timeout``, foreign keys on,
  ``synchronous=NORMAL``. pysqlite's own transaction handling is switched off and alcove
  emits ``BEGIN`` itself (the SQLAlchemy-documented recipe), so transactions start
  where SQLAlchemy thinks they start. Engines made with ``immediate=True`` begin with
  ``BEGIN IMMEDIATE``: the write lock is taken up front, waits honour the busy timeout,
  and a read-then-write transaction cannot fail half way with "database is locked".
* PostgreSQL via psycopg 3 (``postgresql+psycopg://``; ``postgresql://`` and
  ``postgres://`` are rewritten to it), with ``pool_pre_ping``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import sqlalchemy as sa
from sqlalchemy import event
from sqlalchemy.engine import URL, Engine, make_url

SQLITE_BUSY_TIMEOUT_MS = 30_000


def normalize_url(url: str | URL) -> URL:
    u = make_url(url) if isinstance(url, str) else url
    if u.drivername in ("postgresql", "postgres", "postgresql+psycopg2"):
        u = u.set(drivername="postgresql+psycopg")
    return u


def is_sqlite(url: str | URL | Engine) -> bool:
    if isinstance(url, Engine):
        return url.dialect.name == "sqlite"
    return normalize_url(url).get_backend_name() == "sqlite"


def make_engine(
    url: str | URL, *, immediate: bool = False, foreign_keys: bool = True, echo: bool = False, **kwargs: Any
) -> Engine:
    """Create an engine with alcove's per-database settings (see the module docstring).

    ``foreign_keys=False`` is for SQLite migrations only: batch mode recreates tables, and
    that must not cascade or fail on foreign keys (checked afterwards instead).
    """
    u = normalize_url(url)
    if u.get_backend_name() == "sqlite":
        db = u.database
        if db and db != ":memory:" and not db.startswith("file:"):
            Path(db).expanduser().parent.mkdir(parents=True, exist_ok=True)
        connect_args = {
            "check_same_thread": False,
            "timeout": SQLITE_BUSY_TIMEOUT_MS / 1000,
            **kwargs.pop("connect_args", {}),
        }
        engine = sa.create_engine(u, echo=echo, connect_args=connect_args, **kwargs)
        _configure_sqlite(engine, immediate=immediate, foreign_keys=foreign_keys)
        return engine
    if u.get_backend_name() == "postgresql":
        kwargs.setdefault("pool_pre_ping", True)
        kwargs.setdefault("pool_size", 5)
        kwargs.setdefault("max_overflow", 10)
        return sa.create_engine(u, echo=echo, **kwargs)
    return sa.create_engine(u, echo=echo, **kwargs)


def _configure_sqlite(engine: Engine, *, immediate: bool, foreign_keys: bool = True) -> None:
    begin_sql = "BEGIN IMMEDIATE" if immediate else "BEGIN"

    @event.listens_for(engine, "connect")
    def _on_connect(dbapi_connection: Any, connection_record: Any) -> None:
        # take transaction control away from pysqlite (we emit BEGIN in "begin" below)
        dbapi_connection.isolation_level = None
        cur = dbapi_connection.cursor()
        try:
            cur.execute(f"PRAGMA busy_timeout = {SQLITE_BUSY_TIMEOUT_MS}")
            cur.execute(f"PRAGMA foreign_keys = {'ON' if foreign_keys else 'OFF'}")
            if _is_file_db(engine):
                mode = cur.execute("PRAGMA journal_mode = WAL").fetchone()
                if mode and str(mode[0]).lower() != "wal":  # pragma: no cover - e.g. network filesystems
                    raise RuntimeError(f"SQLite refused WAL mode (got {mode[0]!r}) for {engine.url}")
                cur.execute("PRAGMA synchronous = NORMAL")
        finally:
            cur.close()

    @event.listens_for(engine, "begin")
    def _on_begin(conn: sa.Connection) -> None:
        conn.exec_driver_sql(begin_sql)


def _is_file_db(engine: Engine) -> bool:
    db = engine.url.database
    return bool(db) and db != ":memory:" and "mode=memory" not in str(db)
