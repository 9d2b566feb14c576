"""The rule of ``tests/conftest.py``: under CI (``CI=true``) every kind of skip is a failure that
shows the skip's reason; without CI the same tests skip. Checked by running pytest, with the
real ``tests/conftest.py`` as its conftest, on a scratch project that skips in every way."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

SKIPS = """
import pytest


def test_passes():
    pass


def test_skip_in_the_body():
    pytest.skip("reason: skipped in the body")


@pytest.mark.skipif(True, reason="reason: a skipif marker")
def test_skipif_marker():
    pass


@pytest.mark.skip(reason="reason: a skip marker")
def test_skip_marker():
    pass


@pytest.fixture
def service():
    pytest.skip("reason: the fixture's service is down")


def test_fixture_skips(service):
    pass


def test_importorskip_in_the_body():
    pytest.importorskip("alcove_no_such_module_in_the_body")


@pytest.mark.xfail(reason="a known bug", strict=True)
def test_expected_failure():
    assert False
"""

MODULE_IMPORTORSKIP = """
import pytest

pytest.importorskip("alcove_no_such_module_at_import")


def test_never_collected():
    pass
"""

MODULE_SKIP = """
import pytest

pytest.skip("reason: the whole module", allow_module_level=True)


def test_never_collected():
    pass
"""

MODULE_MARKER = """
import pytest

pytestmark = pytest.mark.skipif(True, reason="reason: a module marker")


def test_marked():
    pass
"""

# (outcome under CI, node, the skip's reason as the failure shows it)
UNDER_CI = (
    ("FAILED", "test_skips.py::test_skip_in_the_body", "reason: skipped in the body (test_skips.py:9)"),
    ("FAILED", "test_skips.py::test_importorskip_in_the_body", "could not import 'alcove_no_such_module_in_the_body'"),
    ("ERROR", "test_skips.py::test_skipif_marker", "reason: a skipif marker (test_skips.py:12)"),
    ("ERROR", "test_skips.py::test_skip_marker", "reason: a skip marker (test_skips.py:17)"),
    ("ERROR", "test_skips.py::test_fixture_skips", "reason: the fixture's service is down (test_skips.py:27)"),
    ("ERROR", "test_module_marker.py::test_marked", "reason: a module marker (test_module_marker.py:6)"),
    ("ERROR", "test_module_importorskip.py", "could not import 'alcove_no_such_module_at_import'"),
    ("ERROR", "test_module_skip.py", "reason: the whole module (test_module_skip.py:3)"),
)


@pytest.fixture
def scratch(pytester: pytest.Pytester) -> pytest.Pytester:
    pytester.makeconftest((REPO / "tests" / "conftest.py").read_text())
    pytester.makepyfile(
        test_skips=SKIPS,
        test_module_importorskip=MODULE_IMPORTORSKIP,
        test_module_skip=MODULE_SKIP,
        test_module_marker=MODULE_MARKER,
    )
    return pytester


def run(pytester: pytest.Pytester) -> pytest.RunResult:
    return pytester.runpytest("-p", "no:cacheprovider", "-rA", "--continue-on-collection-errors")


def test_under_ci_every_skip_fails_and_shows_its_reason(
    scratch: pytest.Pytester, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("CI", "true")
    result = run(scratch)
    # a skip in the body fails the test; a skip in setup (markers, fixtures) is an error, and so is
    # a module skipped as a whole (its collection); an expected failure is no skip and stays one
    result.assert_outcomes(passed=1, failed=2, errors=6, xfailed=1)
    assert result.ret == pytest.ExitCode.TESTS_FAILED
    for outcome, node, reason in UNDER_CI:
        result.stdout.fnmatch_lines(
            [f"{outcome} {node} - Failed: skipped under CI (CI='true'), and CI never skips: {reason}*"]
        )
    result.stdout.fnmatch_lines(["XFAIL test_skips.py::test_expected_failure - a known bug"])
    result.stdout.no_fnmatch_line("SKIPPED *")


def test_without_ci_the_same_tests_skip(scratch: pytest.Pytester, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("CI", raising=False)
    result = run(scratch)
    result.assert_outcomes(passed=1, skipped=8, xfailed=1)
    assert result.ret == pytest.ExitCode.OK
    result.stdout.no_fnmatch_line("*skipped under CI*")
    for _outcome, node, reason in UNDER_CI:
        result.stdout.fnmatch_lines([f"SKIPPED [[]1] {node.split('::')[0]}:*{reason.split(' (')[0]}*"])
