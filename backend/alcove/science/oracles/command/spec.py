"""A ``command`` catalogue entry and the parameters a user may set for it (pydantic models).

An entry (:class:`CommandOracleSpec`) is written by the administrator and says how to run
an external solver; users choose an entry by name and set only what :func:`params_model`
of that entry allows: the common :class:`CommandOracleParams` and the numeric parameters
the entry declares (:class:`CommandParameter`).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, create_model, field_validator, model_validator

from alcove.science.errors import FieldError
from alcove.science.oracles.base import OracleParams
from alcove.science.oracles.command.contract import DEFAULT_OUTPUT_FILE, RESERVED_FILES, TEMPLATE_PLACEHOLDERS
from alcove.science.oracles.command.launcher import LauncherSpec

PLAIN_FILE_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]*$")
ENTRY_NAME = re.compile(r"^[a-z0-9][a-z0-9_.-]*$")
PARAMETER_NAME = re.compile(r"[a-z][a-z0-9_]*")
MAX_TIMEOUT_S = 7 * 24 * 3600.0


class CatalogueError(FieldError):
    """The administrator's command catalogue is invalid; ``field`` names the offending entry/key."""


class CommandParameter(BaseModel):
    """A numeric parameter an entry declares; users may set it, templates use it as ``{{ name }}``."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    default: float = Field(description="value when the user sets none, in the unit the description states")
    minimum: float | None = Field(None, description="smallest value a user may set (none: unbounded)")
    maximum: float | None = Field(None, description="largest value a user may set (none: unbounded)")
    description: str = Field("", description="what the parameter is and its unit, shown to users")

    @model_validator(mode="after")
    def _default_in_range(self) -> CommandParameter:
        if self.minimum is not None and self.maximum is not None and self.minimum > self.maximum:
            raise ValueError("minimum is larger than maximum")
        if (self.minimum is not None and self.default < self.minimum) or (
            self.maximum is not None and self.default > self.maximum
        ):
            raise ValueError("default lies outside [minimum, maximum]")
        return self


class CommandOracleParams(OracleParams):
    """What a user may set for a command oracle (an entry adds its declared numeric parameters)."""

    template: str | None = Field(
        None,
        max_length=50_000_000,
        description="template text replacing the entry's template (rendered by plain placeholder substitution)",
    )
    dt_out: float = Field(
        0.0025,
        ge=1e-5,
        le=1.0,
        description="output interval of the forces [s], 1e-5 to 1 s (100 kHz to 1 Hz; placeholder {{ dt_out }})",
    )
    keep_workdir: bool = Field(False, description="keep the working directory after a successful run")


class CommandOracleSpec(BaseModel):
    """One catalogue entry: how to run an external solver."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    name: str = Field(description="catalogue name users choose, e.g. 'lsdyna-headrest'")
    argv: list[str] = Field(min_length=1, description="program and arguments (no shell); run in the working directory")
    description: str = ""
    template: Path | None = Field(
        None, description="template file of the input deck (relative paths: from the catalogue's folder)"
    )
    input_file: str | None = Field(
        None,
        description=(
            "name of the rendered template in the working directory (default: the template's name without .tmpl)"
        ),
    )
    allow_user_template: bool = Field(True, description="users may replace the template with their own text")
    output_file: str = Field(
        DEFAULT_OUTPUT_FILE, description="forces CSV the command writes (header t,fx,fy,fz,mx,my,mz)"
    )
    timeout_s: float = Field(
        3600.0,
        gt=0,
        le=MAX_TIMEOUT_S,
        description="wall-time limit [s], up to 7 days; the process group is killed after it",
    )
    env: dict[str, str] = Field(default_factory=dict, description="extra environment variables (e.g. a licence server)")
    parameters: dict[str, CommandParameter] = Field(
        default_factory=dict, description="numeric parameters users may set"
    )
    workdir_root: Path | None = Field(
        None, description="where working directories are created (default: the system temp dir)"
    )
    launcher: LauncherSpec = Field(
        default_factory=LauncherSpec,
        description="where the program runs: on the oracle worker (local) or as one batch job per call",
    )

    @field_validator("name")
    @classmethod
    def _name(cls, v: str) -> str:
        if not ENTRY_NAME.match(v):
            raise ValueError("use lower-case letters, digits, '-', '_' and '.' (starting with a letter or digit)")
        return v

    @field_validator("argv")
    @classmethod
    def _argv(cls, v: list[str]) -> list[str]:
        if not v[0].strip():
            raise ValueError("the program (argv[0]) is empty")
        return v

    @field_validator("input_file", "output_file")
    @classmethod
    def _plain_file_name(cls, v: str | None) -> str | None:
        if v is not None and (not PLAIN_FILE_NAME.match(v) or v in RESERVED_FILES):
            raise ValueError(
                "must be a plain file name inside the working directory, not one of "
                f"{', '.join(sorted(RESERVED_FILES))}; got {v!r}"
            )
        return v

    @model_validator(mode="after")
    def _distinct_files(self) -> CommandOracleSpec:
        if self.rendered_file_name == self.output_file:
            raise ValueError(f"the rendered template and the output would both be {self.output_file!r}")
        return self

    @field_validator("parameters")
    @classmethod
    def _parameter_names(cls, v: dict[str, CommandParameter]) -> dict[str, CommandParameter]:
        reserved = set(TEMPLATE_PLACEHOLDERS) | set(CommandOracleParams.model_fields)
        for key in v:
            if not PARAMETER_NAME.fullmatch(key):
                raise ValueError(f"parameter name {key!r} must be lower-case letters, digits and '_'")
            if key in reserved:
                raise ValueError(f"parameter name {key!r} is reserved")
        return v

    @property
    def rendered_file_name(self) -> str:
        if self.input_file:
            return self.input_file
        if self.template is not None:
            return self.template.name.removesuffix(".tmpl")
        return "input.txt"


def params_model(spec: CommandOracleSpec) -> type[CommandOracleParams]:
    """The pydantic parameter model of one entry: the common fields plus its declared parameters."""
    fields: dict[str, Any] = {
        key: (float, Field(p.default, ge=p.minimum, le=p.maximum, description=p.description, allow_inf_nan=False))
        for key, p in spec.parameters.items()
    }
    model: type[CommandOracleParams] = create_model(
        f"CommandParams_{spec.name}", __base__=CommandOracleParams, __doc__=spec.description or None, **fields
    )
    return model


__all__ = [
    "ENTRY_NAME",
    "MAX_TIMEOUT_S",
    "PLAIN_FILE_NAME",
    "CatalogueError",
    "CommandOracleParams",
    "CommandOracleSpec",
    "CommandParameter",
    "params_model",
]
