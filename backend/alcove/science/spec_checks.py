"""Shared validation for the user-facing specs (pydantic): physical quantities, whole numbers, errors.

* :func:`quantity` -- the constraints of a physical quantity, with its unit and its range
  stated in the description (the JSON schema is what the web form and the API docs show);
* :data:`WholeNumber` -- an integer field that refuses 2.5, ``"2"`` and ``true``; a float
  without a fractional part (2.0) is accepted, as JSON Schema's ``integer`` accepts it
  (:func:`as_whole_number` for list items);
* :func:`error_location` -- the field path and reason of a pydantic error. Cross-field checks
  raise ``ValueError("path.to.field: reason")`` with the path from the spec's root; the path
  replaces the location pydantic gives (the same rule as ``alcove.errors.merge_message_path``,
  which turns these errors into the API's field errors).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Annotated

from pydantic import BeforeValidator, Field
from pydantic.fields import FieldInfo
from pydantic_core import ErrorDetails, PydanticCustomError


def _number(value: float) -> str:
    """``value`` compactly: 0.02, 1e6, 1e-5, 1.5708."""
    text = f"{value:.6g}"
    mantissa, e, exponent = text.partition("e")
    return f"{mantissa}e{int(exponent)}" if e else mantissa


def range_text(
    unit: str, *, ge: float | None = None, gt: float | None = None, le: float | None = None, lt: float | None = None
) -> str:
    """The range of a quantity in words: ``0.02 to 0.15 m``, ``above 0, at most 60 s``, ``at least 0``."""
    unit = f" {unit}" if unit and unit != "-" else ""
    if ge is not None and le is not None:
        return f"{_number(ge)} to {_number(le)}{unit}"
    lower = f"at least {_number(ge)}" if ge is not None else f"above {_number(gt)}" if gt is not None else ""
    upper = f"at most {_number(le)}" if le is not None else f"below {_number(lt)}" if lt is not None else ""
    return ", ".join(part for part in (lower, upper) if part) + unit if lower or upper else "any finite value"


def quantity(
    description: str,
    unit: str,
    *,
    ge: float | None = None,
    gt: float | None = None,
    le: float | None = None,
    lt: float | None = None,
    why: str = "",
) -> FieldInfo:
    """Constraints and description of a physical quantity, for ``Annotated[float, quantity(...)]``.

    The description reads ``<description> [<unit>], <range>`` (and ``; <why>``); ``unit`` is
    ``"-"`` for a dimensionless number.
    """
    text = f"{description} [{unit}], {range_text(unit, ge=ge, gt=gt, le=le, lt=lt)}" + (f"; {why}" if why else "")
    # strict: a number, not "1" or true (what the schema says; an integer is still a number)
    info: FieldInfo = Field(ge=ge, gt=gt, le=le, lt=lt, allow_inf_nan=False, strict=True, description=text)
    return info


def as_whole_number(value: object) -> object:
    """The value an integer field takes, or a validation error for 2.5, ``"2"``, ``true``, inf.

    Use it as ``Annotated[int, Field(ge=..., le=...), BeforeValidator(as_whole_number)]`` for
    list items: there :data:`WholeNumber` inside another ``Annotated`` would drop the bounds
    from the JSON schema (pydantic writes them as ``ge``/``le`` instead of ``minimum``/``maximum``).
    """
    if isinstance(value, bool):
        raise PydanticCustomError("int_type", "Input should be a whole number, not true or false")
    if isinstance(value, str):
        message = "Input should be a whole number, not text ({text})"
        raise PydanticCustomError("int_type", message, {"text": repr(value)})
    if isinstance(value, float):
        if not math.isfinite(value) or not value.is_integer():
            raise PydanticCustomError("int_from_float", "Input should be a whole number, got {value}", {"value": value})
        return int(value)
    return value


#: An integer field: refuses fractional numbers, text and booleans (2.0 is taken as 2).
WholeNumber = Annotated[int, BeforeValidator(as_whole_number)]


def error_location(error: ErrorDetails, prefix: Sequence[str | int] = ()) -> tuple[str, str]:
    """(dotted field path, reason) of one pydantic error, with the path a cross-field check names.

    A message ``"path.to.field: reason"`` (a ``ValueError`` of a model validator) puts
    ``path.to.field`` in place of pydantic's location from the first part of the path on
    (or after it, if that part does not occur); ``prefix`` goes in front of the location.
    """
    loc: list[str | int] = [*prefix, *error["loc"]]
    msg = str(error["msg"]).removeprefix("Value error, ")
    head, sep, rest = msg.partition(": ")
    parts = head.split(".")
    if sep and head and " " not in head and all(p.isidentifier() or p.isdigit() for p in parts):
        path: list[str | int] = [int(p) if p.isdigit() else p for p in parts]
        cut = loc.index(path[0]) if path[0] in loc else len(loc)
        loc, msg = loc[:cut] + path, rest
    return ".".join(str(p) for p in loc), msg


__all__ = ["WholeNumber", "as_whole_number", "error_location", "quantity", "range_text"]
