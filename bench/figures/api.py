"""REST API under load (``python -m bench.run --only "api:"``).

Setup (untimed): a private PostgreSQL schema, migrated, holding a 200-iteration campaign
synthesized through the services/repositories (``tests/synthetic.py``: iterations,
steps, metrics with 401-sample curves, OCP solutions on the preset's grid of 2 x 100
intervals, pool versions), and the API served the way
``alcove serve`` does it: uvicorn with ``API_WORKERS`` processes on loopback.

Load: 20 concurrent keep-alive connections, authenticated (a personal token), each sending
its next GET as soon as the previous answer arrived (a closed loop: latency = 20 /
throughput), for ``DURATION_S`` seconds per repetition (``bench/loadgen.py``). The generator is ``wrk`` (C, two
threads; Debian package ``wrk``) with its latency distribution; if it is missing, an httpx
async client in Python (it eats much of the same 2 cores: its figures are pessimistic),
and the table's notes say which one ran. Reported: p50/p95/p99, throughput, payload
sizes, the cost of an empty ``?after=200`` poll, the polled campaign detail (with and
without ``If-None-Match``), and the API processes' CPU time per
request (from /proc: much less sensitive to the machine's load than latencies).
"""

from __future__ import annotations

import asyncio
import functools
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import uuid
from pathlib import Path
from typing import Any
from urllib.parse import quote

from bench.harness import figure
from bench.loadgen import httpx_load, process_group_cpu_s, wrk

ITERATIONS = 200
OCP_INTERVALS = 100  # per phase, as the head-headrest-2phase preset: 201 nodes
CLIENTS = 20
REQUESTS_PER_CLIENT = 25  # httpx fallback
DURATION_S = float(os.environ.get("ALCOVE_BENCH_API_SECONDS", "4"))
API_WORKERS = int(os.environ.get("ALCOVE_BENCH_API_WORKERS", "0")) or None  # None: alcove serve's default
PG_URL = os.environ.get("ALCOVE_BENCH_PG_URL", "postgresql+psycopg://postgres@127.0.0.1:5432/test")
REPO = Path(__file__).resolve().parents[2]


def _pg_missing() -> str | None:
    import sqlalchemy as sa

    try:
        eng = sa.create_engine(PG_URL, poolclass=sa.pool.NullPool, connect_args={"connect_timeout": 3})
        with eng.connect() as c:
            c.exec_driver_sql("select 1")
        eng.dispose()
    except Exception as err:
        return f"PostgreSQL not available at {PG_URL} ({type(err).__name__}); set ALCOVE_BENCH_PG_URL"
    return None


class PgSchema:
    """A fresh schema on the bench's PostgreSQL; ``url`` points at it through search_path,
    ``drop()`` removes it with everything in it."""

    def __init__(self, prefix: str) -> None:
        import sqlalchemy as sa

        self.name = f"{prefix}_{uuid.uuid4().hex[:8]}"
        sep = "&" if "?" in PG_URL else "?"
        self.url = f"{PG_URL}{sep}options={quote(f'-csearch_path={self.name}')}"
        self._base = sa.create_engine(PG_URL, poolclass=sa.pool.NullPool)
        with self._base.begin() as c:
            c.exec_driver_sql(f'CREATE SCHEMA "{self.name}"')

    def drop(self) -> None:
        with self._base.begin() as c:
            c.exec_driver_sql(f'DROP SCHEMA IF EXISTS "{self.name}" CASCADE')
        self._base.dispose()


@functools.cache
def server() -> dict[str, Any]:
    """Migrated schema + synthetic campaign + uvicorn on a free port (kept for all figures)."""
    import atexit
    import socket

    import httpx

    schema = PgSchema("alcove_bench_api")
    url = schema.url
    os.environ["ALCOVE_DATABASE_URL"] = url
    from alcove.db import migrate, open_transaction
    from alcove.models import ApiToken, TokenKind, User
    from alcove.settings import get_settings

    get_settings.cache_clear()
    migrate.upgrade(url)
    sys.path.insert(0, str(REPO))
    from tests.synthetic import synthesize_campaign

    with open_transaction(url) as s:
        user = User(email="bench@example.org", role="member")
        s.add(user)
        s.flush()
        token, secret = ApiToken.issue(user, kind=TokenKind.personal, name="bench")
        s.add(token)
        campaign = synthesize_campaign(s, user.id, iterations=ITERATIONS, name="bench-200", ocp_intervals=OCP_INTERVALS)
        cid = campaign.id
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    env = {**os.environ, "ALCOVE_DATABASE_URL": url, "ALCOVE_LOG_LEVEL": "WARNING"}
    from alcove_worker.cli.serve import default_api_workers

    workers = API_WORKERS or default_api_workers()
    # the server's output goes to a file (a pipe nobody reads would block a server that logs)
    log = Path(tempfile.gettempdir()) / f"alcove-bench-api-{port}.log"
    with open(log, "wb") as log_file:
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "alcove_worker.cli.main",
                "serve",
                "--host",
                "127.0.0.1",
                "--port",
                str(port),
                "--workers",
                str(workers),
                "--no-migrate",
            ],
            env=env,
            stdout=log_file,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )

    def stop() -> None:
        proc.terminate()
        try:
            proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=5)
        schema.drop()

    atexit.register(stop)
    root = f"http://127.0.0.1:{port}/api/v1"
    for _ in range(200):
        try:
            if httpx.get(f"{root}/health", timeout=1).status_code == 200:
                break
        except httpx.HTTPError:
            time.sleep(0.1)
    else:
        raise RuntimeError("the API server did not start")
    return {
        "root": root,
        "headers": {"Authorization": f"Bearer {secret}"},
        "campaign_id": cid,
        "results": {},
        "pid": proc.pid,
        "workers": workers,
        "tool": "wrk" if shutil.which("wrk") else "httpx",
    }


def _measure(ctx: dict[str, Any], key: str, path: str) -> float:
    import httpx

    path = path.format(cid=ctx["campaign_id"])
    r = httpx.get(ctx["root"] + path, headers=ctx["headers"], timeout=30)  # warm-up (and payload size)
    r.raise_for_status()
    headers = dict(ctx["headers"])
    if key in ("etag", "detail_etag"):  # a poll that already has the answer: 304, no body
        headers["If-None-Match"] = r.headers["ETag"]
        r = httpx.get(ctx["root"] + path, headers=headers, timeout=30)
        assert r.status_code == 304, r.status_code
    cpu0 = process_group_cpu_s(ctx["pid"])
    if ctx["tool"] == "wrk":
        got = wrk(ctx["root"] + path, headers, clients=CLIENTS, seconds=DURATION_S)
    else:
        load = httpx_load(ctx["root"], headers, path, clients=CLIENTS, requests_per_client=REQUESTS_PER_CLIENT)
        got = asyncio.run(load)
    got["cpu_ms"] = (process_group_cpu_s(ctx["pid"]) - cpu0) / max(got["requests"], 1) * 1e3
    got["size"] = len(r.content)
    ctx["results"].setdefault(key, []).append(got)
    _note(ctx)
    return got["p95"]


def _note(ctx: dict[str, Any]) -> None:
    from bench.harness import FIGURES

    how = (
        f"load: wrk, 2 threads, {CLIENTS} keep-alive connections, {DURATION_S:g} s"
        if ctx["tool"] == "wrk"
        else f"load: wrk NOT FOUND, httpx fallback ({CLIENTS} clients x {REQUESTS_PER_CLIENT} requests, "
        "in Python on the same cores: pessimistic)"
    )
    for fig in FIGURES:
        if fig.group == "api" and fig.name.startswith("api: GET"):
            fig.notes = f"{how}; API: {ctx['workers']} uvicorn worker(s)"


HEALTH = "/health"
METRICS = "/campaigns/{cid}/metrics"
POLL = "/campaigns/{cid}/metrics?after=200"
CURVES = "/campaigns/{cid}/iterations/137/curves"
TRAJECTORY = "/campaigns/{cid}/iterations/137/trajectory"
DETAIL = "/campaigns/{cid}"
COMMON = {"setup": server, "requires": _pg_missing, "group": "api", "reps": 3, "quick_reps": 1}
PATHS = {
    "health": HEALTH,
    "metrics": METRICS,
    "poll": POLL,
    "curves": CURVES,
    "trajectory": TRAJECTORY,
    "etag": METRICS,
    "detail": DETAIL,
    "detail_etag": DETAIL,
}


@figure(
    "api: GET /health (no auth, no database), p95 at 20 clients",
    "ms",
    **COMMON,
    notes="the framework's floor on this machine under the same load: compare the routes below with it",
)
def health_p95(ctx: dict[str, Any]) -> float:
    return _measure(ctx, "health", HEALTH)


@figure(
    "api: GET metrics series (200 iterations), p95 at 20 clients",
    "ms",
    target=30.0,
    baseline="api: GET /health (no auth, no database), p95 at 20 clients",
    **COMMON,
)
def metrics_p95(ctx: dict[str, Any]) -> float:
    return _measure(ctx, "metrics", METRICS)


@figure(
    "api: GET one iteration's curves (401 samples), p95 at 20 clients",
    "ms",
    target=50.0,
    baseline="api: GET /health (no auth, no database), p95 at 20 clients",
    **COMMON,
)
def curves_p95(ctx: dict[str, Any]) -> float:
    return _measure(ctx, "curves", CURVES)


@figure(
    "api: GET one iteration's whole OCP trajectory (201 nodes), p95 at 20 clients",
    "ms",
    target=50.0,
    baseline="api: GET /health (no auth, no database), p95 at 20 clients",
    **COMMON,
)
def trajectory_p95(ctx: dict[str, Any]) -> float:
    return _measure(ctx, "trajectory", TRAJECTORY)


@figure(
    "api: GET metrics ?after=200 (empty poll), p95 at 20 clients",
    "ms",
    baseline="api: GET /health (no auth, no database), p95 at 20 clients",
    **COMMON,
)
def poll_p95(ctx: dict[str, Any]) -> float:
    return _measure(ctx, "poll", POLL)


@figure(
    "api: GET metrics series with If-None-Match (304), p95 at 20 clients",
    "ms",
    baseline="api: GET /health (no auth, no database), p95 at 20 clients",
    **COMMON,
)
def etag_p95(ctx: dict[str, Any]) -> float:
    return _measure(ctx, "etag", METRICS)


@figure(
    "api: GET campaign detail, p95 at 20 clients",
    "ms",
    baseline="api: GET /health (no auth, no database), p95 at 20 clients",
    **COMMON,
)
def detail_p95(ctx: dict[str, Any]) -> float:
    return _measure(ctx, "detail", DETAIL)


@figure(
    "api: GET campaign detail with If-None-Match (304), p95 at 20 clients",
    "ms",
    baseline="api: GET /health (no auth, no database), p95 at 20 clients",
    **COMMON,
)
def detail_etag_p95(ctx: dict[str, Any]) -> float:
    return _measure(ctx, "detail_etag", DETAIL)


def _from(key: str, what: str):
    def run(ctx: dict[str, Any]) -> float:
        got = ctx["results"].get(key)
        if not got:
            _measure(ctx, key, PATHS[key])
            got = ctx["results"][key]
        values = {
            "p50": [g["p50"] for g in got],
            "p99": [g["p99"] for g in got],
            "rps": [g["requests"] / g["seconds"] for g in got],
            "cpu": [g["cpu_ms"] for g in got],
            "kb": [g["size"] / 1024 for g in got],
        }[what]
        return statistics.median(values)

    return run


for _key, _label in (
    ("health", "/health"),
    ("metrics", "metrics series"),
    ("curves", "curves"),
    ("trajectory", "trajectory"),
    ("poll", "metrics ?after=200"),
    ("etag", "metrics 304"),
    ("detail", "campaign detail"),
    ("detail_etag", "campaign detail 304"),
):
    figure(f"api: GET {_label}, p50 at 20 clients", "ms", **{**COMMON, "reps": 1})(_from(_key, "p50"))
    figure(f"api: GET {_label}, p99 at 20 clients", "ms", **{**COMMON, "reps": 1})(_from(_key, "p99"))
    figure(f"api: GET {_label}, throughput at 20 clients", "req/s", higher_is_better=True, **{**COMMON, "reps": 1})(
        _from(_key, "rps")
    )
    figure(f"api: GET {_label}, API CPU per request", "ms", **{**COMMON, "reps": 1})(_from(_key, "cpu"))
    figure(f"api: GET {_label}, payload", "KiB", **{**COMMON, "reps": 1})(_from(_key, "kb"))
