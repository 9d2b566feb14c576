"""Request dependencies shared by the routers."""

from __future__ import annotations

from collections.abc import AsyncIterator
from typing import Annotated

from fastapi import Depends, Request
from sqlalchemy.orm import Session
from starlette.concurrency import run_in_threadpool

from alcove.db import get_sessionmaker
from alcove.settings import Settings, get_settings

#: Methods that only read: their sessions begin deferred (readers never wait in WAL mode).
READ_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})


def settings_dep() -> Settings:
    return get_settings()


async def get_session(request: Request) -> AsyncIterator[Session]:
    """One session per request. The route (or the service it calls) decides when to commit;
    anything not committed is rolled back at the end of the request.

    On SQLite a request that may write (POST, PUT, PATCH, DELETE) gets a session whose
    transactions begin with ``BEGIN IMMEDIATE``: the write lock is taken at the first
    statement and a concurrent writer (a worker committing a step) is waited for, up to the
    busy timeout. A deferred transaction that read first would instead fail at its first
    write with "database is locked" (SQLITE_BUSY_SNAPSHOT, which no timeout helps) whenever
    anyone else committed in between. On PostgreSQL both are the same factory.

    Opening a session does no I/O (a connection is taken at the first query), so it happens
    on the event loop; closing is sent to the thread pool only when the session holds a
    connection. This saves two thread hops per request, which dominate the cost of a
    polled route on a busy machine."""
    session = get_sessionmaker(immediate=request.method not in READ_METHODS)()
    try:
        yield session
    finally:
        if session.in_transaction():
            await run_in_threadpool(session.close)
        else:
            session.close()


SessionDep = Annotated[Session, Depends(get_session)]
SettingsDep = Annotated[Settings, Depends(settings_dep)]
