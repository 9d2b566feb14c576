"""Bodies of the task-definition routes. ``spec`` is :class:`alcove.science.ocp.task_spec.TaskSpec`."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from alcove.names import Name
from alcove.science.ocp.task_spec import TaskSpec
from alcove.versioning.schemas import DefinitionMeta, VersionMeta


class _In(BaseModel):
    # strict: "1" is not a number and 1 or "true" not a boolean, as the schema says (JSON numbers still fill floats)
    model_config = ConfigDict(extra="forbid", strict=True)


class TaskIn(_In):
    name: Name
    description: str = Field("", max_length=20_000)
    spec: TaskSpec
    note: str = Field("", max_length=2000, description="change note stored with the version")


class TaskUpdate(_In):
    name: Name | None = None
    description: str | None = Field(None, max_length=20_000)
    spec: TaskSpec | None = None
    note: str = Field("", max_length=2000)


class TaskDraft(_In):
    """A task to check without saving (any JSON: nothing is validated before the check)."""

    name: str | None = None
    description: str | None = None
    spec: dict[str, Any]


class TaskOut(DefinitionMeta):
    spec: dict[str, Any]
    n_phases: int
    duration_s: float
    intervals: int


class TaskVersionOut(VersionMeta):
    spec: dict[str, Any]


class TaskPresetOut(BaseModel):
    key: str
    name: str
    description: str
    spec: dict[str, Any]


class ModelPresetOut(BaseModel):
    """A model preset (``model.preset``) with every parameter filled in: the model part of a task spec."""

    key: str = Field(description="the value of model.preset")
    description: str
    ndof: int = Field(description="joints of the model")
    model: dict[str, Any] = Field(
        description="the model as a task spec holds it: the 1-DOF preset's parameters, or preset and chain"
    )


class ScenarioPreviewIn(_In):
    """Sample a task's scenarios: the stored task's latest version, or a draft ``spec`` (the editor's unsaved form)."""

    n: int = Field(5, ge=1, le=50, description="scenarios to draw (1 to 50)")
    seed: int = Field(0, ge=0, lt=2**62, description="the campaign seed the draws follow")
    spec: dict[str, Any] | None = Field(None, description="a draft task spec instead of the stored one")


class ScenarioOut(BaseModel):
    iteration: int = Field(description="the iteration of a random-scenarios campaign with this seed that solves it")
    values: dict[str, float] = Field(description="drawn value per ranged parameter (dotted path in the spec)")
    spec: dict[str, Any] = Field(description="the concrete, validated task of this scenario (no ranges)")


class ScenarioPreviewOut(BaseModel):
    seed: int
    ranges: list[dict[str, Any]] = Field(description="the task's ranges (empty: one scenario, the task itself)")
    scenarios: list[ScenarioOut]
