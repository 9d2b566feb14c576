"""Domain errors raised by services (no web imports). The API maps them to HTTP:
:class:`NotFound` 404, :class:`PermissionDenied` 403, :class:`Conflict` 409,
:class:`InvalidInput` 422 (with field paths), :class:`TooLarge` 413, :class:`LoginLocked` 429,
:class:`AuthenticationFailed` 401, :class:`StorageUnavailable` 507 (folder full) or 503 (folder
not writable)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any


class DomainError(Exception):
    """Base of the errors a service raises for a client's mistake (never a 500)."""

    def __init__(self, message: str) -> None:
        super().__init__(message)
        self.message = message


class NotFound(DomainError):
    """Something the caller named does not exist (404): ``NotFound("campaign", 5)`` says
    "campaign 5 not found"; ``message`` gives the whole sentence instead."""

    def __init__(self, what: str, key: Any = None, *, message: str | None = None) -> None:
        self.what, self.key = what, key
        super().__init__(message or (f"{what} {key} not found" if key is not None else f"{what} not found"))


class PermissionDenied(DomainError):
    pass


class Conflict(DomainError):
    pass


class TooLarge(DomainError):
    pass


class AuthenticationFailed(DomainError):
    pass


class TooManyRequests(DomainError):
    """Come back later (429 with ``Retry-After``)."""

    def __init__(self, message: str, retry_after_s: int) -> None:
        super().__init__(message)
        self.retry_after_s = retry_after_s


class StorageUnavailable(DomainError):
    """A folder the request must write to cannot take a write: full (``full``: 507) or
    read-only, not writable or missing (503). The message names the folder and the cause."""

    def __init__(self, message: str, *, full: bool) -> None:
        super().__init__(message)
        self.full = full


class LoginLocked(TooManyRequests):
    """Too many failed logins from this client for this account."""


@dataclass(frozen=True)
class FieldError:
    """One problem with one field: ``loc`` is the path (e.g. ``("spec", "phases", 1, "duration")``)."""

    loc: tuple[str | int, ...]
    msg: str
    type: str = "value_error"

    @property
    def field(self) -> str:
        return ".".join(str(p) for p in self.loc)

    def as_dict(self, prefix: Sequence[str | int] = ()) -> dict[str, Any]:
        loc = [*prefix, *self.loc]
        return {
            "loc": loc,
            "field": ".".join(str(p) for p in loc if p not in ("body", "query", "path")),
            "msg": self.msg,
            "type": self.type,
        }


class InvalidInput(DomainError):
    """Field-level validation errors (422)."""

    def __init__(self, errors: Iterable[FieldError], prefix: Sequence[str | int] = ("body",)) -> None:
        self.errors = list(errors)
        self.prefix = tuple(prefix)
        super().__init__("; ".join(f"{e.field}: {e.msg}" for e in self.errors) or "invalid input")

    @classmethod
    def one(cls, field: str, reason: str, prefix: Sequence[str | int] = ("body",)) -> InvalidInput:
        return cls([FieldError(tuple(_split_path(field)), reason)], prefix)

    def detail(self) -> list[dict[str, Any]]:
        return [e.as_dict(self.prefix) for e in self.errors]


def _split_path(path: str) -> list[str | int]:
    return [int(p) if p.isdigit() else p for p in path.split(".") if p]


def merge_message_path(loc: Sequence[str | int], msg: str) -> tuple[list[str | int], str]:
    """Cross-field validators in the science schemas raise ``ValueError("path.to.field: reason")``
    with the path from the schema's root; put that path into ``loc`` (where its first part
    already occurs in ``loc``, or appended)."""
    msg = str(msg).removeprefix("Value error, ")
    head, sep, rest = msg.partition(": ")
    parts = head.split(".")
    if not (sep and head and " " not in head and all(p.isidentifier() or p.isdigit() for p in parts)):
        return list(loc), msg
    path = _split_path(head)
    loc = list(loc)
    cut = loc.index(path[0]) if path[0] in loc else len(loc)
    return loc[:cut] + path, rest


def field_errors_from_pydantic(err: Any, base: Sequence[str | int] = ()) -> list[FieldError]:
    """Convert a pydantic ``ValidationError`` into :class:`FieldError` s (paths under ``base``)."""
    out: list[FieldError] = []
    for e in err.errors(include_url=False):
        loc, msg = merge_message_path([*base, *e.get("loc", ())], str(e.get("msg", "invalid")))
        out.append(FieldError(tuple(loc), msg, str(e.get("type", "value_error"))))
    return out
