"""Helpers to run real alcove processes (worker, up, CLI) in tests."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
import uuid
from collections.abc import Iterable, Iterator
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Any

import httpx

CLI = [sys.executable, "-m", "alcove_worker.cli.main"]


def alcove_env(**settings: str) -> dict[str, str]:
    """The current environment without ALCOVE_* settings, plus ``settings`` (as ALCOVE_<NAME>)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("ALCOVE_") or k.startswith("ALCOVE_TEST_")}
    env.update({f"ALCOVE_{k.upper()}": str(v) for k, v in settings.items()})
    env.setdefault("ALCOVE_ADMIN_PASSWORD", "test-admin-password")
    return env


def run_cli(args: list[str], env: dict[str, str], timeout: float = 120) -> subprocess.CompletedProcess[str]:
    return subprocess.run(CLI + args, env=env, capture_output=True, text=True, timeout=timeout)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Proc:
    """A child process in its own session, with its output in a log file."""

    def __init__(self, args: list[str], env: dict[str, str], log: Path) -> None:
        self.log = log
        # the child writes to its own copy of the descriptor: ours is closed at once
        with open(log, "wb") as fh:
            self.p = subprocess.Popen(CLI + args, env=env, stdout=fh, stderr=subprocess.STDOUT, start_new_session=True)

    def output(self) -> str:
        return self.log.read_text(errors="replace")

    def alive(self) -> bool:
        return self.p.poll() is None

    def kill(self) -> None:
        """SIGKILL the process and its children (no warm shutdown, no acks)."""
        with suppress(ProcessLookupError):
            os.killpg(self.p.pid, signal.SIGKILL)
        self.p.wait(timeout=10)

    def terminate(self) -> None:
        """SIGTERM (a worker's warm shutdown), without waiting: see :meth:`stopped`."""
        if self.p.poll() is None:
            self.p.send_signal(signal.SIGTERM)

    def stopped(self, timeout: float = 30) -> int:
        """Wait up to ``timeout`` s for the process to exit, then SIGKILL what is left of it."""
        with suppress(subprocess.TimeoutExpired):
            self.p.wait(timeout=timeout)
        with suppress(ProcessLookupError):
            os.killpg(self.p.pid, signal.SIGKILL)
        return self.p.wait(timeout=10)

    def stop(self, timeout: float = 30) -> int:
        self.terminate()
        return self.stopped(timeout)


def stop_all(procs: Iterable[Proc], timeout: float = 30) -> None:
    """Stop several processes at once: SIGTERM to each, then wait for each. A worker's warm
    shutdown takes seconds (up to two 2 s polls of the filesystem broker, then its pool), which
    one after the other would add up."""
    procs = list(procs)
    for proc in procs:
        proc.terminate()
    for proc in procs:
        proc.stopped(timeout)


@contextmanager
def running(args: list[str], env: dict[str, str], log: Path) -> Iterator[Proc]:
    proc = Proc(args, env, log)
    try:
        yield proc
    finally:
        proc.stop()


@contextmanager
def api_processes(
    settings: dict[str, dict[str, str]], database_url: str, redis_url: str, tmp_path_factory: Any, prefix: str
) -> Iterator[dict[str, tuple[str, Proc]]]:
    """``alcove serve`` processes sharing one database and one Redis under the key ``prefix``:
    one per entry of ``settings`` (its name and extra settings), each as (base URL, process).
    They start one after the other (each creates the first admin if there is none); on exit
    they stop and the prefix's Redis keys are deleted."""
    procs: list[Proc] = []
    started: dict[str, tuple[str, Proc]] = {}
    try:
        for name, extra in settings.items():
            port = free_port()
            env = alcove_env(
                database_url=database_url,
                broker_url=redis_url,
                broker_key_prefix=prefix,
                data_dir=str(tmp_path_factory.mktemp(name)),
                log_level="WARNING",
                **extra,
            )
            log = Path(tmp_path_factory.mktemp(f"{name}-log")) / "serve.log"
            proc = Proc(["serve", "--no-migrate", "--workers", "1", "--port", str(port)], env, log)
            procs.append(proc)
            url = f"http://127.0.0.1:{port}"
            started[name] = (url, proc)
            wait_until(lambda url=url: http_ok(f"{url}/api/v1/health"), 90, f"alcove serve ({name})", proc)
        yield started
    finally:
        stop_all(procs)
        import redis

        client = redis.Redis.from_url(redis_url)
        keys = list(client.scan_iter(match=f"{prefix}*"))
        if keys:
            client.delete(*keys)
        client.close()


def wait_until(pred, timeout: float, what: str, proc: Proc | None = None, interval: float = 0.1):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        got = pred()
        if got:
            return got
        if proc is not None and not proc.alive():
            raise AssertionError(f"process died while waiting for {what}:\n{proc.output()[-4000:]}")
        time.sleep(interval)
    raise AssertionError(
        f"timed out after {timeout} s waiting for {what}" + (f":\n{proc.output()[-4000:]}" if proc else "")
    )


def start_worker(
    env: dict[str, str],
    log: Path,
    name: str,
    queues: str = "default,ocp,oracle,train",
    concurrency: int = 1,
    loglevel: str = "INFO",
) -> Proc:
    """An `alcove worker` process (stop it with ``.stop()``, or ``.kill()`` for a SIGKILL)."""
    return Proc(
        ["worker", "--queues", queues, "--concurrency", str(concurrency), "--name", name, "--loglevel", loglevel],
        env,
        log,
    )


def db_rows(url: str, sql: str, **params: object) -> list[tuple]:
    """Rows of ``sql`` on the database at ``url`` (a fresh engine: sees other processes' commits)."""
    import sqlalchemy as sa

    from alcove.db import make_engine

    eng = make_engine(url)
    try:
        with eng.connect() as c:
            return [tuple(r) for r in c.execute(sa.text(sql), params)]
    finally:
        eng.dispose()


def pid_alive(pid: int) -> bool:
    """The process exists and is not a zombie."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split()[2] != "Z"
    except FileNotFoundError:
        return False


def worker_ready(proc: Proc) -> bool:
    return " ready." in proc.output()


def smoke(env: dict[str, str], queue: str = "default", timeout: float = 60) -> dict:
    r = run_cli(["smoke", "--json", "--queue", queue, "--timeout", str(timeout)], env, timeout=timeout + 60)
    assert r.returncode == 0, f"smoke failed ({r.returncode}):\n{r.stdout}\n{r.stderr}"
    return json.loads(r.stdout.strip().splitlines()[-1])


def http_ok(url: str) -> httpx.Response | None:
    try:
        r = httpx.get(url, timeout=2)
        return r if r.status_code == 200 else None
    except httpx.HTTPError:
        return None


def unique(prefix: str) -> str:
    return f"{prefix}-{uuid.uuid4().hex[:8]}"


class PrivateRedis:
    """A redis-server of our own (no persistence): restarting it loses every message."""

    def __init__(self, workdir: Path) -> None:
        self.port = free_port()
        self.workdir = workdir
        self.p: subprocess.Popen[bytes] | None = None

    def start(self) -> None:
        self.p = subprocess.Popen(
            ["redis-server", "--port", str(self.port), "--save", "", "--appendonly", "no", "--dir", str(self.workdir)],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        import redis

        wait_until(lambda: _ping(redis.Redis(port=self.port)), 10, "redis-server")

    def stop(self) -> None:
        if self.p is not None and self.p.poll() is None:
            self.p.terminate()
            self.p.wait(timeout=10)

    @property
    def url(self) -> str:
        return f"redis://127.0.0.1:{self.port}/0"


def _ping(client: Any) -> bool:
    try:
        return bool(client.ping())
    except Exception:
        return False
