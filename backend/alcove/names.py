"""The name a user gives an object (task, oracle, campaign, surrogate configuration, token).

At most 200 characters as sent, at least one of them not whitespace: a name made only of
spaces is refused (it would list as an empty, unclickable row). Leading and trailing
whitespace is dropped, so " a " is stored as "a". The schema states exactly this
(``maxLength`` 200 and the pattern ``\\S``: some character that is not whitespace).
"""

from __future__ import annotations

from typing import Annotated

from pydantic import AfterValidator, StringConstraints, WithJsonSchema

MAX_NAME_LENGTH = 200


def _trimmed(value: str) -> str:
    trimmed = value.strip()
    if not trimmed:
        raise ValueError("is blank: a name needs a character that is not whitespace")
    return trimmed


Name = Annotated[
    str,
    StringConstraints(max_length=MAX_NAME_LENGTH),
    AfterValidator(_trimmed),
    WithJsonSchema({"type": "string", "maxLength": MAX_NAME_LENGTH, "pattern": r"\S"}),
]
