"""The frontend's own checks, run from pytest so `make test` covers them: the generated API
client matches the backend's live OpenAPI schema, and the Vitest component tests pass. Neither
starts a server or a browser: both run in the parallel phase (tests/conftest.py)."""

from __future__ import annotations

import os
import shutil
import subprocess

import pytest

from .conftest import FRONTEND


def _require_node() -> None:
    reason = None
    if shutil.which("node") is None:
        reason = "node is not installed"
    elif not (FRONTEND / "node_modules" / "openapi-typescript").is_dir():
        reason = "frontend/node_modules is missing (cd frontend && npm ci)"
    if reason:
        if os.environ.get("CI"):
            pytest.fail(reason)
        pytest.skip(reason)


def test_generated_api_client_matches_the_live_openapi_schema() -> None:
    _require_node()
    result = subprocess.run(
        ["node", "scripts/gen-api.mjs", "--check"], cwd=FRONTEND, capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stderr + result.stdout


#: Vitest here runs in the parallel phase of `make test`, beside another pytest-xdist worker: one
#: thread of its own (not one per core), and 30 s per test instead of 5 s, the time a test
#: that waits on nothing may take on a loaded machine (a test that hangs still fails)
VITEST_ARGS = ("--maxWorkers=1", "--testTimeout=30000")


def test_vitest_component_tests_pass() -> None:
    _require_node()
    result = subprocess.run(
        ["npx", "vitest", "--run", "--reporter=dot", *VITEST_ARGS],
        cwd=FRONTEND,
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "CI": "true"},
    )
    assert result.returncode == 0, result.stdout[-6000:] + result.stderr[-3000:]
