"""Shared path/query parameter types (bounded so no value can overflow a database integer)."""

from __future__ import annotations

from typing import Annotated

from fastapi import Path, Query
from starlette.convertors import Convertor, register_url_convertor

from alcove.ids import MAX_ID


class SignedIntegerConvertor(Convertor[int]):
    """Path segment ``{name:integer}``: an optionally signed whole number. Integer path
    parameters are declared with it, so that ``/tasks/presets`` does not match
    ``/tasks/{task_id:integer}`` (a PUT there is a 405 listing the methods of
    ``/tasks/presets``, not a 422 on ``task_id``), while ``/tasks/-1`` still reaches the route
    and gets the 422 of the parameter's bounds rather than a 404."""

    regex = "-?[0-9]+"

    def convert(self, value: str) -> int:
        return int(value)

    def to_string(self, value: int) -> str:
        return str(int(value))


register_url_convertor("integer", SignedIntegerConvertor())  # before any router compiles its paths

ObjectId = Annotated[int, Path(ge=1, le=MAX_ID, description="object id")]
VersionNumber = Annotated[int, Path(ge=1, le=MAX_ID, description="version number (1, 2, ...)")]
IterationIndex = Annotated[int, Path(ge=0, le=MAX_ID, description="iteration index k (0 = preliminary data)")]
Limit = Annotated[int, Query(ge=1, le=1000, description="page size")]
Offset = Annotated[int, Query(ge=0, le=MAX_ID, description="rows to skip")]
