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

from fastapi import FastAPI, Request
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
            name = key.replace(NUL, "\\u0000")  # the answer names the key without holding a NUL itself
            if NUL in key:
                yield (*loc, name), "the name "
            yield from nul_paths(item, (*loc, name))
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


#: what the OpenAPI document says of every text a request may carry: no NUL character
NUL_FREE = r"^[^\u0000]*$"
_SUBSCHEMA_LISTS = ("anyOf", "oneOf", "allOf", "prefixItems")
_SUBSCHEMA = ("items", "additionalProperties", "not")


def _forbid_nul(schema: Any) -> None:
    """:data:`NUL_FREE` on every text of a JSON schema (in place): a string's value (beside a
    pattern of its own, through ``allOf``) and the names of an object's free-form keys. Binary
    uploads, enumerations and constants are left alone."""
    if not isinstance(schema, dict):
        return
    binary = schema.get("format") == "binary" or "contentMediaType" in schema
    if schema.get("type") == "string" and not binary and not {"enum", "const"} & set(schema):
        pattern = schema.get("pattern")
        if pattern is None:
            schema["pattern"] = NUL_FREE
        elif pattern != NUL_FREE and {"pattern": NUL_FREE} not in schema.get("allOf", []):
            schema["allOf"] = [*schema.get("allOf", []), {"pattern": NUL_FREE}]
    if schema.get("additionalProperties", False) is not False:
        schema.setdefault("propertyNames", {"pattern": NUL_FREE})
    for item in (schema.get("properties") or {}).values():
        _forbid_nul(item)
    for key in _SUBSCHEMA:
        _forbid_nul(schema.get(key))
    for key in _SUBSCHEMA_LISTS:
        for item in schema.get(key) or []:
            _forbid_nul(item)


def state_the_nul_rule(openapi: dict[str, Any]) -> dict[str, Any]:
    """The OpenAPI document with the rule :func:`reject_nul_characters` applies written into it
    (in place): the schemas, and every operation's parameters and request bodies."""
    for schema in (openapi.get("components") or {}).get("schemas", {}).values():
        _forbid_nul(schema)
    for path_item in (openapi.get("paths") or {}).values():
        for operation in path_item.values():
            if not isinstance(operation, dict):
                continue
            for parameter in operation.get("parameters") or []:
                _forbid_nul(parameter.get("schema"))
            for media in ((operation.get("requestBody") or {}).get("content") or {}).values():
                _forbid_nul(media.get("schema"))
    return openapi


def install_nul_rule(app: FastAPI) -> None:
    """Make ``app``'s OpenAPI document state the NUL rule (:func:`state_the_nul_rule`)."""
    generate = app.openapi

    def openapi() -> dict[str, Any]:
        if app.openapi_schema is None:
            app.openapi_schema = state_the_nul_rule(generate())
        return app.openapi_schema

    app.openapi = openapi  # type: ignore[method-assign]
