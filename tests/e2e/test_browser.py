"""The web UI end to end in a real browser against a real server and worker."""

from __future__ import annotations

import os
import subprocess
import time

import pytest

from .conftest import ADMIN_EMAIL, ADMIN_PASSWORD, ARTIFACTS, FRONTEND, REPO, Server

DOCS_IMAGES = REPO / "docs" / "images"
# written by the run into test-artifacts/; with ALCOVE_DOCS_IMAGES=1 (`make docs-images`) also
# into docs/images/, the screenshots the docs show (a plain `make test` leaves the tree clean)
UPDATE_DOCS_IMAGES = os.environ.get("ALCOVE_DOCS_IMAGES") == "1"
SCREENSHOTS = (
    "campaign-page.png",
    "campaign-trajectory.png",
    "campaigns-list.png",
    "task-editor.png",
    "oracle-editor.png",
    "new-campaign.png",
)

pytestmark = [pytest.mark.slow, pytest.mark.e2e]


def run_browser_script(server: Server, script: str, *extra: str) -> None:
    """Run one of frontend/e2e/*.mjs against the server as the first admin; fail with its
    output and the end of the server's log."""
    ARTIFACTS.mkdir(exist_ok=True)
    command = ["node", f"e2e/{script}", "--base-url", server.base_url, "--email", ADMIN_EMAIL]
    command += ["--password", ADMIN_PASSWORD, "--artifacts", str(ARTIFACTS), *extra]
    result = subprocess.run(command, cwd=FRONTEND, capture_output=True, text=True, timeout=600)
    print(result.stdout)  # the steps with their times (pytest -s)
    if result.returncode != 0:
        server_log = server.log.read_text()[-3000:] if server.log.exists() else ""
        pytest.fail(
            f"browser run failed:\n{result.stdout[-4000:]}\n{result.stderr[-4000:]}\n"
            f"--- alcove up log ---\n{server_log}"
        )


def test_campaign_lifecycle_in_the_browser(alcove_server: Server) -> None:
    """Sign in, token, task, oracle, campaign with >= 2 iterations on the RMSE plot (metrics
    polls transfer only new iterations), force plot, angle and torque, pause/resume, model
    download, screenshots for the docs (see frontend/e2e/run.mjs)."""
    started = time.time() - 1
    run_browser_script(alcove_server, "run.mjs", *(["--docs-images", str(DOCS_IMAGES)] if UPDATE_DOCS_IMAGES else []))
    for name in SCREENSHOTS:
        for folder in (ARTIFACTS, DOCS_IMAGES) if UPDATE_DOCS_IMAGES else (ARTIFACTS,):
            shot = folder / name
            assert shot.stat().st_size > 10_000 and shot.stat().st_mtime >= started, shot


def test_live_updates_forms_forks_and_no_foreign_requests_in_the_browser(alcove_server: Server) -> None:
    """One browser session (see frontend/e2e/live.mjs): the campaign list shows a campaign
    created and started through the API without reload; 5 short campaigns end while their page
    is open and every time the RMSE plot shows every iteration the server has; a click on the
    RMSE plot opens that iteration; an overlay of all iterations keeps the plot's size; a fork
    made with the dialog never shows k / N with k > N and greys its inherited iterations; a bad
    form submit shows each problem once at its field without page errors; no request leaves
    the server's origin."""
    run_browser_script(alcove_server, "live.mjs", "--endings", "5")


def test_forms_keep_typed_numbers_in_the_browser(alcove_server: Server) -> None:
    """0.0005, 0.3001, 0.0025, 1e-4, 1e308 and -0.005 typed key by key into a field of each form
    and table kind (task model form, phases table, chain links and joints tables, oracle form,
    new-campaign form, fork dialog): the field shows exactly the keys typed after each one, and
    the value is either named at the field or stored by the server exactly; text that is no
    number is named at its field. The new-campaign form names problems of every kind while typing
    (its own checks and the API's check route), all at once, each at its field, and each fix
    takes its problem away (see frontend/e2e/forms.mjs)."""
    run_browser_script(alcove_server, "forms.mjs")


def test_accessibility_titles_and_phone_width_in_the_browser(alcove_server: Server) -> None:
    """axe-core finds no violation on the campaigns list, a finished campaign's page, the task,
    oracle and new-campaign editors, the compare and tokens pages; every page has a title of its
    own; at 390 px the campaigns list and every tab of a campaign's page fit the screen with the
    navigation reachable (see frontend/e2e/a11y.mjs)."""
    run_browser_script(alcove_server, "a11y.mjs")
