"""Shared fixtures: real PostgreSQL, SQLite and Redis.

* PostgreSQL: ``ALCOVE_TEST_PG_URL`` or ``postgresql+psycopg://{postgres|root}@127.0.0.1:5432/test``.
  Each test session gets its own schema (``search_path``), migrated with
  ``alembic upgrade head``; each test using ``pg_session`` runs inside a transaction that
  is rolled back. The schema is dropped at the end.
* SQLite: a migrated file in a temporary folder, same per-test rollback.
* Redis: ``ALCOVE_TEST_REDIS_URL`` or ``redis://127.0.0.1:6379/15`` (flushed per test session).

When a service is down the tests needing it are skipped locally.

CI never skips: when ``CI`` is set (``CI=true``), every skip is turned into a failure that
shows the skip's reason, whatever skipped: ``pytest.skip`` in a test or fixture, a
``skip``/``skipif`` marker, ``pytest.importorskip``, or a module skipped as a whole (then
its collection fails). A skip can thus never hide an import failure or a missing service
under CI (``pytest_runtest_makereport`` and ``pytest_make_collect_report`` below; tested in
``tests/test_ci_never_skips.py``). Expected failures (``xfail``) are not skips and stay as
they are.
"""

from __future__ import annotations

import contextlib
import os
import uuid
from collections.abc import Generator, Iterator
from pathlib import Path
from typing import Any
from urllib.parse import quote

import pytest
import sqlalchemy as sa
from sqlalchemy.orm import Session

pytest_plugins = ("pytester",)  # tests/test_ci_never_skips.py runs pytest on scratch projects

REPO = Path(__file__).resolve().parents[1]


# ----------------------------------------------------------------------------- CI never skips


def in_ci() -> bool:
    """True when the ``CI`` environment variable is set (to anything but the empty string)."""
    return bool(os.environ.get("CI"))


def _ci_skip_message(longrepr: object, rootpath: Path) -> str:
    if isinstance(longrepr, tuple) and len(longrepr) == 3:  # a skip's (path, line, "Skipped: reason")
        path, line, reason = longrepr
        with contextlib.suppress(ValueError):
            path = Path(path).relative_to(rootpath)
        what = f"{str(reason).removeprefix('Skipped: ')} ({path}:{line})"
    else:
        what = str(longrepr)
    return (
        f"skipped under CI (CI={os.environ.get('CI')!r}), and CI never skips: {what}. "
        "Make it run here (install or start what it needs, fix the import) or remove the test; "
        "skips are allowed only without CI."
    )


def _failure(when: str, message: str) -> pytest.CallInfo[None]:
    """A call that failed with ``message`` (no traceback), for pytest to turn into a report."""
    return pytest.CallInfo.from_call(lambda: pytest.fail(message, pytrace=False), when=when)  # type: ignore[arg-type]


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(
    item: pytest.Item, call: pytest.CallInfo[None]
) -> Generator[None, pytest.TestReport, pytest.TestReport]:
    """Under CI a skipped test (in setup, call or teardown) is reported as failed, with the reason."""
    report = yield
    if not report.skipped or hasattr(report, "wasxfail") or not in_ci():
        return report
    failed = pytest.TestReport.from_item_and_call(
        item, _failure(call.when, _ci_skip_message(report.longrepr, item.config.rootpath))
    )
    failed.duration, failed.start, failed.stop = report.duration, report.start, report.stop
    return failed


@pytest.hookimpl(wrapper=True)
def pytest_make_collect_report(
    collector: pytest.Collector,
) -> Generator[None, pytest.CollectReport, pytest.CollectReport]:
    """Under CI a module skipped as a whole (``importorskip``, ``skip(allow_module_level=True)``)
    fails to collect, with the reason."""
    report = yield
    if report.skipped and in_ci():
        excinfo = _failure("collect", _ci_skip_message(report.longrepr, collector.config.rootpath)).excinfo
        assert excinfo is not None
        report.outcome = "failed"
        report.longrepr = collector.repr_failure(excinfo)
    return report


def service_unavailable(what: str, err: BaseException | str) -> None:
    """Skip: a service this test needs is down (under CI the skip fails, see above)."""
    pytest.skip(f"{what} is not available: {err}")


# ----------------------------------------------------------------------------- services


def _pg_candidates() -> list[str]:
    env = os.environ.get("ALCOVE_TEST_PG_URL")
    if env:
        return [env]
    return [f"postgresql+psycopg://{user}@127.0.0.1:5432/test" for user in ("postgres", "root")]


_pg_base_cache: list[str | BaseException] = []


def pg_base_url() -> str:
    """A working PostgreSQL URL (database ``test``), or skip/fail."""
    if not _pg_base_cache:
        last: BaseException | None = None
        for url in _pg_candidates():
            eng = sa.create_engine(url, poolclass=sa.pool.NullPool, connect_args={"connect_timeout": 3})
            try:
                with eng.connect() as c:
                    c.exec_driver_sql("select 1")
                _pg_base_cache.append(url)
                break
            except Exception as err:
                last = err
            finally:
                eng.dispose()
        else:
            _pg_base_cache.append(last or RuntimeError("no candidate"))
    got = _pg_base_cache[0]
    if isinstance(got, BaseException):
        tried = ", ".join(sa.make_url(url).render_as_string(hide_password=True) for url in _pg_candidates())
        service_unavailable(f"PostgreSQL ({tried})", got)
    return got  # type: ignore[return-value]


def with_search_path(url: str, schema: str) -> str:
    sep = "&" if "?" in url else "?"
    return f"{url}{sep}options={quote(f'-csearch_path={schema}')}"


class PgSchema:
    """A fresh PostgreSQL schema; ``url`` points at it through search_path."""

    def __init__(self, prefix: str = "t") -> None:
        self.base = pg_base_url()
        self.name = f"{prefix}_{os.getpid()}_{uuid.uuid4().hex[:8]}"
        self.url = with_search_path(self.base, self.name)
        eng = sa.create_engine(self.base, poolclass=sa.pool.NullPool)
        with eng.begin() as c:
            c.exec_driver_sql(f'CREATE SCHEMA "{self.name}"')
        eng.dispose()

    def drop(self) -> None:
        from alcove.db import dispose_engines

        dispose_engines(close=True)
        eng = sa.create_engine(self.base, poolclass=sa.pool.NullPool)
        with eng.begin() as c:
            c.exec_driver_sql(f'DROP SCHEMA IF EXISTS "{self.name}" CASCADE')
        eng.dispose()


@pytest.fixture(scope="session")
def pg_url() -> Iterator[str]:
    """URL of a migrated PostgreSQL schema private to this test session."""
    from alcove.db import migrate

    schema = PgSchema("alcove_test")
    try:
        migrate.upgrade(schema.url)
        yield schema.url
    finally:
        schema.drop()


@pytest.fixture
def fresh_pg_url() -> Iterator[str]:
    """A migrated PostgreSQL schema private to this one test (about 2 s to migrate).

    Tests that start worker processes use it instead of the session's schema: a worker's
    reconciler and outbox relay take up every unfinished campaign in its database, so a
    campaign another test left running would occupy the workers this test counts on."""
    from alcove.db import migrate

    schema = PgSchema("alcove_workers")
    try:
        migrate.upgrade(schema.url)
        yield schema.url
    finally:
        schema.drop()


@pytest.fixture
def empty_pg_url() -> Iterator[str]:
    """URL of an empty PostgreSQL schema private to this test."""
    schema = PgSchema("alcove_empty")
    try:
        yield schema.url
    finally:
        schema.drop()


@pytest.fixture(scope="session")
def sqlite_url(tmp_path_factory: pytest.TempPathFactory) -> str:
    """URL of a migrated SQLite file private to this test session."""
    from alcove.db import migrate

    url = f"sqlite:///{tmp_path_factory.mktemp('sqlite') / 'alcove.db'}"
    migrate.upgrade(url)
    return url


def _rollback_session(url: str) -> Iterator[Session]:
    from alcove.db import make_engine

    engine = make_engine(url)
    conn = engine.connect()
    outer = conn.begin()
    session = Session(bind=conn, join_transaction_mode="create_savepoint", expire_on_commit=False)
    try:
        yield session
    finally:
        session.close()
        outer.rollback()
        conn.close()
        engine.dispose()


@pytest.fixture
def pg_session(pg_url: str) -> Iterator[Session]:
    """A session on PostgreSQL whose work (even ``commit()``) is rolled back after the test."""
    yield from _rollback_session(pg_url)


@pytest.fixture
def sqlite_session(sqlite_url: str) -> Iterator[Session]:
    yield from _rollback_session(sqlite_url)


@pytest.fixture(params=["sqlite", "postgresql"])
def db_url(request: pytest.FixtureRequest) -> str:
    """Each migrated backend in turn."""
    return request.getfixturevalue("sqlite_url" if request.param == "sqlite" else "pg_url")


@pytest.fixture(params=["sqlite", "postgresql"])
def db_session(request: pytest.FixtureRequest) -> Session:
    """A rolled-back session on each backend in turn."""
    return request.getfixturevalue("sqlite_session" if request.param == "sqlite" else "pg_session")


@pytest.fixture(scope="session")
def redis_url() -> str:
    url = os.environ.get("ALCOVE_TEST_REDIS_URL", "redis://127.0.0.1:6379/15")
    import redis

    try:
        client = redis.Redis.from_url(url, socket_connect_timeout=3)
        client.ping()
        client.flushdb()
        client.close()
    except Exception as err:
        service_unavailable(f"Redis at {url}", err)
    return url


@pytest.fixture(scope="session")
def ghost_case() -> tuple[Any, list[Any]]:
    """The ghost-force ensemble of issue 16 and its honest pool (tests/ghost_case.py; ~25 s to train)."""
    from alcove.science.geometry import DEFAULT_PRESET
    from tests.ghost_case import ghost_ensemble

    return ghost_ensemble(DEFAULT_PRESET)
