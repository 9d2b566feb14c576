"""Shared path/query parameter types (bounded so no value can overflow a database integer)."""

from __future__ import annotations

from typing import Annotated

from fastapi import Path, Query

MAX_ID = 2**31 - 1

ObjectId = Annotated[int, Path(ge=1, le=MAX_ID, description="object id")]
VersionNumber = Annotated[int, Path(ge=1, le=MAX_ID, description="version number (1, 2, ...)")]
IterationIndex = Annotated[int, Path(ge=0, le=MAX_ID, description="iteration index k (0 = preliminary data)")]
Limit = Annotated[int, Query(ge=1, le=1000, description="page size")]
Offset = Annotated[int, Query(ge=0, le=MAX_ID, description="rows to skip")]
