"""The web UI end to end in a real browser against a real server and worker."""

from __future__ import annotations

import subprocess

import pytest

from .conftest import ADMIN_EMAIL, ADMIN_PASSWORD, ARTIFACTS, FRONTEND, Server

pytestmark = [pytest.mark.slow, pytest.mark.e2e]


def test_campaign_lifecycle_in_the_browser(alcove_server: Server) -> None:
    """Sign in, token, task, oracle, campaign with >= 2 iterations on the RMSE plot, force
    plot, pause/resume, model download, screenshot (see frontend/e2e/run.mjs)."""
    ARTIFACTS.mkdir(exist_ok=True)
    result = subprocess.run(
        ["node", "e2e/run.mjs", "--base-url", alcove_server.base_url, "--email", ADMIN_EMAIL, "--password", ADMIN_PASSWORD, "--artifacts", str(ARTIFACTS)],
        cwd=FRONTEND,
        capture_output=True,
        text=True,
        timeout=600,
    )
    if result.returncode != 0:
        server_log = alcove_server.log.read_text()[-3000:] if alcove_server.log.exists() else ""
        pytest.fail(f"browser run failed:\n{result.stdout[-4000:]}\n{result.stderr[-4000:]}\n--- alcove up log ---\n{server_log}")
    screenshot = ARTIFACTS / "campaign-page.png"
    assert screenshot.stat().st_size > 10_000
