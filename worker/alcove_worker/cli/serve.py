"""`alcove up`, `alcove serve`, `alcove worker`, `alcove smoke`: run the service."""

from __future__ import annotations

import contextlib
import json
import logging
import os
import signal
import socket
import subprocess
import sys
import threading
import time
import uuid

import typer

from alcove.jobs import QUEUES

log = logging.getLogger("alcove")

ALL_QUEUES = ",".join(QUEUES)


def _parse_queues(queues: str) -> list[str]:
    qs = [q.strip() for q in queues.split(",") if q.strip()]
    bad = [q for q in qs if q not in QUEUES]
    if not qs or bad:
        raise typer.BadParameter(f"queues must be a comma-separated subset of {ALL_QUEUES} (got {queues!r})")
    return list(dict.fromkeys(qs))


def _wait_for_schema(timeout: float) -> None:
    """Block until the database answers and is migrated to head (e.g. while the API migrates)."""
    from alcove.db import migrate

    deadline = time.monotonic() + timeout
    while True:
        try:
            cur, head = migrate.current_revision(), migrate.head_revision()
            if cur == head:
                return
            problem = f"database at revision {cur}, code expects {head}; run `alcove db upgrade`"
        except Exception as err:
            problem = f"database not reachable: {err}"
        if time.monotonic() > deadline:
            typer.echo(problem, err=True)
            raise typer.Exit(2)
        time.sleep(1.0)


def worker(
    queues: str = typer.Option(ALL_QUEUES, "--queues", "-Q", help=f"comma-separated subset of {ALL_QUEUES}"),
    concurrency: int = typer.Option(os.cpu_count() or 1, "--concurrency", "-c", min=1, help="worker processes"),
    name: str | None = typer.Option(
        None, "--name", "-n", help="unique worker name (default: <queues>-<random>@<host>)"
    ),
    loglevel: str = typer.Option("INFO", "--loglevel", "-l"),
    wait_for_db: float = typer.Option(120.0, help="seconds to wait for a reachable, migrated database"),
) -> None:
    """Start a Celery worker consuming QUEUES (on any machine pointed at the same database and broker)."""
    qs = _parse_queues(queues)
    from alcove.science.parallel import usable_cpus

    try:  # a bad ALCOVE_CPUS_PER_PROCESS stops the worker here, not every OCP and training job later
        usable_cpus()
    except ValueError as err:
        typer.echo(f"error: {err}", err=True)
        raise typer.Exit(2) from None
    _wait_for_schema(wait_for_db)
    if not name:
        name = f"{'-'.join(qs)}-{uuid.uuid4().hex[:6]}@%h"
    elif "@" not in name:
        name = f"{name}@%h"
    from alcove.settings import get_settings

    settings = get_settings()
    from alcove_worker.celery_app import app

    argv = [
        "worker",
        "-Q",
        ",".join(qs),
        "-c",
        str(concurrency),
        "-n",
        name,
        "-l",
        loglevel,
        "--without-gossip",
        "--without-mingle",
    ]
    if settings.is_embedded_broker:
        argv.append("--without-heartbeat")
    app.worker_main(argv=argv)


def _ensure_admin() -> None:
    from alcove.db import run_transaction
    from alcove.db.bootstrap import ensure_first_admin
    from alcove.settings import get_settings

    s = get_settings()
    created = run_transaction(
        lambda session: ensure_first_admin(session, s.admin_email, s.admin_password.get_secret_value()) is not None
    )
    if created:
        typer.echo(f"created the first admin: {s.admin_email} (password from ALCOVE_ADMIN_PASSWORD)")


class WorkerProcess:
    """A `alcove worker` child process, restarted with backoff if it dies."""

    def __init__(self, argv: list[str]) -> None:
        self.argv = argv
        self.proc: subprocess.Popen[bytes] | None = None
        self._stopping = threading.Event()
        self._watcher = threading.Thread(target=self._watch, name="alcove-worker-watch", daemon=True)

    def start(self) -> None:
        self._spawn()
        self._watcher.start()

    def _spawn(self) -> None:
        # own session: stopping it also stops its pool processes
        self.proc = subprocess.Popen(self.argv, start_new_session=True)

    def _watch(self) -> None:
        delay = 1.0
        while not self._stopping.is_set():
            assert self.proc is not None
            code = self.proc.wait()
            if self._stopping.is_set():
                return
            typer.echo(f"worker exited with code {code}; restarting in {delay:.0f} s", err=True)
            if self._stopping.wait(delay):
                return
            delay = min(delay * 2, 30.0)
            self._spawn()

    def stop(self, timeout: float = 20.0) -> None:
        self._stopping.set()
        p = self.proc
        if p is None or p.poll() is not None:
            return
        try:
            p.send_signal(signal.SIGTERM)  # Celery warm shutdown: the main process stops its pool
            p.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            typer.echo(f"worker did not stop within {timeout:.0f} s; killing it", err=True)
        finally:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(p.pid, signal.SIGKILL)  # whatever is left of its process group
            p.wait(timeout=5)


def default_api_workers() -> int:
    """API processes by default: one per CPU, at most 4 (each process holds its own
    database pool, token cache and response cache)."""
    return max(1, min(os.cpu_count() or 1, 4))


def _run_api(host: str, port: int, workers: int, log_level: str, access_log: bool) -> None:
    import uvicorn

    # several processes share the port (uvicorn's supervisor restarts one that dies); the
    # import string + factory is what lets each of them build its own app
    uvicorn.run(
        "alcove.app:create_app",
        factory=True,
        host=host,
        port=port,
        log_level=log_level,
        lifespan="on",
        workers=workers,
        access_log=access_log or log_level == "debug",
        timeout_keep_alive=30,
        # the app reads X-Forwarded-For itself, only from ALCOVE_TRUSTED_PROXIES
        # (alcove.api.client_address); uvicorn's default would believe it from 127.0.0.1
        proxy_headers=False,
    )


def serve(
    host: str | None = typer.Option(None, help="API host (default ALCOVE_API_HOST)"),
    port: int | None = typer.Option(None, help="API port (default ALCOVE_API_PORT)"),
    workers: int | None = typer.Option(
        None, "--workers", "-w", min=1, max=64, help="API processes (default: one per CPU, at most 4)"
    ),
    migrate_db: bool = typer.Option(True, "--migrate/--no-migrate", help="run `alcove db upgrade` first"),
    access_log: bool | None = typer.Option(
        None, "--access-log/--no-access-log", help="log every HTTP request (default ALCOVE_ACCESS_LOG)"
    ),
) -> None:
    """Run the API server only (workers run elsewhere: `alcove worker`)."""
    from alcove.db import migrate
    from alcove.settings import get_settings

    s = get_settings()
    s.data_dir.mkdir(parents=True, exist_ok=True)
    if migrate_db:
        migrate.upgrade()
    _ensure_admin()
    host = host or s.api_host
    port = port or s.api_port
    _check_port_free(host, port)
    n = workers or default_api_workers()
    typer.echo(
        f"alcove {_version()} · database {_redact(s.database_url)} · broker {_redact(s.broker_url)}"
        f" · {n} API process(es)"
    )
    signal.signal(signal.SIGTERM, _exit_on_sigterm)
    typer.echo(f"API on http://{host}:{port}  (health: /api/v1/health, docs: /api/v1/docs)")
    _run_api(host, port, n, s.log_level.lower(), s.access_log if access_log is None else access_log)


def up(
    host: str | None = typer.Option(None, help="API host (default ALCOVE_API_HOST)"),
    port: int | None = typer.Option(None, help="API port (default ALCOVE_API_PORT)"),
    workers: int = typer.Option(
        1, "--workers", "-w", min=1, max=64, help="API processes (`alcove serve` defaults to one per CPU)"
    ),
    concurrency: int | None = typer.Option(
        None, "--concurrency", "-c", min=1, help="worker processes (default ALCOVE_WORKER_CONCURRENCY or CPU count)"
    ),
    queues: str = typer.Option(ALL_QUEUES, "--queues", "-Q", help="queues of the bundled worker"),
    with_worker: bool = typer.Option(True, "--worker/--no-worker", help="also start a worker process"),
    migrate_db: bool = typer.Option(True, "--migrate/--no-migrate", help="run `alcove db upgrade` first"),
    access_log: bool | None = typer.Option(
        None, "--access-log/--no-access-log", help="log every HTTP request (default ALCOVE_ACCESS_LOG)"
    ),
) -> None:
    """Run the API server and a Celery worker together (embedded default: SQLite +
    filesystem broker in ALCOVE_DATA_DIR, nothing else needed)."""
    from alcove.db import migrate
    from alcove.settings import get_settings

    s = get_settings()
    s.data_dir.mkdir(parents=True, exist_ok=True)
    qs = _parse_queues(queues)
    if migrate_db:
        migrate.upgrade()
    _ensure_admin()
    _reconcile_at_start()
    host = host or s.api_host
    port = port or s.api_port
    _check_port_free(host, port)
    typer.echo(
        f"alcove {_version()} · database {_redact(s.database_url)} · broker {_redact(s.broker_url)} · data {s.data_dir}"
    )

    wp: WorkerProcess | None = None
    if with_worker:
        n = concurrency or s.worker_concurrency or os.cpu_count() or 1
        argv = [
            sys.executable,
            "-m",
            "alcove_worker.cli.main",
            "worker",
            "--queues",
            ",".join(qs),
            "--concurrency",
            str(n),
            "--loglevel",
            s.log_level,
        ]
        wp = WorkerProcess(argv)
        wp.start()
    # uvicorn re-raises the SIGTERM it caught once it has shut down; turn that into a
    # normal exit so the worker below is stopped too.
    signal.signal(signal.SIGTERM, _exit_on_sigterm)
    try:
        typer.echo(f"API on http://{host}:{port}  (health: /api/v1/health, docs: /api/v1/docs)")
        _run_api(host, port, workers, s.log_level.lower(), s.access_log if access_log is None else access_log)
    finally:
        if wp is not None:
            wp.stop()


def _reconcile_at_start() -> None:
    """Re-enqueue steps whose worker died while no API or worker was running."""
    from alcove.campaigns.run.reconciler import reconcile_and_enqueue

    try:
        jobs = reconcile_and_enqueue()
    except Exception as err:
        typer.echo(f"warning: reconciliation at start failed: {err}", err=True)
        return
    if jobs:
        typer.echo(f"re-enqueued {len(jobs)} step(s) whose worker had died")


def _exit_on_sigterm(signum: int, frame: object) -> None:
    raise SystemExit(0)


def smoke(
    timeout: float = typer.Option(60.0, help="seconds to wait for the committed result"),
    queue: str = typer.Option("default", "--queue", "-Q", help=f"queue to send it to ({ALL_QUEUES})"),
    as_json: bool = typer.Option(False, "--json", help="print the result as JSON"),
) -> None:
    """Enqueue the smoke job and wait until a worker has committed its row."""
    from alcove.jobs import SMOKE_JOB, send_job
    from alcove.jobs.smoke import wait_for_smoke

    _parse_queues(queue)
    token = uuid.uuid4().hex
    t0 = time.time()
    send_job(SMOKE_JOB, token, t0, queue=queue)
    got = wait_for_smoke(token, timeout=timeout)
    if got is None:
        msg = (
            f"no worker committed the smoke job within {timeout:.0f} s"
            f" (is `alcove worker -Q {queue}` or `alcove up` running?)"
        )
        typer.echo(json.dumps({"ok": False, "error": msg}) if as_json else msg, err=not as_json)
        raise typer.Exit(1)
    got["round_trip_s"] = round(time.time() - t0, 3)
    if as_json:
        typer.echo(json.dumps({"ok": True, **got}))
    else:
        typer.echo(
            f"smoke job ok: worker {got['worker_name']} committed row {got['id']} in {got['round_trip_s']:.3f} s"
            f" (its process may use {got['payload'].get('cpus', '?')} CPU(s))"
        )


def _version() -> str:
    import alcove

    return alcove.__version__


def _redact(url: str) -> str:
    from sqlalchemy.engine import make_url

    try:
        return make_url(url).render_as_string(hide_password=True)
    except Exception:
        return url.split("@")[-1]


def _check_port_free(host: str, port: int) -> None:
    """Exit 2 when another server listens on ``host:port``.

    The probe binds with ``SO_REUSEADDR``, as uvicorn does: then only a listening socket makes
    the bind fail, not the connections a killed server left in the kernel (FIN_WAIT_2 while a
    keep-alive or event-stream client keeps its end open, TIME_WAIT after), which would
    otherwise refuse a restart for tens of seconds."""
    with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind((host, port))
        except OSError as err:
            typer.echo(f"cannot listen on {host}:{port}: {err.strerror} (another alcove up? use --port)", err=True)
            raise typer.Exit(2) from None
