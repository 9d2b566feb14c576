"""Watching a running campaign (``python -m bench.run --only "live:"``): what 50 viewers cost.

Setup (untimed): a private PostgreSQL schema, migrated; the API served the way ``alcove
serve`` does it (uvicorn, its default processes) and one ``alcove worker`` (all queues, one
process) sharing the embedded filesystem broker in a temporary data dir; a small campaign
(aux-penalty oracle, 400 LHS samples, 20 OCP intervals per phase, 60 epochs) that runs for
the whole measurement. Then phases of ``PHASE_S`` seconds (20; 10 in --quick) on the same
campaign, the first two alternating ``ROUNDS`` times so that a change in the machine's load
hits both:

1. nobody watches (the baseline);
2. ``VIEWERS`` clients hold the campaign's event stream open
   (``GET /campaigns/{id}/events/stream``, server-sent events, read as they come by plain
   asyncio sockets in a thread of the bench process; their CPU is reported too);
3. ``VIEWERS`` clients poll the campaign's metrics series in a closed loop (the old way of
   watching; its p95 is reported): ``wrk`` where it is installed (Debian package ``wrk``), else
   httpx in the bench process (:func:`bench.loadgen.closed_loop`; pessimistic: it eats the same
   cores as the API), named in the figure's note.

Reported per phase: the API processes' CPU (user + system, from /proc, as % of one core)
and the median iteration wall time (time between two consecutive iterations' ``append``
steps finishing). Targets: 50 stream viewers cost the API < 10 % of one core and
leave the iteration time within 5 % of the baseline. This machine is small and shared
(2 cores; the worker, the API, PostgreSQL and the load generator share them): the
iteration times are noisy, read the load average printed with the figures.
"""

from __future__ import annotations

import asyncio
import functools
import itertools
import json
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from bench.figures.api import PgSchema, _pg_missing
from bench.harness import figure, quick
from bench.loadgen import closed_loop, load_tool, process_group_cpu_s

VIEWERS = 50
PHASE_S = float(os.environ.get("ALCOVE_BENCH_LIVE_SECONDS", "20"))
#: nobody / viewers phases, alternating
ROUNDS = 3
CAMPAIGN = {
    "preliminary": {"samples": 400, "chunks": 4},
    "settings": {"ocp_intervals": 20, "replay_dt": 0.01},
    "stopping": {"max_iterations": 1000},
}


def _phase_s() -> float:
    return min(PHASE_S, 10.0) if quick() else PHASE_S


def _spawn(args: list[str], env: dict[str, str], log: Path) -> subprocess.Popen[bytes]:
    with open(log, "wb") as fh:
        return subprocess.Popen(
            [sys.executable, "-m", "alcove_worker.cli.main", *args],
            env=env,
            stdout=fh,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )


def _stop(p: subprocess.Popen[bytes]) -> None:
    p.terminate()
    try:
        p.wait(timeout=20)
    except subprocess.TimeoutExpired:
        p.kill()
        p.wait(timeout=5)


def _make_campaign(url: str) -> tuple[int, str]:
    """A started campaign of the local user and a token of that user (who may watch it)."""
    from alcove.campaigns import presets, service
    from alcove.campaigns.schemas import CampaignCreate
    from alcove.db import open_transaction
    from alcove.jobs.campaign import send_committed, stage
    from alcove.users import service as users

    with open_transaction(url) as s:
        u = presets.local_user(s)
        data = CampaignCreate(
            name="bench-live",
            task_version_id=presets.task_version_from_preset(s, u.id, "head-headrest-2phase"),
            oracle_version_id=presets.oracle_version_for(s, u.id, "aux-penalty"),
            surrogate_config_version_id=presets.surrogate_config_version_for(s, u.id, {"max_epochs": 60}),
            **CAMPAIGN,
        )
        c = service.create_campaign(s, u.id, data)
        staged = stage(s, service.start(s, c.id)[1])
        secret = users.create_token(s, u, "bench-live", None)[1]
        cid = c.id
    send_committed(staged)
    return cid, secret


def _appends(url: str, cid: int) -> list[float]:
    """Wall-clock times (s since the epoch) at which the campaign's iterations finished."""
    import sqlalchemy as sa

    eng = sa.create_engine(url, poolclass=sa.pool.NullPool)
    with eng.connect() as c:
        got = c.execute(
            sa.text(
                "SELECT s.finished_at FROM iteration_steps s JOIN iterations i ON i.id = s.iteration_id "
                "WHERE s.campaign_id = :c AND s.step = 'append' AND s.status = 'succeeded' ORDER BY i.index"
            ),
            {"c": cid},
        ).all()
    eng.dispose()
    return [r[0].timestamp() for r in got]


class Viewers(threading.Thread):
    """``n`` clients reading the campaign's event stream (server-sent events) until stopped:
    plain asyncio sockets (HTTP/1.1), each counting the ``event:`` lines it receives; as
    cheap a load generator as Python allows (its own CPU time is reported as ``client_cpu``)."""

    def __init__(self, root: str, headers: dict[str, str], cid: int, n: int) -> None:
        super().__init__(daemon=True, name="bench-viewers")
        parts = urlsplit(f"{root}/campaigns/{cid}/events/stream?timeout=3600")
        self.host, self.port = parts.hostname or "127.0.0.1", parts.port or 80
        lines = [f"GET {parts.path}?{parts.query} HTTP/1.1", f"Host: {self.host}:{self.port}"]
        lines += [f"{k}: {v}" for k, v in headers.items()] + ["Accept: text/event-stream", "", ""]
        self.request = "\r\n".join(lines).encode()
        self.n = n
        self.events = 0
        self.connected = 0
        self.cpu_s = 0.0
        self.errors: list[str] = []
        self._done = threading.Event()

    def run(self) -> None:
        t0 = time.thread_time()
        asyncio.run(self._main())
        self.cpu_s = time.thread_time() - t0

    async def _main(self) -> None:
        tasks = [asyncio.create_task(self._one()) for _ in range(self.n)]
        while not self._done.is_set():
            await asyncio.sleep(0.2)
        for t in tasks:
            t.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)

    async def _one(self) -> None:
        reader, writer = await asyncio.open_connection(self.host, self.port)
        try:
            writer.write(self.request)
            status = await reader.readline()
            if b" 200 " not in status:
                self.errors.append(status.decode(errors="replace"))
                return
            self.connected += 1
            while data := await reader.read(65536):
                self.events += data.count(b"\nevent: ") + data.startswith(b"event: ")
        finally:
            writer.close()

    def stop(self) -> None:
        self._done.set()
        self.join(timeout=10)


@functools.cache
def watched_campaign() -> dict[str, Any]:
    """Runs the three phases once; the figures read their values from the result."""
    import httpx

    from alcove.db import migrate
    from alcove.settings import get_settings
    from alcove_worker.cli.serve import default_api_workers

    schema = PgSchema("alcove_bench_live")
    url = schema.url
    tmp = Path(tempfile.mkdtemp(prefix="alcove-bench-live-"))
    env = {k: v for k, v in os.environ.items() if not k.startswith("ALCOVE_")}
    env.update(ALCOVE_DATABASE_URL=url, ALCOVE_DATA_DIR=str(tmp / "data"), ALCOVE_LOG_LEVEL="WARNING")
    saved = {k: os.environ.get(k) for k in ("ALCOVE_DATABASE_URL", "ALCOVE_DATA_DIR", "ALCOVE_BROKER_URL")}
    os.environ.update(ALCOVE_DATABASE_URL=url, ALCOVE_DATA_DIR=str(tmp / "data"))
    os.environ.pop("ALCOVE_BROKER_URL", None)
    get_settings.cache_clear()
    from alcove.db import dispose_engines
    from alcove.jobs import reset_sender

    dispose_engines(close=True)
    reset_sender()
    migrate.upgrade(url)
    import socket

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    workers = default_api_workers()
    api = _spawn(
        ["serve", "--host", "127.0.0.1", "--port", str(port), "--workers", str(workers), "--no-migrate"],
        env,
        tmp / "api.log",
    )
    worker = _spawn(["worker", "--concurrency", "1", "--name", "bench-live"], env, tmp / "worker.log")
    root = f"http://127.0.0.1:{port}/api/v1"
    out: dict[str, Any] = {"api_workers": workers}
    try:
        for _ in range(300):
            try:
                if httpx.get(f"{root}/health", timeout=1).status_code == 200:
                    break
            except httpx.HTTPError:
                pass
            time.sleep(0.1)
        else:
            raise RuntimeError(f"the API did not start: {(tmp / 'api.log').read_text()[-2000:]}")
        cid, secret = _make_campaign(url)
        headers = {"Authorization": f"Bearer {secret}"}
        deadline = time.monotonic() + 600
        while len(_appends(url, cid)) < 3:  # warm: preliminary data, the first iterations
            if time.monotonic() > deadline or worker.poll() is not None:
                raise RuntimeError(f"the campaign did not run: {(tmp / 'worker.log').read_text()[-2000:]}")
            time.sleep(0.5)

        samples: dict[str, list[dict[str, float]]] = {"idle": [], "stream": [], "poll": []}

        def phase(name: str, during: Any) -> None:
            t0, cpu0 = time.time(), process_group_cpu_s(api.pid)
            extra = during()
            t1, cpu1 = time.time(), process_group_cpu_s(api.pid)
            done = [t for t in _appends(url, cid) if t0 <= t <= t1]
            got = {
                "seconds": t1 - t0,
                "api_cpu_s": cpu1 - cpu0,
                "load": os.getloadavg()[0],
                **(extra or {}),
            }
            samples[name].append({**got, "walls": [b - a for a, b in itertools.pairwise(done)]})  # type: ignore[dict-item]
            print(f"  live: {name}: {json.dumps({k: round(v, 3) for k, v in got.items()})}, {len(done)} iterations")

        def stream() -> dict[str, float]:
            v = Viewers(root, headers, cid, VIEWERS)
            v.start()
            time.sleep(_phase_s())
            connected, seen = v.connected, v.events
            v.stop()
            if connected < VIEWERS:
                raise RuntimeError(f"only {connected} of {VIEWERS} viewers connected: {v.errors[:3]}")
            return {"events_received": float(seen), "client_cpu_s": v.cpu_s}

        def poll() -> dict[str, float]:
            got = closed_loop(root, headers, f"/campaigns/{cid}/metrics", clients=VIEWERS, seconds=_phase_s())
            return {"poll_p95_ms": got["p95"], "poll_rps": got["requests"] / got["seconds"]}

        # nobody and the viewers alternate, and nobody watches before and after every viewers
        # phase: the iterations slow down as the pool grows (each appends a trajectory, training
        # takes longer), so each viewers phase is compared with the mean of the two phases that
        # bracket it, not with all idle phases pooled (which would count the growth as the
        # viewers' cost)
        for _ in range(ROUNDS):
            phase("idle", lambda: time.sleep(_phase_s()))
            phase("stream", stream)
        phase("idle", lambda: time.sleep(_phase_s()))
        phase("poll", poll)

        def median_wall(run: dict[str, Any]) -> float:
            return statistics.median(run["walls"]) if run["walls"] else float("nan")

        idle_runs, stream_runs = samples["idle"], samples["stream"]
        slowdowns = [
            100.0 * (median_wall(v) / (0.5 * (median_wall(idle_runs[i]) + median_wall(idle_runs[i + 1]))) - 1.0)
            for i, v in enumerate(stream_runs)
        ]
        rounded = [round(x, 1) for x in slowdowns]
        print(f"  live: slowdown per viewers phase against its bracketing idle phases: {rounded} %")
        out["stream_slowdown_percent"] = statistics.median(slowdowns)
        for name, runs in samples.items():
            walls = [w for r in runs for w in r["walls"]]  # type: ignore[union-attr]
            seconds = sum(r["seconds"] for r in runs)
            out[name] = {
                "cpu_percent": 100.0 * sum(r["api_cpu_s"] for r in runs) / seconds,
                "iteration_s": statistics.median(walls) if walls else float("nan"),
                "iterations": len(walls),
                "load": statistics.mean(r["load"] for r in runs),
                "client_cpu_percent": 100.0 * sum(r.get("client_cpu_s", 0.0) for r in runs) / seconds,
                **({"poll_p95_ms": runs[0]["poll_p95_ms"]} if name == "poll" else {}),
            }
            print(f"  live: {name} overall: {json.dumps({k: round(v, 3) for k, v in out[name].items()})}")
    finally:
        _stop(worker)
        _stop(api)
        schema.drop()
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
        get_settings.cache_clear()
        dispose_engines(close=True)
        reset_sender()
    return out


COMMON: dict[str, Any] = {
    "setup": watched_campaign,
    "requires": _pg_missing,
    "group": "live",
    "reps": 1,
    "quick_reps": 1,
}
IDLE = "live: iteration wall time, nobody watching (aux-penalty, small)"


@figure(IDLE, "s", **COMMON, notes="median time between consecutive iterations finishing, same campaign throughout")
def idle_iteration(ctx: dict[str, Any]) -> float:
    return float(ctx["idle"]["iteration_s"])


@figure("live: API CPU, nobody watching", "% of a core", **COMMON, notes="API processes (uvicorn), from /proc")
def idle_cpu(ctx: dict[str, Any]) -> float:
    return float(ctx["idle"]["cpu_percent"])


@figure(
    f"live: API CPU, {VIEWERS} viewers on the event stream (SSE)",
    "% of a core",
    target=10.0,
    **COMMON,
    notes="one event hub per API process: one query per second for all viewers",
)
def stream_cpu(ctx: dict[str, Any]) -> float:
    return float(ctx["stream"]["cpu_percent"])


@figure(f"live: iteration wall time, {VIEWERS} viewers on the event stream", "s", baseline=IDLE, **COMMON)
def stream_iteration(ctx: dict[str, Any]) -> float:
    return float(ctx["stream"]["iteration_s"])


@figure(
    f"live: iteration slowdown, {VIEWERS} viewers on the event stream",
    "%",
    target=5.0,
    **COMMON,
    notes="median over viewers phases of stream / mean(idle before, after) - 1 (iterations slow as the pool grows)",
)
def stream_slowdown(ctx: dict[str, Any]) -> float:
    return float(ctx["stream_slowdown_percent"])


@figure(f"live: API CPU, {VIEWERS} clients polling metrics (closed loop)", "% of a core", **COMMON)
def poll_cpu(ctx: dict[str, Any]) -> float:
    return float(ctx["poll"]["cpu_percent"])


@figure(f"live: iteration wall time, {VIEWERS} clients polling metrics", "s", baseline=IDLE, **COMMON)
def poll_iteration(ctx: dict[str, Any]) -> float:
    return float(ctx["poll"]["iteration_s"])


@figure(
    f"live: metrics poll p95, {VIEWERS} clients (closed loop)",
    "ms",
    **COMMON,
    notes=f"load generator: {load_tool()} (httpx: in Python on the same cores, pessimistic)",
)
def poll_p95(ctx: dict[str, Any]) -> float:
    return float(ctx["poll"]["poll_p95_ms"])


@figure(
    f"live: the {VIEWERS} stream viewers' own CPU (load generator, not the API)",
    "% of a core",
    **COMMON,
    notes="asyncio sockets in the bench process, on the same 2 cores as the API and the worker",
)
def stream_client_cpu(ctx: dict[str, Any]) -> float:
    return float(ctx["stream"]["client_cpu_percent"])
