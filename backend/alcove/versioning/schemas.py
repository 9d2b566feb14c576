"""What every versioned definition (task, oracle, surrogate config) shows and how the
editors' validation answers, shared by the definition domains' routers."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from alcove.errors import FieldError
from alcove.names import Name


class _In(BaseModel):
    # strict: "1" is not a number and 1 or "true" not a boolean, as the schema says (JSON numbers still fill floats)
    model_config = ConfigDict(extra="forbid", strict=True)


class DefinitionMeta(BaseModel):
    """What every versioned definition (task, oracle, surrogate config) shows."""

    id: int
    name: str
    description: str
    owner_id: int
    owner: str | None = Field(None, description="owner's e-mail")
    preset_key: str | None
    version: int = Field(description="latest version number")
    version_locked: bool = Field(
        description="the latest version is used by a campaign: the next edit of the content creates a new version"
    )
    can_edit: bool
    archived: bool
    created_at: datetime
    updated_at: datetime


class VersionMeta(BaseModel):
    version: int
    spec_hash: str
    note: str
    locked: bool
    created_at: datetime


class FieldErrorOut(BaseModel):
    loc: list[str | int]
    field: str
    msg: str
    type: str

    @classmethod
    def of(cls, e: FieldError) -> FieldErrorOut:
        return cls(**e.as_dict())


class CheckReport(BaseModel):
    valid: bool
    errors: list[FieldErrorOut] = Field(description="field-level problems (paths relative to the request body)")
    normalized: dict[str, Any] | None = Field(
        None, description="the validated content with defaults filled in, when valid"
    )


class CopyPreset(_In):
    name: Name | None = Field(None, description="name of the copy (default: the preset's)")
