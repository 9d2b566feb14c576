"""API factory: health, readiness, frontend serving, busy-database handling, and that the
API process stays light (no torch, no casadi)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import sqlalchemy as sa
from fastapi.testclient import TestClient

from alcove.settings import Settings

#: a client in ALCOVE_HEALTH_DETAILS_NETWORKS (readiness details)
LOCAL = ("127.0.0.1", 50000)


@pytest.fixture
def settings(tmp_path: Path, private_sqlite_url: str, monkeypatch: pytest.MonkeyPatch) -> Settings:
    """A database of this test alone: readiness counts the heartbeat rows other tests leave."""
    monkeypatch.setenv("ALCOVE_DATA_DIR", str(tmp_path))
    monkeypatch.setenv("ALCOVE_DATABASE_URL", private_sqlite_url)
    monkeypatch.setenv("ALCOVE_HEALTH_DETAILS_NETWORKS", "127.0.0.1")  # the readiness details for LOCAL
    from alcove.settings import get_settings

    get_settings.cache_clear()
    yield get_settings()
    get_settings.cache_clear()


def test_health_needs_nothing(settings: Settings) -> None:
    from alcove.app import create_app

    r = TestClient(create_app(settings)).get("/api/v1/health")
    assert r.status_code == 200 and r.json()["status"] == "ok"


def test_readiness_without_workers_is_503_with_reasons(settings: Settings) -> None:
    from alcove.app import create_app

    r = TestClient(create_app(settings), client=LOCAL).get("/api/v1/health/ready")
    assert r.status_code == 503
    body = r.json()
    assert body["database"]["ok"] and body["broker"]["ok"]
    assert not body["workers"]["ok"] and "no worker" in body["workers"]["detail"]


def test_readiness_sees_a_fresh_heartbeat(settings: Settings) -> None:
    from alcove.app import create_app
    from alcove.jobs.heartbeat import beat, mark_stopped

    beat("api-test@host", queues=["default", "ocp"], concurrency=1, starting=True)
    try:
        r = TestClient(create_app(settings), client=LOCAL).get("/api/v1/health/ready")
        assert r.status_code == 200, r.json()
        assert r.json()["queues_served"] == ["default", "ocp"]
    finally:
        mark_stopped("api-test@host")


def test_readiness_reports_an_unmigrated_database(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ALCOVE_DATA_DIR", str(tmp_path))
    monkeypatch.setenv("ALCOVE_DATABASE_URL", f"sqlite:///{tmp_path / 'empty.db'}")
    monkeypatch.setenv("ALCOVE_HEALTH_DETAILS_NETWORKS", "127.0.0.1")
    from alcove.app import create_app
    from alcove.settings import get_settings

    get_settings.cache_clear()
    try:
        r = TestClient(create_app(), client=LOCAL).get("/api/v1/health/ready")
        assert r.status_code == 503 and "alcove db upgrade" in r.json()["database"]["detail"]
    finally:
        get_settings.cache_clear()


def test_openapi_operation_ids_are_stable(settings: Settings) -> None:
    from alcove.app import create_app

    spec = TestClient(create_app(settings)).get("/api/v1/openapi.json").json()
    ops = {op["operationId"] for path in spec["paths"].values() for op in path.values()}
    assert {"health", "readiness"} <= ops


def test_serves_the_built_frontend_with_spa_fallback(tmp_path: Path, settings: Settings) -> None:
    from alcove.app import create_app

    static = tmp_path / "static"
    (static / "assets").mkdir(parents=True)
    (static / "index.html").write_text("<html>alcove ui</html>")
    (static / "assets" / "app.js").write_text("console.log(1)")
    client = TestClient(create_app(settings.model_copy(update={"static_dir": static})))
    assert "alcove ui" in client.get("/").text
    assert client.get("/assets/app.js").text == "console.log(1)"
    assert "alcove ui" in client.get("/campaigns/12").text  # client-side route
    assert client.get("/api/v1/health").json()["status"] == "ok"
    assert client.get("/api/v1/nope").status_code == 404
    # below the API the web UI answers nothing: the API's own 404, and 405 with Allow for a path
    # an API route serves with another method (a non-integer id is no such path)
    r = client.get("/api/v1/tasks/check")
    assert r.status_code == 405 and r.headers["allow"] == "POST"
    assert client.put("/api/v1/surrogate-configs/null,null", json={}).status_code == 404
    assert client.post("/api/v1/campaigns/9.81/cancel").status_code == 404
    assert client.post("/").status_code == 405  # the web UI is read-only


def test_placeholder_page_without_frontend(tmp_path: Path, settings: Settings) -> None:
    from alcove.app import create_app

    r = TestClient(create_app(settings.model_copy(update={"static_dir": tmp_path / "none"}))).get("/")
    assert r.status_code == 200 and "/api/v1/docs" in r.text


def test_busy_database_is_503_retry_not_500(tmp_path: Path, settings: Settings) -> None:
    from alcove.app import create_app

    app = create_app(settings.model_copy(update={"static_dir": tmp_path / "none"}))

    @app.get("/api/v1/_busy")
    def busy() -> None:
        import sqlite3

        raise sa.exc.OperationalError("UPDATE x", {}, sqlite3.OperationalError("database is locked"))

    r = TestClient(app, raise_server_exceptions=False).get("/api/v1/_busy")
    assert r.status_code == 503 and r.headers["retry-after"] == "1"


def test_api_process_does_not_import_torch_or_casadi() -> None:
    code = (
        "import sys\n"
        "from alcove.app import create_app\n"
        "from alcove.jobs import send_job, celery_config\n"
        "from alcove.db import get_engine\n"
        "import alcove.models\n"
        "create_app(); celery_config()\n"
        # the API validates with the science package's pydantic schemas, but never
        # imports the heavy libraries or the worker
        "bad = sorted(m for m in ('torch', 'casadi', 'skfem', 'alcove_worker') if m in sys.modules)\n"
        "assert not bad, bad\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
