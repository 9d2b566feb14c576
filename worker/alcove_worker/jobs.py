"""Celery job wrappers. Thin: parse the message, call the domain code in ``alcove``.

Names follow ``alcove.<queue>.<what>`` (see :func:`alcove.jobs.queue_for`), so the API
can send a job by name without importing this module (or torch, or casadi).
"""

from __future__ import annotations

from typing import Any

from alcove.jobs import SMOKE_JOB
from alcove_worker.celery_app import app


@app.task(name=SMOKE_JOB, bind=True)
def smoke(self: Any, token: str, sent_at: float | None = None) -> int:
    """Write one ``smoke_checks`` row in one transaction (idempotent per token)."""
    from alcove.jobs.smoke import run_smoke

    return run_smoke(token, worker_name=self.request.hostname or "unknown", sent_at=sent_at)
