"""REST API under load (``python -m bench.run --only "api:"``).

Setup (untimed): a private PostgreSQL schema, migrated, holding a 200-iteration campaign
synthesized through the services/repositories (``tests/api/synthetic.py``: iterations,
steps, metrics with 401-sample curves, pool versions), and a real uvicorn server on
loopback. Each repetition: 20 concurrent clients (httpx async, keep-alive) each make
25 authenticated GETs; the figure is the p95 of the per-request latency. p50/p99 and
payload sizes are reported from the same measurement.
"""

from __future__ import annotations

import asyncio
import functools
import os
import statistics
import subprocess
import sys
import time
import uuid
from pathlib import Path
from typing import Any
from urllib.parse import quote

from bench.harness import figure

ITERATIONS = 200
CLIENTS = 20
REQUESTS_PER_CLIENT = 25
PG_URL = os.environ.get("ALCOVE_BENCH_PG_URL", "postgresql+psycopg://postgres@127.0.0.1:5432/test")
REPO = Path(__file__).resolve().parents[2]


def _pg_missing() -> str | None:
    import sqlalchemy as sa

    try:
        eng = sa.create_engine(PG_URL, poolclass=sa.pool.NullPool, connect_args={"connect_timeout": 3})
        with eng.connect() as c:
            c.exec_driver_sql("select 1")
        eng.dispose()
    except Exception as err:  # noqa: BLE001
        return f"PostgreSQL not available at {PG_URL} ({type(err).__name__}); set ALCOVE_BENCH_PG_URL"
    return None


@functools.cache
def server() -> dict[str, Any]:
    """Migrated schema + synthetic campaign + uvicorn on a free port (kept for all figures)."""
    import atexit
    import socket

    import httpx
    import sqlalchemy as sa

    schema = f"alcove_bench_api_{uuid.uuid4().hex[:8]}"
    sep = "&" if "?" in PG_URL else "?"
    url = f"{PG_URL}{sep}options={quote(f'-csearch_path={schema}')}"
    base = sa.create_engine(PG_URL, poolclass=sa.pool.NullPool)
    with base.begin() as c:
        c.exec_driver_sql(f'CREATE SCHEMA "{schema}"')
    os.environ["ALCOVE_DATABASE_URL"] = url
    from alcove.db import migrate, session_scope
    from alcove.models import ApiToken, TokenKind, User
    from alcove.settings import get_settings

    get_settings.cache_clear()
    migrate.upgrade(url)
    sys.path.insert(0, str(REPO))
    from tests.api.synthetic import synthesize_campaign

    with session_scope(url) as s:
        user = User(email="bench@example.org", role="member")
        s.add(user)
        s.flush()
        token, secret = ApiToken.issue(user, kind=TokenKind.personal, name="bench")
        s.add(token)
        campaign = synthesize_campaign(s, user.id, iterations=ITERATIONS, name="bench-200")
        cid = campaign.id
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    env = {**os.environ, "ALCOVE_DATABASE_URL": url, "ALCOVE_LOG_LEVEL": "WARNING"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "uvicorn", "alcove.api.app:create_app", "--factory", "--host", "127.0.0.1", "--port", str(port), "--log-level", "warning", "--no-access-log", "--timeout-keep-alive", "120"],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
    )

    def stop() -> None:
        proc.terminate()
        proc.wait(timeout=10)
        with base.begin() as c:
            c.exec_driver_sql(f'DROP SCHEMA IF EXISTS "{schema}" CASCADE')
        base.dispose()

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
    return {"root": root, "headers": {"Authorization": f"Bearer {secret}"}, "campaign_id": cid, "results": {}}


async def _load(root: str, headers: dict[str, str], path: str) -> tuple[list[float], int]:
    import httpx

    limits = httpx.Limits(max_connections=CLIENTS, max_keepalive_connections=CLIENTS)
    async with httpx.AsyncClient(base_url=root, headers=headers, limits=limits, timeout=30) as client:
        r = await client.get(path)  # warm-up (and payload size)
        r.raise_for_status()
        size = len(r.content)
        latencies: list[float] = []

        async def one_client() -> None:
            for _ in range(REQUESTS_PER_CLIENT):
                t0 = time.perf_counter()
                resp = await client.get(path)
                latencies.append((time.perf_counter() - t0) * 1e3)
                resp.raise_for_status()

        await asyncio.gather(*(one_client() for _ in range(CLIENTS)))
    return latencies, size


def _quantile(values: list[float], q: float) -> float:
    return statistics.quantiles(values, n=100, method="inclusive")[int(q) - 1]


def _measure(ctx: dict[str, Any], key: str, path: str) -> float:
    latencies, size = asyncio.run(_load(ctx["root"], ctx["headers"], path.format(cid=ctx["campaign_id"])))
    ctx["results"].setdefault(key, {"latencies": [], "size": size})["latencies"].extend(latencies)
    return _quantile(latencies, 95)


HEALTH = "/health"
METRICS = "/campaigns/{cid}/metrics"
CURVES = "/campaigns/{cid}/iterations/137/curves"
COMMON = {"setup": server, "requires": _pg_missing, "group": "api", "reps": 3, "quick_reps": 1}


@figure("api: GET /health (no auth, no database), p95 at 20 clients", "ms", **COMMON,
        notes="the framework's floor on this machine under the same load: compare the routes below with it")
def health_p95(ctx: dict[str, Any]) -> float:
    return _measure(ctx, "health", HEALTH)


@figure("api: GET metrics series (200 iterations), p95 at 20 clients", "ms", target=30.0, baseline="api: GET /health (no auth, no database), p95 at 20 clients", **COMMON)
def metrics_p95(ctx: dict[str, Any]) -> float:
    return _measure(ctx, "metrics", METRICS)


@figure("api: GET one iteration's curves (401 samples), p95 at 20 clients", "ms", target=50.0, baseline="api: GET /health (no auth, no database), p95 at 20 clients", **COMMON)
def curves_p95(ctx: dict[str, Any]) -> float:
    return _measure(ctx, "curves", CURVES)


def _from(key: str, what: str):  # noqa: ANN202
    def run(ctx: dict[str, Any]) -> float:
        got = ctx["results"].get(key)
        if not got:
            _measure(ctx, key, {"metrics": METRICS, "curves": CURVES, "health": HEALTH}[key])
            got = ctx["results"][key]
        lat = got["latencies"]
        return {"p50": lambda: _quantile(lat, 50), "p99": lambda: _quantile(lat, 99), "kb": lambda: got["size"] / 1024}[what]()

    return run


for _key, _label in (("health", "/health"), ("metrics", "metrics series"), ("curves", "curves")):
    figure(f"api: GET {_label}, p50 at 20 clients", "ms", **{**COMMON, "reps": 1})(_from(_key, "p50"))
    figure(f"api: GET {_label}, p99 at 20 clients", "ms", **{**COMMON, "reps": 1})(_from(_key, "p99"))
    figure(f"api: GET {_label}, payload", "KiB", **{**COMMON, "reps": 1})(_from(_key, "kb"))
