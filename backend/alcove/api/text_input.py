"""No NUL character in any text a request carries: query and path parameters, JSON bodies
(every string and object key, however deep, free-form ``params`` included) and form fields.

PostgreSQL cannot store U+0000 in text or JSON, so such a value used to fail at the database
with "a value is out of range for the database" and no field. One dependency of every API
route (:func:`reject_nul_characters`, added in :func:`alcove.app.create_app`) answers 422
naming each offending field instead, before the route runs (and before authentication: an
unauthenticated request with a NUL is refused with 422 rather than 401, which tells nothing
either way). It costs a substring search of the body (already read by FastAPI); the JSON is
parsed again only when ``\\u0000`` occurs in it.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any

from fastapi import Request
from fastapi.exceptions import RequestValidationError

NUL = "\x00"
MESSAGE = "contains a NUL character (U+0000), which cannot be stored: remove it"


def _error(loc: tuple[str | int, ...], what: str = "") -> dict[str, Any]:
    return {"type": "string_nul", "loc": loc, "msg": f"{what}{MESSAGE}", "input": None}


def nul_paths(value: Any, loc: tuple[str | int, ...] = ()) -> Iterator[tuple[tuple[str | int, ...], str]]:
    """(location, what) of every string in a JSON value that holds a NUL (keys too)."""
    if isinstance(value, str):
        if NUL in value:
            yield loc, ""
    elif isinstance(value, dict):
        for key, item in value.items():
            if NUL in key:
                yield (*loc, key.replace(NUL, "\\u0000")), "the name "
            yield from nul_paths(item, (*loc, key))
    elif isinstance(value, list):
        for i, item in enumerate(value):
            yield from nul_paths(item, (*loc, i))


async def reject_nul_characters(request: Request) -> None:
    """422 for every query/path parameter, JSON string or form field holding a NUL character."""
    errors = [_error(("query", name)) for name, value in request.query_params.multi_items() if NUL in name + value]
    errors += [_error(("path", name)) for name, value in request.path_params.items() if NUL in str(value)]
    content_type = request.headers.get("content-type", "")
    if content_type.startswith(("multipart/form-data", "application/x-www-form-urlencoded")):
        form = await request.form()
        errors += [
            _error(("body", name))
            for name, value in form.multi_items()
            if isinstance(value, str) and NUL in name + value
        ]
    elif request.method in ("POST", "PUT", "PATCH"):
        body = await request.body()
        if b"\\u0000" in body:
            try:
                data = json.loads(body)
            except ValueError:  # not JSON: the route's own parsing says so
                data = None
            errors += [_error(("body", *loc), what) for loc, what in nul_paths(data)]
    if errors:
        raise RequestValidationError(errors)
