"""The phases of ``make test`` (``tests/conftest.py``): tests that start worker processes
(through the fixtures that give them a database schema or Redis of their own), drive the browser,
or sit in a listed file are marked ``serial``; the others are not. The listed serial tests that
compare timings also get ``alone`` (the third phase). Each phase is its own pytest
run, so a phase that selects nothing exits 5 (which ``make test`` fails on). Under pytest-xdist
each worker flushes a Redis database of its own."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.conftest import _redis_db_for_this_process

REPO = Path(__file__).resolve().parents[1]

SCRATCH = """
import pytest


@pytest.fixture
def fresh_pg_url():
    return "a schema of its own"


@pytest.fixture
def pg_redis(fresh_pg_url):  # like tests/campaigns/conftest.py: the serial fixture one level down
    return fresh_pg_url


def test_plain():
    pass


def test_starts_workers(pg_redis):
    pass


@pytest.mark.parametrize("n", [1, 2])
def test_plain_parametrized(n):
    pass
"""


@pytest.fixture
def scratch(pytester: pytest.Pytester) -> pytest.Pytester:
    pytester.makeconftest((REPO / "tests" / "conftest.py").read_text())
    pytester.makeini("[pytest]\nmarkers =\n    serial: not in parallel\n    alone: nothing beside it\n")
    pytester.makepyfile(test_scratch=SCRATCH)
    (pytester.path / "tests" / "campaigns").mkdir(parents=True)
    (pytester.path / "tests" / "campaigns" / "test_workers.py").write_text("def test_listed_file():\n    pass\n")
    (pytester.path / "tests" / "campaigns" / "test_recovery.py").write_text(RECOVERY)
    return pytester


#: a file with a test listed in ALONE_PATHS (the slow worker) beside a serial one that is not
RECOVERY = """
def test_a_slow_worker_keeps_its_step():
    pass


def test_a_job_whose_sender_died_after_the_commit_is_sent_by_a_workers_relay(fresh_pg_url):
    pass


def test_plain_in_a_listed_file():
    pass
"""


def selected(result: pytest.RunResult) -> set[str]:
    return {line.split("::")[-1] for line in result.outlines if "::" in line}


def test_serial_marks_worker_tests_and_listed_files_only(scratch: pytest.Pytester) -> None:
    serial = scratch.runpytest("-p", "no:cacheprovider", "--strict-markers", "-m", "serial", "--collect-only", "-q")
    assert selected(serial) == {
        "test_starts_workers",
        "test_listed_file",
        "test_a_slow_worker_keeps_its_step",
        "test_a_job_whose_sender_died_after_the_commit_is_sent_by_a_workers_relay",
    }
    rest = scratch.runpytest("-p", "no:cacheprovider", "-m", "not serial", "--collect-only", "-q")
    assert selected(rest) == {
        "test_plain",
        "test_plain_parametrized[1]",
        "test_plain_parametrized[2]",
        "test_plain_in_a_listed_file",
    }


def test_the_phases_split_serial_tests_into_parallel_ones_and_those_that_run_alone(scratch: pytest.Pytester) -> None:
    """make test's phases 2 and 3: every serial test is in exactly one of them."""
    args = ("-p", "no:cacheprovider", "--strict-markers", "--collect-only", "-q")
    alone = scratch.runpytest(*args, "-m", "alone")
    assert selected(alone) == {"test_a_slow_worker_keeps_its_step"}
    beside = scratch.runpytest(*args, "-m", "serial and not alone")
    assert selected(beside) == {
        "test_starts_workers",
        "test_listed_file",
        "test_a_job_whose_sender_died_after_the_commit_is_sent_by_a_workers_relay",
    }


def test_a_phase_that_selects_nothing_exits_5(scratch: pytest.Pytester) -> None:
    result = scratch.runpytest("-p", "no:cacheprovider", "-m", "serial", "-k", "plain")
    assert result.ret == pytest.ExitCode.NO_TESTS_COLLECTED


def test_each_xdist_worker_has_its_own_redis_database(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("PYTEST_XDIST_WORKER", raising=False)
    assert _redis_db_for_this_process("redis://127.0.0.1:6379/15") == "redis://127.0.0.1:6379/15"
    got = set()
    for worker in ("gw0", "gw1", "gw2"):
        monkeypatch.setenv("PYTEST_XDIST_WORKER", worker)
        got.add(_redis_db_for_this_process("redis://127.0.0.1:6379/15"))
    assert got == {f"redis://127.0.0.1:6379/{db}" for db in (15, 14, 13)}
    monkeypatch.setenv("PYTEST_XDIST_WORKER", "gw1")
    assert _redis_db_for_this_process("redis://h:1/0?x=1") == "redis://h:1/15?x=1"
