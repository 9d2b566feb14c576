"""Fixtures for the browser tests: `alcove up` (API + a real worker) on a temporary data dir.

The browser is Debian's Chromium (``apt-get install chromium``) driven by ``playwright-core``
from ``frontend/node_modules``; nothing is downloaded. Without them the tests skip locally
and fail under CI (``CI=true``), so a CI machine that lacks them cannot pass silently.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
FRONTEND = REPO / "frontend"
STATIC = REPO / "backend" / "alcove" / "static"
CHROMIUM = os.environ.get("ALCOVE_CHROMIUM", "/usr/bin/chromium")
ARTIFACTS = REPO / "test-artifacts"
ADMIN_EMAIL = "admin@alcove.local"
ADMIN_PASSWORD = "e2e-admin-password"


def missing_prerequisite() -> str | None:
    if shutil.which("node") is None:
        return "node is not installed"
    if not (FRONTEND / "node_modules" / "playwright-core").is_dir():
        return "frontend/node_modules is missing (cd frontend && npm ci)"
    if not Path(CHROMIUM).exists():
        return f"{CHROMIUM} is missing (apt-get install -y chromium)"
    return None


def require_browser() -> None:
    reason = missing_prerequisite()
    if reason is None:
        return
    if os.environ.get("CI"):
        pytest.fail(f"browser tests cannot run: {reason}")
    pytest.skip(reason)


def ensure_frontend_built() -> None:
    """Build the UI into backend/alcove/static unless a build is already there."""
    if (STATIC / "index.html").is_file():
        return
    subprocess.run(["npm", "run", "build"], cwd=FRONTEND, check=True, timeout=600)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@dataclass
class Server:
    base_url: str
    data_dir: Path
    env: dict[str, str]
    log: Path


def _wait_healthy(url: str, proc: subprocess.Popen[bytes], log: Path, timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"alcove up exited with {proc.returncode}:\n{log.read_text()[-4000:]}")
        try:
            with urllib.request.urlopen(f"{url}/api/v1/health", timeout=2) as r:
                if r.status == 200:
                    return
        except OSError:
            pass
        time.sleep(0.5)
    raise RuntimeError(f"alcove up did not become healthy within {timeout:.0f} s:\n{log.read_text()[-4000:]}")


def start_server(data_dir: Path, concurrency: int = 1) -> tuple[Server, subprocess.Popen[bytes]]:
    port = _free_port()
    env = {k: v for k, v in os.environ.items() if not k.startswith("ALCOVE_")}
    env.update(
        ALCOVE_DATA_DIR=str(data_dir),
        ALCOVE_ADMIN_EMAIL=ADMIN_EMAIL,
        ALCOVE_ADMIN_PASSWORD=ADMIN_PASSWORD,
        ALCOVE_API_PORT=str(port),
        ALCOVE_WORKER_CONCURRENCY=str(concurrency),
        ALCOVE_LOG_LEVEL="WARNING",
    )
    log = data_dir / "alcove-up.log"
    data_dir.mkdir(parents=True, exist_ok=True)
    alcove = Path(sys.executable).with_name("alcove")
    cmd = [str(alcove)] if alcove.exists() else [sys.executable, "-m", "alcove_worker.cli.main"]
    with log.open("wb") as out:
        proc = subprocess.Popen(
            [*cmd, "up", "--port", str(port)],
            cwd=REPO,
            env=env,
            stdout=out,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
    server = Server(base_url=f"http://127.0.0.1:{port}", data_dir=data_dir, env=env, log=log)
    try:
        _wait_healthy(server.base_url, proc, log, timeout=120)
    except Exception:
        stop_server(proc)
        raise
    return server, proc


def stop_server(proc: subprocess.Popen[bytes]) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(timeout=40)
    with contextlib.suppress(ProcessLookupError):
        os.killpg(proc.pid, signal.SIGKILL)  # anything left in its session (worker pool)
    proc.wait(timeout=10)


@pytest.fixture(scope="session")
def alcove_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    require_browser()
    ensure_frontend_built()
    server, proc = start_server(tmp_path_factory.mktemp("alcove-e2e"))
    try:
        yield server
    finally:
        stop_server(proc)
