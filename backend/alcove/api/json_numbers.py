"""Integer-valued JSON numbers are integers, as JSON Schema reads ``"type": "integer"``.

The request models are strict (``"1"`` is not a number, ``1`` is not a boolean), and pydantic's
strict integers refuse a float. JSON Schema, which the OpenAPI document states the API in, counts
``2.0`` and ``1e3`` as integers, and clients that hold every number as a double (JavaScript)
send them so. :class:`WholeNumbers` rewrites such numbers of a JSON request body to integer
literals before the route reads it (a body without a fraction or an exponent is passed on
untouched; one that is not JSON too, for the route to refuse). Floats stay floats where a
float is expected: a strict float accepts an integer.
"""

from __future__ import annotations

import json
import re
from decimal import Decimal, InvalidOperation
from typing import Any

from starlette.types import ASGIApp, Message, Receive, Scope, Send

#: integers beyond this stay as written (no integer field takes them; a float field still does)
LARGEST = 2**64
#: a digit followed by a fraction or an exponent somewhere in the body
MAYBE = re.compile(rb"\d[.eE]")


def _number(text: str) -> int | float:
    try:
        exact = Decimal(text)
    except InvalidOperation:  # pragma: no cover - json hands only number literals here
        return float(text)
    if exact.is_finite() and exact == exact.to_integral_value() and abs(exact) < LARGEST:
        return int(exact)
    return float(text)


def whole_numbers(body: bytes) -> bytes:
    """``body`` with every integer-valued number written as an integer (unchanged if not JSON)."""
    if not MAYBE.search(body):
        return body
    try:
        data: Any = json.loads(body, parse_float=_number)
    except ValueError:
        return body
    return json.dumps(data, separators=(",", ":")).encode()


class WholeNumbers:
    """ASGI middleware: :func:`whole_numbers` on JSON request bodies."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or scope.get("method") not in ("POST", "PUT", "PATCH"):
            await self.app(scope, receive, send)
            return
        content_type = dict(scope.get("headers") or []).get(b"content-type", b"")
        if not content_type.split(b";")[0].strip().endswith(b"json"):
            await self.app(scope, receive, send)
            return
        chunks = []
        while True:
            message = await receive()
            if message["type"] != "http.request":  # the client went away: pass that on
                await self.app(scope, _replay([message]), send)
                return
            chunks.append(message.get("body", b""))
            if not message.get("more_body", False):
                break
        body = whole_numbers(b"".join(chunks))
        headers = [(k, v) for k, v in scope.get("headers") or [] if k != b"content-length"]
        headers.append((b"content-length", str(len(body)).encode()))
        await self.app({**scope, "headers": headers}, _replay([{"type": "http.request", "body": body}], receive), send)


def _replay(messages: list[Message], then: Receive | None = None) -> Receive:
    async def receive() -> Message:
        if messages:
            return messages.pop(0)
        if then is not None:
            return await then()
        return {"type": "http.disconnect"}

    return receive
