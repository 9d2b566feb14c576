"""Send jobs once the transaction that made them necessary has committed.

Code that writes inside somebody else's transaction (a domain's rows written in the
transaction that completes a campaign step) cannot send after the commit itself:
:func:`send_after_commit` attaches the messages to the session and sends them from its
``after_commit`` event, so a rolled-back transaction sends nothing. A failed send loses
nothing: the rows are queued in the database and a reconciler re-sends them.
"""

from __future__ import annotations

import logging
from typing import Any

import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove.jobs import send_job

log = logging.getLogger(__name__)
_KEY = "alcove_after_commit_jobs"


def send_after_commit(session: Session, name: str, *args: Any) -> None:
    """Send job ``name(*args)`` after ``session``'s transaction commits (never if it rolls back)."""
    pending: list[tuple[str, tuple[Any, ...]]] | None = session.info.get(_KEY)
    if pending is None:
        pending = session.info[_KEY] = []
        sa.event.listen(session, "after_commit", _send, once=True)
        sa.event.listen(session, "after_rollback", _forget, once=True)
    pending.append((name, args))


def _send(session: Session) -> None:
    jobs = session.info.pop(_KEY, None) or []
    for name, args in jobs:
        try:
            send_job(name, *args)
        except Exception:
            log.exception("sending %s%r failed; the reconciler will re-send it", name, args)


def _forget(session: Session) -> None:
    session.info.pop(_KEY, None)
