"""Where a command oracle's program runs: on the worker itself, or as a batch-scheduler job.

A catalogue entry's ``launcher`` (:class:`LauncherSpec`) is the administrator's choice.
``scheduler: local`` (the default) starts the program on the oracle worker's machine. A batch
scheduler (``slurm``, ``pbs``, ``lsf``) makes every oracle call one batch job with the entry's
resources: the oracle worker, on a login or service node, stages the job folder, submits,
waits without computing and collects the outputs (:mod:`.batch`).

Every value here ends up in a job script, so names are restricted to characters no shell or
scheduler treats specially; the errors name the field.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

#: the batch schedulers a command oracle can be submitted to (PSI/J executors of these names)
SCHEDULERS = ("slurm", "pbs", "lsf")
#: a partition, account, module or directive value: no blanks, quotes or shell syntax
SCHEDULER_WORD = re.compile(r"^[A-Za-z0-9_.+/@:=,%-]{1,200}$")
DIRECTIVE_NAME = re.compile(r"^[a-z][a-z0-9-]{0,63}$")
ENV_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]{0,127}$")
MAX_TIME_LIMIT_S = 30 * 24 * 3600.0


class LauncherSpec(BaseModel):
    """How an entry's program is started: ``local`` or one batch job per oracle call."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    scheduler: Literal["local", "slurm", "pbs", "lsf"] = Field(
        "local", description="local: on the oracle worker; slurm, pbs, lsf: one batch job per oracle call"
    )
    partition: str | None = Field(None, description="partition (Slurm) or queue (PBS, LSF) the jobs go to")
    account: str | None = Field(None, description="account (project) the jobs are charged to")
    time_limit_s: float | None = Field(
        None,
        gt=0,
        le=MAX_TIME_LIMIT_S,
        description="the job's wall-time limit [s] (default: the entry's timeout_s); Slurm rounds it up to minutes",
    )
    nodes: int = Field(1, ge=1, le=100_000, description="nodes per job")
    tasks: int = Field(1, ge=1, le=10_000_000, description="processes (MPI ranks) per job")
    cpus_per_task: int = Field(1, ge=1, le=10_000, description="CPU cores per process (threads of a threaded solver)")
    memory_mb: int | None = Field(None, ge=1, le=100_000_000, description="memory per job [MB]")
    directives: dict[str, str] = Field(
        default_factory=dict,
        description="further scheduler options, name -> value (Slurm: qos: normal gives --qos=normal)",
    )
    modules: list[str] = Field(default_factory=list, description="environment modules loaded before the program")
    env: dict[str, str] = Field(default_factory=dict, description="environment variables of the job")
    job_root: Path | None = Field(
        None,
        description=(
            "folder shared by the worker and the compute nodes where job folders are made "
            "(default: the entry's workdir_root)"
        ),
    )
    poll_s: float = Field(
        5.0, ge=0.05, le=600, description="how often the worker asks the scheduler for its jobs' states [s]"
    )

    @field_validator("partition", "account")
    @classmethod
    def _word(cls, v: str | None) -> str | None:
        if v is not None and not SCHEDULER_WORD.match(v):
            raise ValueError("use letters, digits and _ . + / @ : = , % - only (no blanks or quotes)")
        return v

    @field_validator("modules")
    @classmethod
    def _modules(cls, v: list[str]) -> list[str]:
        for name in v:
            if not SCHEDULER_WORD.match(name):
                raise ValueError(f"module {name!r}: use letters, digits and _ . + / @ : = , % - only")
        return v

    @field_validator("directives")
    @classmethod
    def _directives(cls, v: dict[str, str]) -> dict[str, str]:
        for key, value in v.items():
            if not DIRECTIVE_NAME.match(key):
                raise ValueError(f"directive {key!r}: a lower-case option name (letters, digits, '-')")
            if not SCHEDULER_WORD.match(str(value)):
                raise ValueError(f"directive {key}: value {value!r}: no blanks or quotes")
        return v

    @field_validator("env")
    @classmethod
    def _env(cls, v: dict[str, str]) -> dict[str, str]:
        for key in v:
            if not ENV_NAME.match(key):
                raise ValueError(
                    f"environment variable name {key!r}: letters, digits and '_', not starting with a digit"
                )
        return v

    @model_validator(mode="after")
    def _local_has_no_resources(self) -> LauncherSpec:
        if self.scheduler == "local":
            batch_only = ("partition", "account", "time_limit_s", "memory_mb", "job_root")
            given = [name for name in batch_only if getattr(self, name) is not None]
            given += [name for name in ("directives", "modules", "env") if getattr(self, name)]
            given += [name for name in ("nodes", "tasks", "cpus_per_task") if getattr(self, name) != 1]
            if given:
                raise ValueError(f"{', '.join(given)}: only for a batch scheduler (scheduler: slurm, pbs or lsf)")
        return self

    @property
    def is_batch(self) -> bool:
        return self.scheduler != "local"

    def summary(self) -> str:
        """What a user is told about where the oracle runs, e.g. "one Slurm job per oracle call
        (partition short, 1 task x 8 CPUs, 16000 MB, time limit 3600 s)"."""
        if not self.is_batch:
            return "on the oracle worker"
        parts = [f"partition {self.partition}"] if self.partition else []
        if self.nodes > 1:
            parts.append(f"{self.nodes} nodes")
        parts.append(f"{self.tasks} task{'s' if self.tasks > 1 else ''} x {self.cpus_per_task} CPU")
        if self.memory_mb:
            parts.append(f"{self.memory_mb} MB")
        if self.time_limit_s:
            parts.append(f"time limit {self.time_limit_s:g} s")
        name = {"slurm": "Slurm", "pbs": "PBS", "lsf": "LSF"}[self.scheduler]
        return f"one {name} job per oracle call ({', '.join(parts)})"


LOCAL = LauncherSpec()

__all__ = ["LOCAL", "MAX_TIME_LIMIT_S", "SCHEDULERS", "LauncherSpec"]
