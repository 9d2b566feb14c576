"""Bodies of the oracle routes."""

from __future__ import annotations

from datetime import datetime
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from alcove.names import Name
from alcove.science.oracles.command.launcher import LauncherSpec
from alcove.versioning.schemas import DefinitionMeta, VersionMeta


class _In(BaseModel):
    # strict: "1" is not a number and 1 or "true" not a boolean, as the schema says (JSON numbers still fill floats)
    model_config = ConfigDict(extra="forbid", strict=True)


TypeName = Field(
    min_length=1,
    max_length=100,
    description=(
        "a built-in type (`aux-penalty`, `fe-headrest-2d`, `fe-headrest-3d-ccx`) or a command catalogue entry's name"
    ),
)


class OracleIn(_In):
    name: Name
    description: str = Field("", max_length=20_000)
    type: str = TypeName
    params: dict[str, Any] = Field(
        default_factory=dict, description="parameters of the type (see its JSON Schema); defaults fill the rest"
    )
    note: str = Field("", max_length=2000)


class OracleUpdate(_In):
    name: Name | None = None
    description: str | None = Field(None, max_length=20_000)
    type: str | None = Field(None, min_length=1, max_length=100)
    params: dict[str, Any] | None = None
    note: str = Field("", max_length=2000)


class OracleDraft(_In):
    type: str = TypeName
    params: dict[str, Any] = Field(default_factory=dict)


class OracleOut(DefinitionMeta):
    type: str
    params: dict[str, Any]


class OracleVersionOut(VersionMeta):
    type: str
    params: dict[str, Any]


class OracleTypeOut(BaseModel):
    name: str
    kind: Literal["builtin", "command"]
    description: str
    available: bool
    unavailable_reason: str | None = None
    launcher: str | None = Field(
        None, description="how its calls run when not on the oracle worker: one batch job per call, with the resources"
    )
    params_schema: dict[str, Any] = Field(description="JSON Schema of the parameters")


class OraclePresetOut(BaseModel):
    key: str
    name: str
    type: str
    description: str
    params: dict[str, Any]


class CommandOracleIn(_In):
    """A catalogue entry (administrators only). The program runs without a shell, in a fresh
    working directory holding ``trajectory.csv`` and ``params.json``, and must write
    ``forces.csv``; ``{{ placeholder }}`` s in ``argv`` are filled in by the worker."""

    name: str = Field(min_length=1, max_length=100, pattern=r"^[a-z0-9][a-z0-9_.-]*$")
    description: str = Field("", max_length=20_000)
    argv: list[str] = Field(min_length=1, max_length=200)
    env: dict[str, str] = Field(default_factory=dict)
    timeout_s: float = Field(3600.0, gt=0, le=7 * 24 * 3600)
    working_dir: str | None = Field(None, max_length=1000, description="where working directories are created")
    launcher: LauncherSpec | None = Field(
        None,
        description="where the program runs: on the oracle worker (none, or scheduler local) or as one batch job "
        "per oracle call (scheduler slurm, pbs or lsf, with the job's resources)",
    )
    enabled: bool = True


class CommandOracleOut(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    id: int
    name: str
    description: str
    argv: list[str]
    env: dict[str, str]
    timeout_s: float
    working_dir: str | None
    launcher: dict[str, Any] | None
    enabled: bool
    created_at: datetime
    updated_at: datetime


class BatchJobRead(BaseModel):
    """A batch-scheduler job of an oracle call (a command oracle submitted to Slurm, PBS or LSF)."""

    model_config = ConfigDict(from_attributes=True)

    scheduler: str = Field(description="slurm, pbs or lsf")
    job_id: str = Field(description="the scheduler's id of the job (squeue -j, qstat, bjobs)")
    state: str = Field(
        description="queued, running, completed (result not yet stored), collected (result stored), failed, cancelled"
    )
    reason: str | None = Field(None, description="why it failed or was cancelled")
    attempt: int = Field(description="the step's attempt that submitted it")
    worker_name: str | None = Field(None, description="the oracle worker waiting for it")
    workdir: str = Field(description="the job folder")
    exit_code: int | None = None
    submitted_at: datetime | None = None
    started_at: datetime | None = None
    ended_at: datetime | None = None
    collected_at: datetime | None = None
