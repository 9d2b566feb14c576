"""Routes: login/logout, ``/me`` and personal tokens, user administration, sharing."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Query, Request, Response, status

from alcove.api.client_address import client_address
from alcove.api.deps import SessionDep
from alcove.api.errors import ErrorOut
from alcove.api.params import MAX_ID, ObjectId
from alcove.errors import LoginLocked
from alcove.models import ApiToken
from alcove.users import repository as repo
from alcove.users import service
from alcove.users.auth import AdminUser, CurrentToken, CurrentUser
from alcove.users.ratelimit import LoginThrottle
from alcove.users.schemas import (
    LoginIn,
    LoginOut,
    MeUpdate,
    ObjectType,
    ShareCreate,
    ShareOut,
    TokenCreate,
    TokenCreated,
    TokenOut,
    UserCreate,
    UserOut,
    UserUpdate,
)

router = APIRouter()

AUTH_ERRORS: dict[int | str, dict[str, Any]] = {
    401: {"model": ErrorOut, "description": "wrong e-mail or password (the same for an unknown e-mail)"},
    429: {"model": ErrorOut, "description": "too many failed logins: wait the seconds in Retry-After"},
}


def _token_out(token: ApiToken, secret: str | None = None) -> TokenOut:
    data = {
        c: getattr(token, c)
        for c in ("id", "name", "kind", "token_prefix", "created_at", "last_used_at", "expires_at", "revoked_at")
    }
    data["revoked"] = token.revoked_at is not None
    return TokenCreated(**data, token=secret) if secret else TokenOut(**data)


def login_throttle(request: Request) -> LoginThrottle:
    """The app's login throttle (:func:`alcove.app.create_app` makes one per app)."""
    throttle: LoginThrottle = request.app.state.login_throttle  # app.state is untyped; set by create_app
    return throttle


@router.post("/auth/login", response_model=LoginOut, tags=["auth"], operation_id="login", responses=AUTH_ERRORS)
def login(body: LoginIn, request: Request, session: SessionDep) -> LoginOut:
    """Exchange e-mail and password for a bearer token (valid 12 h).

    Failed logins are throttled per (e-mail, client address): five cost nothing, then each
    further attempt from that address on that e-mail must wait a delay that doubles from 1 s
    up to 5 minutes; 30 failures from one client address within 5 minutes block that address
    for the rest of the 5 minutes. Both answer 429 with Retry-After (the seconds to wait).
    An unknown e-mail is answered exactly like a wrong password (401, same body, same work),
    and throttled the same way; an account is never locked for its owner on another address."""
    throttle = login_throttle(request)
    client = client_address(request, request.app.state.trusted_proxies, request.app.state.forwarded_header)
    wait = throttle.begin(body.email, client)
    if wait:
        raise LoginLocked("too many failed logins: try again later", wait)
    token, secret = service.login(session, body.email, body.password)  # a failure stays counted
    session.commit()
    throttle.succeeded(body.email, client)
    return LoginOut(access_token=secret, expires_at=token.expires_at)


@router.post("/auth/logout", status_code=status.HTTP_204_NO_CONTENT, tags=["auth"], operation_id="logout")
def logout(token: CurrentToken, session: SessionDep) -> Response:
    """Revoke the token this request was made with."""
    service.revoke(session, token)
    session.commit()
    return Response(status_code=status.HTTP_204_NO_CONTENT)


@router.get("/me", response_model=UserOut, tags=["me"], operation_id="get_me")
async def get_me(user: CurrentUser) -> UserOut:
    return UserOut.model_validate(user)


@router.patch("/me", response_model=UserOut, tags=["me"], operation_id="update_me")
def update_me(body: MeUpdate, user: CurrentUser, session: SessionDep) -> UserOut:
    """Change your display name or password. A new password ends every session of yours (this
    one too: log in again) and every personal token, unless `keep_personal_tokens` is true."""
    user = session.merge(user)
    service.update_me(
        session, user, body.display_name, body.new_password, body.current_password, body.keep_personal_tokens
    )
    session.commit()
    return UserOut.model_validate(user)


@router.get("/me/tokens", response_model=list[TokenOut], tags=["me"], operation_id="list_tokens")
def list_tokens(user: CurrentUser, session: SessionDep, include_sessions: bool = False) -> list[TokenOut]:
    """Your personal API tokens (never their secrets)."""
    return [_token_out(t) for t in repo.list_tokens(session, user, include_sessions=include_sessions)]


@router.post(
    "/me/tokens",
    response_model=TokenCreated,
    status_code=status.HTTP_201_CREATED,
    tags=["me"],
    operation_id="create_token",
)
def create_token(body: TokenCreate, user: CurrentUser, session: SessionDep) -> TokenOut:
    """Create a personal API token. The secret is in this response only."""
    token, secret = service.create_token(session, user, body.name, body.expires_in_days)
    session.commit()
    return _token_out(token, secret)


@router.delete(
    "/me/tokens/{token_id:integer}", status_code=status.HTTP_204_NO_CONTENT, tags=["me"], operation_id="revoke_token"
)
def revoke_token(token_id: ObjectId, user: CurrentUser, session: SessionDep) -> Response:
    service.revoke_token(session, user, token_id)
    session.commit()
    return Response(status_code=status.HTTP_204_NO_CONTENT)


# ----------------------------------------------------------------------------- admin: users


@router.get("/users", response_model=list[UserOut], tags=["users"], operation_id="list_users")
def list_users(admin: AdminUser, session: SessionDep) -> list[UserOut]:
    return [UserOut.model_validate(u) for u in repo.list_users(session)]


@router.post(
    "/users", response_model=UserOut, status_code=status.HTTP_201_CREATED, tags=["users"], operation_id="create_user"
)
def create_user(body: UserCreate, admin: AdminUser, session: SessionDep) -> UserOut:
    user = service.create_user(session, body)
    session.commit()
    return UserOut.model_validate(user)


@router.get("/users/{user_id:integer}", response_model=UserOut, tags=["users"], operation_id="get_user")
def get_user(user_id: ObjectId, admin: AdminUser, session: SessionDep) -> UserOut:
    return UserOut.model_validate(service.get_user(session, user_id))


@router.patch("/users/{user_id:integer}", response_model=UserOut, tags=["users"], operation_id="update_user")
def update_user(
    user_id: ObjectId, body: UserUpdate, admin: AdminUser, session: SessionDep, request: Request
) -> UserOut:
    """Change a user. A new password ends every session and personal token of that user and
    clears the login delays of that e-mail on every address."""
    user = service.update_user(session, admin, user_id, body)
    session.commit()
    if body.password is not None:
        login_throttle(request).clear_account(user.email)
    return UserOut.model_validate(user)


# ----------------------------------------------------------------------------- sharing


@router.post(
    "/shares",
    response_model=ShareOut,
    status_code=status.HTTP_201_CREATED,
    tags=["sharing"],
    operation_id="create_share",
)
def create_share(body: ShareCreate, user: CurrentUser, session: SessionDep) -> ShareOut:
    """Share one of your objects with someone by e-mail (view or edit); sharing again updates
    the permission. If no account has that e-mail yet, the share waits for the account made
    with it; the answer is the same either way (it does not tell whether the address has an
    account)."""
    out = service.share(session, user, body)
    session.commit()
    return out


@router.get("/shares", response_model=list[ShareOut], tags=["sharing"], operation_id="list_shares")
def list_shares(
    object_type: ObjectType, object_id: Annotated[int, Query(ge=1, le=MAX_ID)], user: CurrentUser, session: SessionDep
) -> list[ShareOut]:
    """Who one of your objects is shared with (by e-mail, including addresses without an account yet)."""
    return service.list_shares(session, user, object_type, object_id)


@router.delete(
    "/shares/{share_id:integer}", status_code=status.HTTP_204_NO_CONTENT, tags=["sharing"], operation_id="delete_share"
)
def delete_share(share_id: ObjectId, user: CurrentUser, session: SessionDep) -> Response:
    service.delete_share(session, user, share_id)
    session.commit()
    return Response(status_code=status.HTTP_204_NO_CONTENT)
