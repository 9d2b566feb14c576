"""What the lifecycle's API takes: a new campaign (as the API and as the service take it), an
edit of its settings, a fork, a step to retry. The settings themselves are
:mod:`alcove.campaigns.config`."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field
from pydantic.config import JsonDict

from alcove.api.params import MAX_ID
from alcove.campaigns.config import CampaignConfig, Policies, PreliminaryConfig, RunSettings, StoppingRules
from alcove.models.base import StepName
from alcove.names import Name


class _In(BaseModel):
    # strict: "1" is not a number and 1 or "true" not a boolean, as the schema says (JSON numbers still fill floats)
    model_config = ConfigDict(extra="forbid", strict=True)


class CampaignCreate(CampaignConfig):
    name: Name
    description: str = ""
    task_version_id: int
    oracle_version_id: int
    surrogate_config_version_id: int
    seed: int = Field(0, ge=0, lt=2**62)


class CampaignConfigUpdate(_In):
    """Edit of a campaign's settings: each given part replaces the current one and a new
    config version is recorded; iterations created afterwards use it."""

    surrogate_config_version_id: int | None = None
    stopping: StoppingRules | None = None
    policies: Policies | None = None
    settings: RunSettings | None = None
    note: str = ""


class ForkRequest(_In):
    """A new campaign continuing from ``iteration`` of the source (its pool version and
    model at that iteration), with changed settings."""

    iteration: int = Field(ge=0)
    name: Name | None = None
    surrogate_config_version_id: int | None = None
    oracle_version_id: int | None = None
    task_version_id: int | None = None
    seed: int | None = Field(None, ge=0, lt=2**62)
    stopping: StoppingRules | None = None
    policies: Policies | None = None
    settings: RunSettings | None = None
    start: bool = False


class CampaignCreateIn(_In):
    """A campaign of one of your (or shared) tasks and oracles. Versions default to the latest;
    the surrogate config defaults to the paper's."""

    name: Name
    description: str = Field("", max_length=20_000)
    task_id: int = Field(ge=1, le=MAX_ID)
    task_version: int | None = Field(None, ge=1, le=MAX_ID)
    oracle_id: int = Field(ge=1, le=MAX_ID)
    oracle_version: int | None = Field(None, ge=1, le=MAX_ID)
    surrogate_config_id: int | None = Field(None, ge=1, le=MAX_ID)
    surrogate_config_version: int | None = Field(None, ge=1, le=MAX_ID)
    seed: int = Field(0, ge=0, lt=2**62)
    preliminary: PreliminaryConfig = Field(default_factory=PreliminaryConfig)
    stopping: StoppingRules = Field(default_factory=StoppingRules)
    policies: Policies = Field(default_factory=Policies)
    settings: RunSettings = Field(default_factory=RunSettings)
    start: bool = Field(False, description="start right away")


_GIVEN: JsonDict = {"not": {"type": "null"}}  # a JSON value that is given and not null


class RetryIn(_In):
    """The failed step to run again: ``iteration`` and ``step`` together (as the schema states), or neither."""

    model_config = ConfigDict(
        json_schema_extra={
            "allOf": [
                {
                    "if": {"required": [a], "properties": {a: _GIVEN}},
                    "then": {"required": [b], "properties": {b: _GIVEN}},
                }
                for a, b in (("iteration", "step"), ("step", "iteration"))
            ]
        }
    )

    iteration: int | None = Field(None, ge=0, le=MAX_ID)
    step: StepName | None = Field(None, strict=False)  # an enum from a JSON string
