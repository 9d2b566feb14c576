"""Authentication dependencies: ``Authorization: Bearer <token>`` (a login session token
or a personal API token). Every route except health and login depends on
:data:`CurrentUser`; admin-only routes on :data:`AdminUser`."""

from __future__ import annotations

import logging
from datetime import datetime
from typing import Annotated

from fastapi import Depends, HTTPException, Request, status
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer
from sqlalchemy.orm import Session
from sqlalchemy.orm.attributes import set_committed_value
from starlette.concurrency import run_in_threadpool

from alcove.api.deps import SessionDep
from alcove.models import ApiToken, User, utcnow
from alcove.users import service

log = logging.getLogger(__name__)

bearer_scheme = HTTPBearer(
    auto_error=False, description="A token from `POST /api/v1/auth/login` or a personal API token (`alc_...`)."
)


def _unauthorized(detail: str) -> HTTPException:
    return HTTPException(status.HTTP_401_UNAUTHORIZED, detail=detail, headers={"WWW-Authenticate": "Bearer"})


async def current_token(
    request: Request,
    session: SessionDep,
    credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(bearer_scheme)],
) -> ApiToken:
    if credentials is None or credentials.scheme.lower() != "bearer" or not credentials.credentials:
        raise _unauthorized("not authenticated: send Authorization: Bearer <token>")
    secret = credentials.credentials
    # in a thread: the revocation generation is read from Redis, the token from the cache or the database
    found = await run_in_threadpool(_lookup, session, secret)
    if found is None:
        raise _unauthorized("invalid, expired or revoked token")
    token, user = found
    request.state.user = user
    return token


def _lookup(session: Session, secret: str) -> tuple[ApiToken, User] | None:
    found = service.authenticate(session, secret)
    # End the lookup's transaction at once, so the request holds no connection while the route
    # runs: a route may take one of the same pool for itself (a cached body's build opens its
    # own session), and requests that each hold one while waiting for another exhaust the pool
    # and wait for one another until the pool times out (seen with 20 concurrent first requests
    # against a pool of 15). Nothing is expired (expire_on_commit=False); on SQLite a write
    # request's BEGIN IMMEDIATE is taken again by the route's first statement.
    session.commit()
    if found is not None and service.needs_touch(found[0]):
        if session.get_bind().dialect.name == "sqlite" and not _is_immediate(session):
            # a read-only request: record the use in its own short write transaction (the
            # request's session begins deferred and is kept for reads)
            now = _touch(found[0].id)
            set_committed_value(found[0], "last_used_at", now)  # not a pending change of this session
        else:
            found[0].last_used_at = utcnow()
            session.commit()  # nothing else happened in this session yet
    return found


def _is_immediate(session: Session) -> bool:
    from alcove.db import get_engine

    return session.get_bind() is get_engine(immediate=True)


def _touch(token_id: int) -> datetime:
    """Best effort: ``last_used_at`` is informational, a busy database must not fail the request."""
    from sqlalchemy import exc, update

    from alcove.db import run_transaction

    now = utcnow()
    try:
        run_transaction(
            lambda s: s.execute(update(ApiToken).where(ApiToken.id == token_id).values(last_used_at=now)), attempts=3
        )
    except exc.OperationalError:
        log.warning("could not record the use of token %d (database busy)", token_id)
    return now


async def current_user(request: Request, token: Annotated[ApiToken, Depends(current_token)]) -> User:
    user = request.state.user  # set by current_token
    assert isinstance(user, User)  # request.state is untyped
    return user


async def admin_user(user: Annotated[User, Depends(current_user)]) -> User:
    if not user.is_admin:
        raise HTTPException(status.HTTP_403_FORBIDDEN, detail="administrators only")
    return user


CurrentToken = Annotated[ApiToken, Depends(current_token)]
CurrentUser = Annotated[User, Depends(current_user)]
AdminUser = Annotated[User, Depends(admin_user)]
