"""Error handlers and request-size limits.

Every client mistake gets a 4xx with a readable body, never a 500:

* 422 ``{"detail": [{"loc": [...], "field": "spec.phases.1.duration", "msg": ..., "type": ...}]}``
  for request validation (FastAPI) and for the services' :class:`~alcove.errors.InvalidInput`;
* 404 / 403 / 409 / 413 / 429 / 401 ``{"detail": "..."}`` for the other domain errors;
* 409 for integrity violations (e.g. a duplicate name) and for edits of immutable rows;
* 507 (folder full) or 503 (read-only or not writable) ``{"detail": "..."}`` naming the folder
  when a download must store a file it cannot (:class:`~alcove.errors.StorageUnavailable`).
"""

from __future__ import annotations

import logging
from collections.abc import Awaitable, Callable
from typing import Any

from fastapi import FastAPI, Request
from fastapi.encoders import jsonable_encoder
from fastapi.exception_handlers import http_exception_handler
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from pydantic import BaseModel, Field, ValidationError
from sqlalchemy import exc as sa_exc
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.formparsers import MultiPartException
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from alcove.api.route_table import allowed_methods
from alcove.errors import (
    AuthenticationFailed,
    Conflict,
    InvalidInput,
    NotFound,
    PermissionDenied,
    StorageUnavailable,
    TooLarge,
    TooManyRequests,
    field_errors_from_pydantic,
    merge_message_path,
)
from alcove.models import ImmutableRowError

log = logging.getLogger(__name__)

#: Largest JSON request body (a command oracle's template text can be a few MB).
MAX_JSON_BODY_BYTES = 8 * 1024 * 1024
#: Largest upload (a preliminary data set CSV).
MAX_UPLOAD_BODY_BYTES = 64 * 1024 * 1024
UPLOAD_PATH_SUFFIXES = ("/uploads", "/preliminary-datasets")


class ErrorOut(BaseModel):
    detail: str


class FieldErrorItem(BaseModel):
    loc: list[str | int] = Field(description="where: e.g. ['body', 'spec', 'phases', 1, 'duration']")
    field: str = Field(description="the same as a dotted path without the location, e.g. 'spec.phases.1.duration'")
    msg: str = Field(description="the reason")
    type: str


class ValidationErrorOut(BaseModel):
    detail: list[FieldErrorItem]


#: Documented on every authenticated route (status codes the error handlers produce).
COMMON_RESPONSES: dict[int | str, dict[str, Any]] = {
    401: {"model": ErrorOut, "description": "not authenticated (missing, invalid, expired or revoked token)"},
    403: {
        "model": ErrorOut,
        "description": "not allowed (admin-only route, or an object shared with you for viewing only)",
    },
    404: {"model": ErrorOut, "description": "no such object, or not visible to you"},
    409: {
        "model": ErrorOut,
        "description": "conflicts with the current state (e.g. a campaign transition, a duplicate)",
    },
    413: {"model": ErrorOut, "description": "request body too large"},
    422: {"model": ValidationErrorOut, "description": "invalid input: field paths and reasons"},
    503: {"model": ErrorOut, "description": "database busy or unavailable: retry"},
}


def _validation_detail(errors: list[Any]) -> list[dict[str, Any]]:
    out = []
    for e in errors:
        if e.get("type") == "json_invalid" and len(e.get("loc", ())) == 2:  # FastAPI: ("body", character position)
            reason = (e.get("ctx") or {}).get("error", "invalid")
            e = {
                **e,
                "loc": ("body",),
                "msg": f"the request body is not valid JSON: {reason} (character {e['loc'][1]})",
            }
        loc, msg = merge_message_path(list(e.get("loc", ())), str(e.get("msg", "invalid")))
        # a key holding a NUL is named with the NUL written out: the answer states no NUL either
        loc = [p.replace("\x00", "\\u0000") if isinstance(p, str) else p for p in loc]
        item = {
            "loc": loc,
            "field": ".".join(str(p) for p in loc if p not in ("body", "query", "path", "header")),
            "msg": msg,
            "type": e.get("type", "value_error"),
        }
        out.append(item)
    detail: list[dict[str, Any]] = jsonable_encoder(out)  # typed Any; a list of dicts in, a list of dicts out
    return detail


def _unparseable_body(err: StarletteHTTPException) -> JSONResponse | None:
    """FastAPI answers 400 "There was an error parsing the body" when a JSON body is not
    even text (invalid UTF-8); a body that is text but not JSON is already a 422
    ``json_invalid``. Starlette answers 400 "Invalid multipart data." when an upload's
    multipart body is malformed (its ``MultiPartException`` is the context of the 400). All are
    invalid input: 422 with the reason, like every other."""
    if err.status_code != 400:
        return None
    if isinstance(err.__context__, MultiPartException):
        item = {
            "loc": ["body"],
            "field": "",
            "msg": f"the request body is not valid multipart/form-data ({err.__context__.message})",
            "type": "multipart_invalid",
        }
        return JSONResponse({"detail": [item]}, status_code=422)
    cause = err.__cause__
    if cause is None:
        return None
    reason = "is not UTF-8 text" if isinstance(cause, UnicodeDecodeError) else f"cannot be parsed ({cause})"
    item = {"loc": ["body"], "field": "", "msg": f"the request body {reason}", "type": "json_invalid"}
    return JSONResponse({"detail": [item]}, status_code=422)


def install_error_handlers(app: FastAPI) -> None:
    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, err: StarletteHTTPException) -> Any:
        unparseable = _unparseable_body(err)
        if unparseable is not None:
            return unparseable
        if err.status_code == 405:
            # Starlette names only the first matching route's methods; a path has one route per method
            allow = ", ".join(allowed_methods(app, request.url.path))
            err = StarletteHTTPException(405, err.detail, headers={**(err.headers or {}), "Allow": allow})
        return await http_exception_handler(request, err)

    @app.exception_handler(RequestValidationError)
    async def _request_validation(request: Request, err: RequestValidationError) -> JSONResponse:
        return JSONResponse({"detail": _validation_detail(list(err.errors()))}, status_code=422)

    @app.exception_handler(InvalidInput)
    async def _invalid(request: Request, err: InvalidInput) -> JSONResponse:
        return JSONResponse({"detail": jsonable_encoder(err.detail())}, status_code=422)

    @app.exception_handler(ValidationError)
    async def _pydantic(request: Request, err: ValidationError) -> JSONResponse:
        # a pydantic model validated inside a service (the request body itself was fine)
        return JSONResponse(
            {"detail": jsonable_encoder([e.as_dict(("body",)) for e in field_errors_from_pydantic(err)])},
            status_code=422,
        )

    def simple(
        status: int, headers: dict[str, str] | None = None
    ) -> Callable[[Request, Exception], Awaitable[JSONResponse]]:
        async def handler(request: Request, err: Exception) -> JSONResponse:
            return JSONResponse({"detail": getattr(err, "message", str(err))}, status_code=status, headers=headers)

        return handler

    app.add_exception_handler(NotFound, simple(404))
    app.add_exception_handler(PermissionDenied, simple(403))
    app.add_exception_handler(Conflict, simple(409))
    app.add_exception_handler(ImmutableRowError, simple(409))
    app.add_exception_handler(TooLarge, simple(413))
    app.add_exception_handler(AuthenticationFailed, simple(401, {"WWW-Authenticate": "Bearer"}))

    @app.exception_handler(StorageUnavailable)
    async def _storage(request: Request, err: StorageUnavailable) -> JSONResponse:
        log.warning("storage unavailable: %s", err.message)
        return JSONResponse({"detail": err.message}, status_code=507 if err.full else 503)

    @app.exception_handler(TooManyRequests)
    async def _too_many(request: Request, err: TooManyRequests) -> JSONResponse:
        return JSONResponse({"detail": err.message}, status_code=429, headers={"Retry-After": str(err.retry_after_s)})

    @app.exception_handler(ArithmeticError)
    async def _arithmetic(request: Request, err: ArithmeticError) -> JSONResponse:
        # e.g. a validator squaring a huge number someone entered: bad input, not a server fault
        log.info("arithmetic error answered 422: %s", err)
        return JSONResponse(
            {
                "detail": [
                    {
                        "loc": ["body"],
                        "field": "",
                        "msg": f"a number is out of range ({err})",
                        "type": "value_error.overflow",
                    }
                ]
            },
            status_code=422,
        )

    @app.exception_handler(sa_exc.DataError)
    async def _data_error(request: Request, err: sa_exc.DataError) -> JSONResponse:
        log.info("data error answered 422: %s", err.orig)
        return JSONResponse(
            {
                "detail": [
                    {"loc": [], "field": "", "msg": "a value is out of range for the database", "type": "value_error"}
                ]
            },
            status_code=422,
        )

    @app.exception_handler(sa_exc.IntegrityError)
    async def _integrity(request: Request, err: sa_exc.IntegrityError) -> JSONResponse:
        log.info("integrity error answered 409: %s", err.orig)
        return JSONResponse({"detail": "conflicts with existing data (duplicate or still referenced)"}, status_code=409)


class BodySizeLimit:
    """Pure ASGI middleware: 413 when a request body exceeds its limit (declared or streamed)."""

    def __init__(
        self, app: ASGIApp, max_json: int = MAX_JSON_BODY_BYTES, max_upload: int = MAX_UPLOAD_BODY_BYTES
    ) -> None:
        self.app = app
        self.max_json = max_json
        self.max_upload = max_upload

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        path: str = scope.get("path", "")
        limit = self.max_upload if path.endswith(UPLOAD_PATH_SUFFIXES) else self.max_json
        for name, value in scope.get("headers", ()):
            if name == b"content-length":
                try:
                    declared = int(value)
                except ValueError:
                    declared = 0
                if declared > limit:
                    await _too_large(send, limit)
                    return
        received = 0
        started = False

        async def limited_receive() -> Message:
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > limit:
                    raise _BodyTooLarge
            return message

        async def tracking_send(message: Message) -> None:
            nonlocal started
            if message["type"] == "http.response.start":
                started = True
            await send(message)

        try:
            await self.app(scope, limited_receive, tracking_send)
        except _BodyTooLarge:
            if not started:
                await _too_large(send, limit)


class _BodyTooLarge(Exception):
    pass


async def _too_large(send: Send, limit: int) -> None:
    body = JSONResponse({"detail": f"request body larger than {limit} bytes"}, status_code=413).body
    await send(
        {
            "type": "http.response.start",
            "status": 413,
            "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())],
        }
    )
    await send({"type": "http.response.body", "body": body})
