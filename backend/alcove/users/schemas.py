"""Request and response bodies of the user, token and sharing routes."""

from __future__ import annotations

from datetime import datetime
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from alcove.ids import MAX_ID
from alcove.names import Name

EMAIL_PATTERN = r"^[^@\s]+@[^@\s]+$"

ObjectType = Literal["task", "oracle", "surrogate_config", "campaign"]


class _In(BaseModel):
    # strict: "1" is not a number and 1 or "true" not a boolean, as the schema says (JSON numbers still fill floats)
    model_config = ConfigDict(extra="forbid", strict=True)


class LoginIn(_In):
    email: str = Field(min_length=3, max_length=320, description="account e-mail (case-insensitive)")
    password: str = Field(min_length=1, max_length=1024)


class LoginOut(BaseModel):
    access_token: str = Field(description="bearer token: send it as `Authorization: Bearer <token>`")
    token_type: Literal["bearer"] = "bearer"
    expires_at: datetime


class UserOut(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    id: int
    email: str
    display_name: str
    role: Literal["admin", "member"]
    is_active: bool
    created_at: datetime
    last_login_at: datetime | None = None


class UserCreate(_In):
    email: str = Field(min_length=3, max_length=320, pattern=EMAIL_PATTERN)
    password: str = Field(min_length=8, max_length=1024)
    display_name: str = Field("", max_length=200)
    role: Literal["admin", "member"] = "member"

    @field_validator("email")
    @classmethod
    def _lower(cls, v: str) -> str:
        return v.strip().lower()


class UserUpdate(_In):
    display_name: str | None = Field(None, max_length=200)
    role: Literal["admin", "member"] | None = None
    is_active: bool | None = None
    password: str | None = Field(
        None,
        min_length=8,
        max_length=1024,
        description="set a new password: ends every session and personal token of the user"
        " and clears the login delays of this e-mail",
    )


class MeUpdate(_In):
    display_name: str | None = Field(None, max_length=200)
    new_password: str | None = Field(None, min_length=8, max_length=1024)
    current_password: str | None = Field(None, max_length=1024, description="required with new_password")
    keep_personal_tokens: bool = Field(
        False,
        description=(
            "with new_password: keep your personal API tokens working (every session token ends"
            " anyway); by default a new password ends them all"
        ),
    )


class TokenCreate(_In):
    name: Name = Field(description="what the token is for, e.g. 'notebook'")
    expires_in_days: int | None = Field(None, ge=1, le=3650, description="null = does not expire")


class TokenOut(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    id: int
    name: str
    kind: Literal["session", "personal"]
    token_prefix: str = Field(description="first characters of the token, to recognise it")
    created_at: datetime
    last_used_at: datetime | None
    expires_at: datetime | None
    revoked_at: datetime | None
    revoked: bool


class TokenCreated(TokenOut):
    token: str = Field(description="the secret: shown once, only its hash is stored")


class ShareCreate(_In):
    object_type: ObjectType
    object_id: int = Field(ge=1, le=MAX_ID)
    email: str = Field(
        min_length=3,
        max_length=320,
        pattern=EMAIL_PATTERN,
        description="who to share with: an account's e-mail, or an address that will get it when its account is made",
    )
    permission: Literal["view", "edit"] = "view"

    @field_validator("email")
    @classmethod
    def _lower(cls, v: str) -> str:
        return v.strip().lower()


class ShareOut(BaseModel):
    id: int
    object_type: ObjectType
    object_id: int
    email: str = Field(description="the grantee's e-mail (whether or not an account has it yet)")
    permission: Literal["view", "edit"]
    created_at: datetime


#: the largest value a job limit takes (a NULL limit is no limit)
MAX_JOB_LIMIT = 1_000_000_000


def _limit(what: str) -> Any:
    return Field(None, ge=1, le=MAX_JOB_LIMIT, description=f"{what}; null: no limit")


class JobLimitsValues(BaseModel):
    """How much work one user may ask of the shared workers."""

    max_running_campaigns: int | None = _limit(
        "campaigns of the user running at once; a campaign started (or resumed, or retried) beyond it waits "
        "in status 'queued' with a wait_reason and starts when one of the user's running campaigns ends"
    )
    max_preliminary_samples: int | None = _limit("largest preliminary.samples of a campaign")
    max_ocp_intervals: int | None = _limit(
        "most DMOCC intervals per phase: a campaign's settings.ocp_intervals (or its task's, when it sets none) "
        "and a task preview's intervals"
    )
    max_ensemble_size: int | None = _limit("largest ensemble_size of a surrogate config")
    max_hidden_layers: int | None = _limit("most hidden layers of a surrogate's net")
    max_layer_width: int | None = _limit("most units in one hidden layer of a surrogate's net")
    max_epochs: int | None = _limit("largest max_epochs (and warm_max_epochs) of a surrogate config")


class JobLimitsUpdate(JobLimitsValues):
    """The limits to change: a field left out keeps its value, null lifts the limit."""

    # strict: "1" is not a number, as the schema says
    model_config = ConfigDict(extra="forbid", strict=True)


class JobLimitsOut(JobLimitsValues):
    source: Literal["defaults", "own", "none"] = Field(
        description="where the limits come from: 'defaults' (the members' defaults), 'own' (set for this user by an "
        "administrator), 'none' (an administrator without limits of their own: no limit)"
    )
