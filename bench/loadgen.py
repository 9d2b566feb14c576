"""HTTP load generators for the API figures (``bench/figures/api.py``): closed-loop GETs from
``clients`` keep-alive connections, reported as latency percentiles (ms), requests and seconds.

``wrk`` (C, two threads; Debian package ``wrk``) with its latency distribution, or, where it
is missing, an httpx async client in Python (which eats much of the same cores: pessimistic).
Also the CPU time of a server's process group, read from /proc.
"""

from __future__ import annotations

import asyncio
import json
import os
import re
import shutil
import statistics
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

# wrk's report as one JSON line on stdout (latencies in us)
WRK_REPORT = """
done = function(summary, latency, requests)
  local e = summary.errors
  io.write(string.format(
    "WRK_JSON {\\"p50\\": %d, \\"p95\\": %d, \\"p99\\": %d, \\"requests\\": %d, "
      .. "\\"duration_us\\": %d, \\"bytes\\": %d, \\"errors\\": %d, \\"non2xx\\": %d}\\n",
    latency:percentile(50), latency:percentile(95), latency:percentile(99),
    summary.requests, summary.duration, summary.bytes,
    e.connect + e.read + e.write + e.timeout, e.status))
end
"""


def wrk(url: str, headers: dict[str, str], *, clients: int, seconds: float) -> dict[str, Any]:
    """``seconds`` of load by wrk (2 threads, ``clients`` connections); raises on any error or non-2xx."""
    with tempfile.NamedTemporaryFile("w", suffix=".lua", delete=False) as f:
        f.write(WRK_REPORT)
    try:
        cmd = ["wrk", "-t2", f"-c{clients}", f"-d{seconds:g}s", "--timeout", "10s", "-s", f.name]
        for k, v in headers.items():
            cmd += ["-H", f"{k}: {v}"]
        out = subprocess.run([*cmd, url], capture_output=True, text=True, timeout=seconds + 60)
    finally:
        os.unlink(f.name)
    m = re.search(r"WRK_JSON (\{.*\})", out.stdout)
    if m is None:
        raise RuntimeError(f"wrk gave no report: {out.stdout[-500:]} {out.stderr[-500:]}")
    r = json.loads(m.group(1))
    if r["errors"] or r["non2xx"]:
        raise RuntimeError(f"wrk: {r['errors']} socket errors, {r['non2xx']} non-2xx answers for {url}")
    return {
        "p50": r["p50"] / 1e3,
        "p95": r["p95"] / 1e3,
        "p99": r["p99"] / 1e3,
        "requests": r["requests"],
        "seconds": r["duration_us"] / 1e6,
    }


async def httpx_load(
    root: str,
    headers: dict[str, str],
    path: str,
    *,
    clients: int,
    requests_per_client: int | None = None,
    seconds: float | None = None,
) -> dict[str, Any]:
    """``clients`` concurrent httpx clients, each sending GETs one after the other: ``requests_per_client``
    each, or as many as fit in ``seconds``."""
    import httpx

    if (requests_per_client is None) == (seconds is None):
        raise ValueError("give requests_per_client or seconds")
    limits = httpx.Limits(max_connections=clients, max_keepalive_connections=clients)
    async with httpx.AsyncClient(base_url=root, headers=headers, limits=limits, timeout=30) as client:
        latencies: list[float] = []
        t0 = time.perf_counter()
        deadline = t0 + seconds if seconds is not None else None

        async def one_client() -> None:
            sent = 0
            while (deadline is None and sent < (requests_per_client or 0)) or (
                deadline is not None and time.perf_counter() < deadline
            ):
                start = time.perf_counter()
                resp = await client.get(path)
                latencies.append((time.perf_counter() - start) * 1e3)
                sent += 1
                if resp.status_code >= 400:
                    resp.raise_for_status()

        await asyncio.gather(*(one_client() for _ in range(clients)))
        elapsed = time.perf_counter() - t0
    return {
        "p50": _quantile(latencies, 50),
        "p95": _quantile(latencies, 95),
        "p99": _quantile(latencies, 99),
        "requests": len(latencies),
        "seconds": elapsed,
    }


def closed_loop(root: str, headers: dict[str, str], path: str, *, clients: int, seconds: float) -> dict[str, Any]:
    """``seconds`` of closed-loop GETs of ``root + path`` from ``clients`` connections: by ``wrk`` where it
    is installed, else by :func:`httpx_load` for as long (in Python on the same cores: pessimistic)."""
    if load_tool() == "wrk":
        return wrk(root + path, headers, clients=clients, seconds=seconds)
    return asyncio.run(httpx_load(root, headers, path, clients=clients, seconds=seconds))


def load_tool() -> str:
    """``"wrk"`` where it is installed, else ``"httpx"``."""
    return "wrk" if shutil.which("wrk") else "httpx"


def _quantile(values: list[float], q: float) -> float:
    return statistics.quantiles(values, n=100, method="inclusive")[int(q) - 1]


def process_group_cpu_s(pid: int) -> float:
    """CPU time (user + system) of the process group led by ``pid`` (a server and its workers)."""
    total = 0.0
    tick = os.sysconf("SC_CLK_TCK")
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            fields = (d / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == pid or int(d.name) == pid:  # fields[2] = pgrp (the server leads its own session)
            total += (int(fields[11]) + int(fields[12])) / tick
    return total
