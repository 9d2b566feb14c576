"""Shared fixtures: real PostgreSQL, SQLite and Redis.

* PostgreSQL: ``ALCOVE_TEST_PG_URL`` or ``postgresql+psycopg://{postgres|root}@127.0.0.1:5432/test``.
  Each test session gets its own schema (``search_path``), migrated with
  ``alembic upgrade head``; each test using ``pg_session`` runs inside a transaction that
  is rolled back. The schema is dropped at the end.
* SQLite: a migrated file in a temporary folder, same per-test rollback.
* Redis: ``ALCOVE_TEST_REDIS_URL`` or ``redis://127.0.0.1:6379/15`` (flushed per test session).
* The app over HTTP: ``client`` (the real app in a TestClient on the session's PostgreSQL schema)
  and three accounts, ``owner``, ``other`` and ``admin``, for every domain's route tests.

When a service is down the tests needing it are skipped locally.

Three phases (``make test``), each its own pytest run:

1. the tests not marked ``serial``, on two pytest-xdist workers (``-n 2``);
2. the ``serial`` tests not marked ``alone``, also on two xdist workers: they start worker or API
   processes, kill them, restart a Redis server of their own or drive the browser, each with a
   PostgreSQL schema, Redis key prefix, data folder and ports of its own, but two of them beside
   two other tests' processes would overload the machine;
3. the ``alone`` tests, one after the other, nothing beside them: they compare times, or hold a
   live worker to a dead-worker threshold of a few seconds that a neighbour's load could break.

``serial`` is applied here, at collection (:func:`pytest_collection_modifyitems`), to every test
that starts worker or API processes, kills them, restarts Redis, drives the browser, or
measures time against its neighbours (see ``SERIAL_FIXTURES`` and ``SERIAL_PATHS``), and
``alone`` (with ``serial``) to those of ``ALONE_PATHS``; a test file's other tests stay in the
parallel phase. Each xdist worker has its own PostgreSQL schemas (named after the process),
SQLite files (its own temporary folder) and Redis database (:func:`redis_url`). Under xdist a
file's tests stay together on one worker (``--dist loadfile``: module fixtures are built once),
except those of ``ONE_TEST_PER_UNIT`` (handed out one by one), the files that share an expensive
session fixture go to the same worker (``SAME_WORKER``), and the longest start first
(``LONG_FIRST``).

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
from urllib.parse import quote, urlsplit, urlunsplit

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


# ----------------------------------------------------------------------------- the phases of make test

#: a test that uses one of these starts worker or API processes (its own PostgreSQL schema, Redis)
#: or the browser's ``alcove up``: it runs in the serial phase
SERIAL_FIXTURES = frozenset({"fresh_pg_url", "redis_url", "alcove_server"})

#: folders, files and tests in the serial phase, and why (besides the tests the fixtures above catch)
SERIAL_PATHS = {
    "tests/campaigns/test_workers.py": "starts and kills worker processes on the embedded default",
    "tests/jobs/test_worker_e2e.py": "starts worker and `alcove up` processes on the embedded default",
    "tests/api/test_serve_restart.py": "starts and SIGKILLs `alcove serve` on the embedded default",
}

#: serial tests that run in the third phase, with nothing beside them, and why
ALONE_PATHS = {
    "tests/oracles/test_slurm_node_failure.py": (
        "takes the test cluster's only node down: a Slurm job of another test beside it would fail with it"
    ),
    "tests/users/test_login_throttle.py::test_enumeration_timing_existing_and_unknown_emails_answer_alike": (
        "compares login times (paired, but a neighbour's load is noise)"
    ),
    "tests/campaigns/test_recovery.py::test_a_killed_workers_step_runs_again_within_seconds": (
        "a 4 s dead-worker threshold: a live worker slowed by a neighbour must not look dead"
    ),
    "tests/campaigns/test_recovery.py::test_a_slow_worker_keeps_its_step": (
        "a live worker must keep beating within a 4 s dead-worker threshold"
    ),
}

#: files that share an expensive session fixture run on one xdist worker (the fixture is built once)
SAME_WORKER = {
    "tests/cli/test_ocp_cli.py": "ghost_case",  # the ghost-force ensemble, ~25 s to train
    "tests/science/surrogate/test_trust.py": "ghost_case",
    "tests/e2e/test_browser.py": "alcove_server",  # `alcove up` for the browser (serial phase)
    "tests/e2e/test_csp.py": "alcove_server",
}


def _relpath(item: pytest.Item) -> str:
    try:
        return item.path.relative_to(item.config.rootpath).as_posix()
    except ValueError:  # outside the rootdir
        return item.path.as_posix()


def _listed(item: pytest.Item, paths: dict[str, str]) -> bool:
    path = _relpath(item)
    test = f"{path}::{item.name.split('[')[0]}"
    return any(path == p or test == p or path.startswith(p + "/") for p in paths)


def is_serial(item: pytest.Item) -> bool:
    if _listed(item, SERIAL_PATHS) or _listed(item, ALONE_PATHS):
        return True
    return not SERIAL_FIXTURES.isdisjoint(getattr(item, "fixturenames", ()))


def is_alone(item: pytest.Item) -> bool:
    return _listed(item, ALONE_PATHS)


@pytest.hookimpl(tryfirst=True)  # before ``-m`` deselects by marker
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        if is_serial(item):
            item.add_marker(pytest.mark.serial)
        if is_alone(item):
            item.add_marker(pytest.mark.alone)


#: files whose tests share no expensive fixture and together take minutes: each test is handed out
#: on its own, so that both workers share them
ONE_TEST_PER_UNIT = frozenset(
    {
        "tests/science/oracles/test_ccx_oracle.py",
        # the serial phase's (each test has a schema, key prefix, data folder and ports of its own)
        "tests/campaigns/test_workers.py",
        "tests/campaigns/test_batch.py",
        "tests/campaigns/test_recovery.py",
        "tests/jobs/test_worker_e2e.py",
    }
)

#: the parallel phase's longest files, tests (of ``ONE_TEST_PER_UNIT``) or ``SAME_WORKER`` groups,
#: longest first: handed out before the others, so that none starts last while the other worker
#: idles (from the durations of CI and of one local run; one missing here only starts later)
_CCX = "tests/science/oracles/test_ccx_oracle.py::"
_WORKERS = "tests/campaigns/test_workers.py::"
LONG_FIRST: tuple[str, ...] = (
    f"{_CCX}test_peak_force_at_the_default_mesh_is_within_5_percent_of_a_refined_mesh",  # ~60 s
    "tests/e2e/test_frontend.py",  # Vitest on one thread, ~60 s
    f"{_CCX}test_planar_motion_gives_a_symmetric_wrench_and_runs_from_the_cli",  # ~40 s
    "tests/cli/test_surrogate_cli.py",  # ~45 s in all
    "tests/test_reproduce_quick.py",  # the quick reproduction, ~27 s
    "ghost_case",  # the ghost-force ensemble, ~25 s to train, and the tests on it
    "tests/campaigns/test_validation_suite.py",
    "tests/campaigns/test_flows.py",
    f"{_CCX}test_a_deep_press_that_stalled_ccx_replays_with_sane_physics",
    "tests/science/surrogate/test_warm_protocol.py",
    # the serial phase's
    "alcove_server",  # `alcove up` and three browser runs, ~65 s
    "tests/api/test_schemathesis.py",  # a live `alcove serve` and a time budget of 40 s, ~55 s
    f"{_WORKERS}test_campaign_run_without_a_worker_names_the_queue_it_waits_on",  # ~27 s
    f"{_WORKERS}test_killing_the_controlling_process_leaves_a_campaign_that_a_new_worker_finishes",
    f"{_WORKERS}test_alcove_campaign_run_on_the_embedded_default",
    "tests/campaigns/test_batch.py::test_a_redis_restart_between_fan_out_and_fan_in_loses_nothing",
    f"{_WORKERS}test_sigkill_of_a_worker_during_an_oracle_job_loses_and_duplicates_nothing",
    "tests/campaigns/test_batch.py::test_a_worker_killed_in_one_of_three_oracle_jobs_costs_that_job_only",
    f"{_WORKERS}test_an_api_restart_mid_campaign_changes_nothing_and_the_new_api_controls_it",
)


@pytest.hookimpl(optionalhook=True)  # a hook of pytest-xdist: unknown without it (``-p no:xdist``)
def pytest_xdist_make_scheduler(config: pytest.Config, log: Any) -> Any:
    """``--dist loadfile``, except that the files of ``SAME_WORKER`` count as one file, the tests
    of ``ONE_TEST_PER_UNIT`` as one file each, and those of ``LONG_FIRST`` are handed out first
    (then xdist's order: most tests first)."""
    if config.getoption("dist") != "loadfile":
        return None
    from xdist.scheduler import LoadFileScheduling

    rank = {scope: i for i, scope in enumerate(LONG_FIRST)}

    class Scheduler(LoadFileScheduling):
        ordered = False

        def _split_scope(self, nodeid: str) -> str:
            path = super()._split_scope(nodeid)
            return nodeid if path in ONE_TEST_PER_UNIT else SAME_WORKER.get(path, path)

        def _assign_work_unit(self, node: Any) -> None:
            if not self.ordered:  # the first assignment: the queue is complete
                self.ordered = True
                queue = sorted(self.workqueue.items(), key=lambda unit: rank.get(unit[0], len(rank)))
                self.workqueue.clear()
                self.workqueue.update(queue)
            super()._assign_work_unit(node)

    return Scheduler(config, log)


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


@pytest.fixture(scope="session")
def _migrated_sqlite_template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A migrated SQLite file that no test writes to; ``private_sqlite_url`` copies it."""
    from alcove.db import migrate

    path = tmp_path_factory.mktemp("sqlite-template") / "alcove.db"
    migrate.upgrade(f"sqlite:///{path}")
    return path


@pytest.fixture
def private_sqlite_url(_migrated_sqlite_template: Path, tmp_path: Path) -> str:
    """URL of a migrated SQLite file private to this test, for what must hold of a database that
    other tests never touched (no worker heartbeat, no campaign): the session's ``sqlite_url`` is
    shared by every test of one test process, which leave rows behind."""
    import sqlite3

    path = tmp_path / "private.db"
    with (
        contextlib.closing(sqlite3.connect(_migrated_sqlite_template)) as src,
        contextlib.closing(sqlite3.connect(path)) as dst,
    ):
        src.backup(dst)
    return f"sqlite:///{path}"


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


def _redis_db_for_this_process(url: str) -> str:
    """``url`` itself, or under pytest-xdist worker ``gwN`` the database N below it (mod 16):
    each worker flushes its own database, never another's."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    if not worker.startswith("gw"):
        return url
    parts = urlsplit(url)
    db = (int(parts.path.strip("/") or 0) - int(worker[2:])) % 16
    return urlunsplit(parts._replace(path=f"/{db}"))


@pytest.fixture(scope="session")
def redis_url() -> str:
    """Redis for this test session, flushed at its start: ``ALCOVE_TEST_REDIS_URL`` or
    ``redis://127.0.0.1:6379/15`` (under xdist, one database per worker)."""
    url = _redis_db_for_this_process(os.environ.get("ALCOVE_TEST_REDIS_URL", "redis://127.0.0.1:6379/15"))
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
    """The ghost-force ensemble and its honest pool (tests/ghost_case.py; ~25 s to train)."""
    from alcove.science.geometry import DEFAULT_PRESET
    from tests.ghost_case import ghost_ensemble

    return ghost_ensemble(DEFAULT_PRESET)


# ----------------------------------------------------------------------------- the app over HTTP
# The real app (TestClient) on the session's migrated PostgreSQL schema, for every domain's
# route tests. Three users: ``owner`` and ``other`` (members) and ``admin``, each with a bearer
# token (``Account.headers``; tests/helpers.py). Data is committed (the API opens its own
# sessions), so tests use unique names.


@pytest.fixture(scope="session")
def api_settings(pg_url: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    mp = pytest.MonkeyPatch()
    mp.setenv("ALCOVE_DATABASE_URL", pg_url)
    mp.setenv("ALCOVE_DATA_DIR", str(tmp_path_factory.mktemp("alcove-api")))
    mp.delenv("ALCOVE_BROKER_URL", raising=False)
    mp.delenv("ALCOVE_COMMAND_ORACLES_FILE", raising=False)
    from alcove.settings import get_settings

    get_settings.cache_clear()
    yield
    mp.undo()
    get_settings.cache_clear()


@pytest.fixture(scope="session")
def app(api_settings: None, tmp_path_factory: pytest.TempPathFactory) -> Any:
    from alcove.app import create_app
    from alcove.settings import get_settings

    settings = get_settings().model_copy(update={"static_dir": tmp_path_factory.mktemp("no-frontend")})
    return create_app(settings)


@pytest.fixture(scope="session")
def client(app: Any) -> Any:
    from fastapi.testclient import TestClient

    return TestClient(app)


def _without_a_running_campaigns_limit(account: Any) -> Any:
    """The session's members start campaigns in many tests, and no worker runs them (they stay
    queued): the running-campaigns limit would make later tests' campaigns wait depending on the
    order the tests run in. The limits' own tests use fresh accounts."""
    from alcove.db import open_transaction
    from alcove.models import User
    from alcove.users.limits import set_own
    from alcove.users.schemas import JobLimitsUpdate

    with open_transaction() as s:
        user = s.get(User, account.id)
        assert user is not None
        set_own(s, user, JobLimitsUpdate(max_running_campaigns=None))
    return account


@pytest.fixture(scope="session")
def owner(api_settings: None) -> Any:
    from tests.helpers import make_account

    return _without_a_running_campaigns_limit(make_account("member", "owner"))


@pytest.fixture(scope="session")
def other(api_settings: None) -> Any:
    from tests.helpers import make_account

    return _without_a_running_campaigns_limit(make_account("member", "other"))


@pytest.fixture(scope="session")
def admin(api_settings: None) -> Any:
    from tests.helpers import make_account

    return make_account("admin", "admin")
