"""Send jobs once the transaction that made them necessary has committed.

Code that writes inside somebody else's transaction (a domain's rows written in the
transaction that completes a campaign step) cannot send after the commit itself:
:func:`send_after_commit` records the job in the outbox (:mod:`alcove.jobs.outbox`) in that
transaction and sends it from the session's ``after_commit`` event, so a rolled-back
transaction sends nothing and a failed send loses nothing (the outbox relay sends it when
the broker answers, and again after a broker restart if no worker took it).
"""

from __future__ import annotations

import logging
from typing import Any

import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove.jobs import outbox

log = logging.getLogger(__name__)
_KEY = "alcove_after_commit_jobs"


def send_after_commit(session: Session, name: str, *args: Any) -> None:
    """Record job ``name(*args)`` in ``session``'s transaction and send it after the commit
    (never if it rolls back)."""
    what = name.rsplit(".", 1)[-1]
    row = outbox.record(session, name, args, subject=f"{what}/{'/'.join(str(a) for a in args)}"[:90])
    pending: list[int] | None = session.info.get(_KEY)
    if pending is None:
        pending = session.info[_KEY] = []
        sa.event.listen(session, "after_commit", _send, once=True)
        sa.event.listen(session, "after_rollback", _forget, once=True)
    pending.append(row.id)


def _send(session: Session) -> None:
    ids = session.info.pop(_KEY, None) or []
    if ids:
        outbox.send_now(ids)


def _forget(session: Session) -> None:
    session.info.pop(_KEY, None)
