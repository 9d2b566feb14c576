"""The Content-Security-Policy does not break the web UI or the API docs in a real browser
(against `alcove up`): the campaign list, a campaign page with its plotly charts and their
PNG export, and Swagger UI load without any CSP violation (tests/e2e/csp_check.mjs). Which
requests leave the origin is another test's business; this one is about the policy."""

from __future__ import annotations

import json
import subprocess
import uuid

import pytest
import sqlalchemy as sa
from sqlalchemy.orm import Session

from .conftest import ADMIN_EMAIL, ADMIN_PASSWORD, REPO, Server

pytestmark = [pytest.mark.slow, pytest.mark.e2e]


def synthesize_campaign_in(server: Server) -> tuple[int, str]:
    """A finished two-iteration campaign of the admin, written into the server's database."""
    from alcove.db import make_engine
    from alcove.models import User
    from tests.synthetic import synthesize_campaign

    name = f"csp-{uuid.uuid4().hex[:6]}"
    # BEGIN IMMEDIATE: wait for the server's worker rather than fail on a write after a read
    engine = make_engine(f"sqlite:///{server.data_dir / 'alcove.db'}", immediate=True)
    try:
        with Session(engine, expire_on_commit=False) as s:
            owner = s.scalar(sa.select(User.id).where(User.email == ADMIN_EMAIL))
            campaign = synthesize_campaign(s, owner, iterations=2, name=name, curve_samples=101, pool_samples=20)
            s.commit()
            return campaign.id, name
    finally:
        engine.dispose()


def test_pages_load_without_csp_violations(alcove_server: Server) -> None:
    r = subprocess.run(["curl", "-sI", f"{alcove_server.base_url}/campaigns"], capture_output=True, text=True)
    assert "content-security-policy: default-src 'self'" in r.stdout.lower(), r.stdout
    campaign_id, name = synthesize_campaign_in(alcove_server)
    result = subprocess.run(
        [
            "node",
            str(REPO / "tests" / "e2e" / "csp_check.mjs"),
            "--base-url",
            alcove_server.base_url,
            "--email",
            ADMIN_EMAIL,
            "--password",
            ADMIN_PASSWORD,
            "--campaign",
            str(campaign_id),
            "--name",
            name,
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    lines = [line for line in result.stdout.splitlines() if line.startswith("{")]
    assert lines, f"no result from the browser:\n{result.stdout[-3000:]}\n{result.stderr[-3000:]}"
    report = json.loads(lines[-1])
    print(json.dumps(report, indent=2))
    assert report["failed"] is None, report["failed"]
    assert report["violations"] == [], report["violations"]
    assert len(report["steps"]) == 4 and result.returncode == 0, report
