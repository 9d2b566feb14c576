"""The smoke job: proves that a message went through the broker to a worker process and
that the worker's result was committed to the database (one transaction, idempotent)."""

from __future__ import annotations

import os
import socket
import time
from typing import Any

import sqlalchemy as sa

from alcove.db import open_transaction, run_transaction
from alcove.models import SmokeCheck
from alcove.science.parallel import usable_cpus


def run_smoke(token: str, worker_name: str, sent_at: float | None = None) -> int:
    """Write the smoke row for ``token`` (once; a duplicate delivery is a no-op). Returns its id."""

    def work(s: sa.orm.Session) -> int:
        existing = s.scalar(sa.select(SmokeCheck.id).where(SmokeCheck.token == token))
        if existing is not None:
            return existing
        row = SmokeCheck(
            token=token,
            worker_name=worker_name,
            payload={
                "pid": os.getpid(),
                "host": socket.gethostname(),
                # the CPUs the worker's pool process may use (ALCOVE_CPUS_PER_PROCESS caps them: science.parallel)
                "cpus": usable_cpus(),
                "sent_at": sent_at,
                "ran_at": time.time(),
            },
        )
        s.add(row)
        s.flush()
        return row.id

    return run_transaction(work)


def smoke_result(token: str) -> dict[str, Any] | None:
    with open_transaction() as s:
        row = s.scalar(sa.select(SmokeCheck).where(SmokeCheck.token == token))
        if row is None:
            return None
        return {
            "id": row.id,
            "token": row.token,
            "worker_name": row.worker_name,
            "payload": row.payload,
            "created_at": row.created_at.isoformat(),
        }


def wait_for_smoke(token: str, timeout: float = 60.0, poll: float = 0.05) -> dict[str, Any] | None:
    deadline = time.monotonic() + timeout
    while True:
        got = smoke_result(token)
        if got is not None or time.monotonic() > deadline:
            return got
        time.sleep(poll)
