"""The ``command`` oracle: an external solver (LS-DYNA, Abaqus, a cluster script) as an oracle.

An administrator defines each external solver in a server-side YAML catalogue (see
``docs/external-solvers.md``); web users only choose an entry by name and may supply a text
template and the numeric parameters the entry declares. Nothing a user enters is executed:
commands are argument lists from the catalogue (never a shell string, never ``shell=True``),
and templates are rendered by plain substitution of a fixed set of ``{{ name }}``
placeholders.

File contract of one run (all in a fresh working directory, which is the command's cwd):

* alcove writes ``trajectory.csv`` (``t,q_0,qd_0[,tau_0]``: s, rad, rad/s, N m),
  ``params.json`` (``dt_out`` and the entry's declared parameters) and, if the entry or the
  user provides a template, the rendered input deck (e.g. ``headrest.k``);
* the command writes the forces CSV (default ``forces.csv``, header ``t,fx,fy,fz,mx,my,mz``:
  s, N, N m; contact force on the head and its moment about the head frame origin, in the
  headrest frame) covering the trajectory's time span, optionally ``diagnostics.json``
  (a JSON object), and exits with code 0.

Environment of the command: the worker's environment, the entry's ``env``, and
``ALCOVE_WORKDIR``, ``ALCOVE_TRAJECTORY``, ``ALCOVE_INPUT``, ``ALCOVE_OUTPUT``,
``ALCOVE_PARAMS``. A non-zero exit code, a timeout (the whole process group is killed), a
missing, malformed or too short output give ``OracleResult(ok=False)`` naming what failed;
the working directory is then kept and its path is in the diagnostics.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, create_model, field_validator, model_validator

from alcove.science.geometry import DEFAULT_PRESET, HeadNeckPreset, relative_kinematics
from alcove.science.oracles.base import CancelCheck, OracleCancelled, OracleInputError, OracleParams, OracleResult
from alcove.science.oracles.registry import BUILTIN_TYPE_NAMES, SUMMARY_DIAGNOSTICS
from alcove.science.series import ForceSeries, SeriesFormatError, Trajectory

TRAJECTORY_FILE = "trajectory.csv"
PARAMS_FILE = "params.json"
DIAGNOSTICS_FILE = "diagnostics.json"
STDOUT_FILE = "stdout.log"
STDERR_FILE = "stderr.log"
RESERVED_FILES = frozenset({TRAJECTORY_FILE, PARAMS_FILE, DIAGNOSTICS_FILE, STDOUT_FILE, STDERR_FILE})
POLL_SECONDS = 0.05
TERMINATE_GRACE_SECONDS = 3.0

PLACEHOLDER = re.compile(r"\{\{\s*([A-Za-z_][A-Za-z0-9_]*)\s*\}\}")
PLAIN_FILE_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]*$")
ENTRY_NAME = re.compile(r"^[a-z0-9][a-z0-9_.-]*$")

#: Placeholders every template may use (besides the entry's declared parameters).
TEMPLATE_PLACEHOLDERS: dict[str, str] = {
    "motion_curve": "theta(t) of the trajectory as *DEFINE_CURVE data lines: t [s], theta [rad] (2 fields of 20 characters)",
    "head_x_curve": "x_H displacement of the head frame origin from its start [m] over t, as curve data lines",
    "head_z_curve": "z_H displacement of the head frame origin from its start [m] over t, as curve data lines",
    "head_rotation_curve": "rotation of the head about y_H from its start [rad] over t (= theta(t0) - theta(t)), as curve data lines",
    "head_x0": "x_H of the head frame origin at the start [m]",
    "head_z0": "z_H of the head frame origin at the start [m]",
    "head_x0_mm": "the same in mm",
    "head_z0_mm": "the same in mm",
    "head_rotation0": "rotation of the head frame about y_H relative to the headrest frame at the start [rad] (= tilt - theta_start)",
    "head_rotation0_deg": "the same in degrees",
    "theta_start": "theta at the start [rad]",
    "headrest_tilt": "backward tilt of the headrest [rad]",
    "t_start": "first time of the trajectory [s]",
    "t_end": "last time of the trajectory [s]",
    "duration": "t_end - t_start [s]",
    "n_samples": "number of trajectory samples",
    "dt_out": "requested output interval of the forces [s]",
    "trajectory_file": "name of the trajectory CSV in the working directory",
    "output_file": "name of the forces CSV the command must write",
}


class CatalogueError(ValueError):
    """The administrator's command catalogue is invalid; ``field`` names the offending entry/key."""

    def __init__(self, field: str, reason: str):
        self.field = field
        self.reason = reason
        super().__init__(f"{field}: {reason}")


class CommandParameter(BaseModel):
    """A numeric parameter an entry declares; users may set it, templates use it as ``{{ name }}``."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    default: float
    minimum: float | None = None
    maximum: float | None = None
    description: str = ""

    @model_validator(mode="after")
    def _default_in_range(self) -> CommandParameter:
        if self.minimum is not None and self.maximum is not None and self.minimum > self.maximum:
            raise ValueError("minimum is larger than maximum")
        if (self.minimum is not None and self.default < self.minimum) or (
            self.maximum is not None and self.default > self.maximum
        ):
            raise ValueError("default lies outside [minimum, maximum]")
        return self


class CommandOracleSpec(BaseModel):
    """One catalogue entry: how to run an external solver."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    name: str = Field(description="catalogue name users choose, e.g. 'lsdyna-headrest'")
    argv: list[str] = Field(min_length=1, description="program and arguments (no shell); run in the working directory")
    description: str = ""
    template: Path | None = Field(
        None, description="template file of the input deck (relative paths: from the catalogue's folder)"
    )
    input_file: str | None = Field(
        None,
        description="name of the rendered template in the working directory (default: the template's name without .tmpl)",
    )
    allow_user_template: bool = Field(True, description="users may replace the template with their own text")
    output_file: str = Field("forces.csv", description="forces CSV the command writes (header t,fx,fy,fz,mx,my,mz)")
    timeout_s: float = Field(
        3600.0, gt=0, le=7 * 24 * 3600, description="wall-time limit; the process group is killed after it"
    )
    env: dict[str, str] = Field(default_factory=dict, description="extra environment variables (e.g. a licence server)")
    parameters: dict[str, CommandParameter] = Field(
        default_factory=dict, description="numeric parameters users may set"
    )
    workdir_root: Path | None = Field(
        None, description="where working directories are created (default: the system temp dir)"
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
                f"must be a plain file name inside the working directory, not one of {', '.join(sorted(RESERVED_FILES))}; got {v!r}"
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
            if not re.fullmatch(r"[a-z][a-z0-9_]*", key):
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


class CommandOracleParams(OracleParams):
    """What a user may set for a command oracle (an entry adds its declared numeric parameters)."""

    template: str | None = Field(
        None,
        max_length=50_000_000,
        description="template text replacing the entry's template (rendered by plain placeholder substitution)",
    )
    dt_out: float = Field(
        0.0025, gt=0, le=1.0, description="output interval of the forces [s] (placeholder {{ dt_out }})"
    )
    keep_workdir: bool = Field(False, description="keep the working directory after a successful run")


def params_model(spec: CommandOracleSpec) -> type[CommandOracleParams]:
    """The pydantic parameter model of one entry: the common fields plus its declared parameters."""
    fields: dict[str, Any] = {
        key: (float, Field(p.default, ge=p.minimum, le=p.maximum, description=p.description, allow_inf_nan=False))
        for key, p in spec.parameters.items()
    }
    return create_model(
        f"CommandParams_{spec.name}", __base__=CommandOracleParams, __doc__=spec.description or None, **fields
    )


# ---- catalogue -----------------------------------------------------------------------------
def load_command_catalogue(path: str | Path) -> dict[str, CommandOracleSpec]:
    """Read the administrator's YAML catalogue.

    Format::

        command_oracles:
          lsdyna-headrest:
            description: LS-DYNA headrest model (MAT_057 foam)
            argv: ["{catalogue_dir}/run_lsdyna.sh", "ncpu=4"]
            template: lsdyna/headrest.k.tmpl
            timeout_s: 1800

    ``{catalogue_dir}`` (the catalogue's folder) and ``{python}`` (the Python running alcove)
    are replaced in ``argv`` and ``env`` values; relative template paths are resolved from
    the catalogue's folder. Raises :class:`CatalogueError` naming the entry and key.
    """
    path = Path(path)
    try:
        raw = yaml.safe_load(path.read_text())
    except FileNotFoundError:
        raise CatalogueError("catalogue", f"{path} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CatalogueError("catalogue", f"cannot read {path}: {getattr(exc, 'strerror', None) or exc}") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1})" if mark is not None else ""
        raise CatalogueError("catalogue", f"{path} is not valid YAML{where}: {getattr(exc, 'problem', exc)}") from None
    if not isinstance(raw, dict) or not isinstance(raw.get("command_oracles"), dict):
        raise CatalogueError(
            "command_oracles", f"{path} must have a top-level mapping 'command_oracles: {{name: entry}}'"
        )
    base = path.resolve().parent
    substitute = lambda s: s.replace("{catalogue_dir}", str(base)).replace("{python}", sys.executable)  # noqa: E731
    catalogue: dict[str, CommandOracleSpec] = {}
    for name, entry in raw["command_oracles"].items():
        field = f"command_oracles.{name}"
        if not isinstance(entry, dict):
            raise CatalogueError(field, "must be a mapping of settings")
        if str(name) in BUILTIN_TYPE_NAMES:
            raise CatalogueError(field, f"the name is a built-in oracle type ({', '.join(sorted(BUILTIN_TYPE_NAMES))})")
        if "name" in entry and entry["name"] != name:
            raise CatalogueError(f"{field}.name", "differs from the entry's key; leave it out")
        entry = {**entry, "name": str(name)}
        if isinstance(entry.get("argv"), str):
            raise CatalogueError(f"{field}.argv", "must be a list of arguments, not a shell string")
        if isinstance(entry.get("argv"), list):
            entry["argv"] = [substitute(a) if isinstance(a, str) else a for a in entry["argv"]]
        if isinstance(entry.get("env"), dict):
            entry["env"] = {k: substitute(v) if isinstance(v, str) else v for k, v in entry["env"].items()}
        if isinstance(entry.get("template"), str):
            entry["template"] = base / substitute(entry["template"])
        try:
            spec = CommandOracleSpec.model_validate(entry)
        except ValidationError as exc:
            raise CatalogueError(*_first_error(exc, prefix=field)) from None
        if spec.template is not None and not spec.template.is_file():
            raise CatalogueError(f"{field}.template", f"{spec.template} does not exist")
        catalogue[spec.name] = spec
    return catalogue


def _first_error(exc: ValidationError, prefix: str) -> tuple[str, str]:
    err = exc.errors()[0]
    loc = ".".join(str(p) for p in err["loc"])
    return (f"{prefix}.{loc}" if loc else prefix), err["msg"]


# ---- template rendering ----------------------------------------------------------------------
def render_template(text: str, values: Mapping[str, str]) -> str:
    """Replace ``{{ name }}`` by ``values[name]``; nothing else in ``text`` is interpreted.

    Only plain names are placeholders. An unknown name is an error (a typo would otherwise
    reach the solver); any other text, including ``{{ expression }}``, ``${VAR}``, ``$(...)``
    or backquotes, is copied verbatim. Substitution is a single pass: inserted values are
    never rendered again.
    """
    for match in PLACEHOLDER.finditer(text):
        if match.group(1) not in values:
            line = text.count("\n", 0, match.start()) + 1
            known = ", ".join(sorted(values))
            raise OracleInputError(
                "template", f"unknown placeholder {match.group(0)!r} on line {line} (known: {known})"
            )
    return PLACEHOLDER.sub(lambda m: values[m.group(1)], text)


def curve_lines(t: np.ndarray, y: np.ndarray) -> str:
    """Curve data as LS-DYNA *DEFINE_CURVE data cards (two 20-character fields per line)."""
    return "\n".join(f"{a:20.12e}{b:20.12e}" for a, b in zip(t, y, strict=False))


def card_number(value: float, width: int = 10) -> str:
    """``value`` with as many significant digits (at most 12) as fit in ``width`` characters.

    Fixed-format keyword cards (LS-DYNA: 10-character fields; also the limit of a value in a
    comma-separated free-format card) cannot hold 12 significant digits.
    """
    v = float(value)
    for digits in range(12, 0, -1):
        text = format(v, f".{digits}g")
        if len(text) <= width:
            return text
    raise ValueError(f"{v!r} does not fit in {width} characters")


def template_values(
    trajectory: Trajectory, preset: HeadNeckPreset, params: CommandOracleParams, spec: CommandOracleSpec
) -> dict[str, str]:
    """The values of the fixed placeholders (and the entry's parameters) for one trajectory.

    SI values (``head_x0``, ``theta_start``, ...) have 12 significant digits; the values meant
    for card fields (mm, degrees, times, ``dt_out`` and the entry's parameters) fit in 10
    characters (:func:`card_number`).
    """
    t, theta = trajectory.t, trajectory.q[:, 0]
    kin = relative_kinematics(preset, theta, trajectory.qd[:, 0])
    x, z = kin.r_rel[:, 0], kin.r_rel[:, 2]
    number = lambda v: format(float(v), ".12g")  # noqa: E731
    card = card_number
    values = {
        "motion_curve": curve_lines(t, theta),
        "head_x_curve": curve_lines(t, x - x[0]),
        "head_z_curve": curve_lines(t, z - z[0]),
        "head_rotation_curve": curve_lines(t, theta[0] - theta),
        "head_x0": number(x[0]),
        "head_z0": number(z[0]),
        "head_x0_mm": card(1e3 * x[0]),
        "head_z0_mm": card(1e3 * z[0]),
        "head_rotation0": number(preset.tilt - theta[0]),
        "head_rotation0_deg": card(np.degrees(preset.tilt - theta[0])),
        "theta_start": number(theta[0]),
        "headrest_tilt": number(preset.tilt),
        "t_start": card(t[0]),
        "t_end": card(t[-1]),
        "duration": card(t[-1] - t[0]),
        "n_samples": str(len(t)),
        "dt_out": card(params.dt_out),
        "trajectory_file": TRAJECTORY_FILE,
        "output_file": spec.output_file,
    }
    values.update({key: card(getattr(params, key)) for key in spec.parameters})
    return values


# ---- the oracle --------------------------------------------------------------------------------
class CommandOracle:
    """Runs one catalogue entry on a trajectory (type name: the entry's name)."""

    type_name: ClassVar[str] = "command"

    def __init__(
        self,
        spec: CommandOracleSpec,
        params: CommandOracleParams | None = None,
        preset: HeadNeckPreset = DEFAULT_PRESET,
    ):
        model = params_model(spec)
        self.spec = spec
        self.params = model.model_validate(params.model_dump() if params is not None else {})
        self.preset = preset
        if self.params.template is not None and not spec.allow_user_template:
            raise OracleInputError(
                "params.template", f"the command oracle '{spec.name}' does not accept user templates"
            )

    def run(self, trajectory: Trajectory, cancel: CancelCheck | None = None) -> OracleResult:
        start = time.perf_counter()
        if trajectory.ndof != 1:
            raise OracleInputError(
                "q", f"the head-neck preset has 1 degree of freedom (q_0 = theta), the trajectory has {trajectory.ndof}"
            )
        deck = self._rendered_deck(trajectory)
        if cancel is not None and cancel():
            raise OracleCancelled(f"command oracle '{self.spec.name}' cancelled before it started")
        workdir = self._make_workdir()
        self._write_inputs(workdir, trajectory, deck)
        diagnostics: dict[str, Any] = {
            "command": self.spec.name,
            "max_penetration_m": None,
            "dissipated_energy_j": None,
            "newton_iterations": None,
        }

        def failed(reason: str) -> OracleResult:
            diagnostics["workdir"] = str(workdir)
            diagnostics["stderr_tail"] = _tail(workdir / STDERR_FILE)
            return OracleResult(
                False,
                None,
                None,
                diagnostics,
                time.perf_counter() - start,
                f"command oracle '{self.spec.name}': {reason}",
            )

        outcome = self._execute(workdir, cancel)
        diagnostics["exit_code"] = outcome.get("exit_code")
        if "failure" in outcome:
            return failed(outcome["failure"])
        output = workdir / self.spec.output_file
        if not output.is_file():
            return failed(f"output: the command exited with code 0 but wrote no {self.spec.output_file}")
        try:
            forces = ForceSeries.from_csv(output)
        except SeriesFormatError as exc:
            return failed(f"output: {self.spec.output_file} is malformed: {exc}")
        tol = 1e-6 * max(1.0, trajectory.t[-1] - trajectory.t[0])
        if forces.t[0] > trajectory.t[0] + tol or forces.t[-1] < trajectory.t[-1] - tol:
            return failed(
                f"output: {self.spec.output_file} covers t = [{forces.t[0]:.6g}, {forces.t[-1]:.6g}] s "
                f"but the trajectory spans [{trajectory.t[0]:.6g}, {trajectory.t[-1]:.6g}] s"
            )
        try:
            diagnostics.update(self._solver_diagnostics(workdir))
        except ValueError as exc:
            return failed(f"output: {exc}")
        inside = (forces.t >= trajectory.t[0] - tol) & (forces.t <= trajectory.t[-1] + tol)
        if inside.sum() < 2:
            return failed(f"output: {self.spec.output_file} has fewer than 2 samples within the trajectory's time span")
        forces = ForceSeries(forces.t[inside], forces.force[inside], forces.moment[inside])
        sampled = trajectory.resample(np.clip(forces.t, trajectory.t[0], trajectory.t[-1]))
        kinematics = relative_kinematics(self.preset, sampled.q[:, 0], sampled.qd[:, 0])
        if self.params.keep_workdir:
            diagnostics["workdir"] = str(workdir)
        else:
            shutil.rmtree(workdir, ignore_errors=True)
        return OracleResult(True, forces, kinematics, diagnostics, time.perf_counter() - start)

    # -- steps ------------------------------------------------------------------------------------
    def _rendered_deck(self, trajectory: Trajectory) -> str | None:
        text = self.params.template
        if text is None and self.spec.template is not None:
            text = self.spec.template.read_text()
        if text is None:
            return None
        return render_template(text, template_values(trajectory, self.preset, self.params, self.spec))

    def _make_workdir(self) -> Path:
        root = self.spec.workdir_root
        if root is not None:
            root.mkdir(parents=True, exist_ok=True)
        return Path(tempfile.mkdtemp(prefix=f"alcove-{self.spec.name}-", dir=root))

    def _write_inputs(self, workdir: Path, trajectory: Trajectory, deck: str | None) -> None:
        trajectory.to_csv(workdir / TRAJECTORY_FILE)
        values = {"dt_out": self.params.dt_out, **{key: getattr(self.params, key) for key in self.spec.parameters}}
        (workdir / PARAMS_FILE).write_text(json.dumps(values, indent=2) + "\n")
        if deck is not None:
            (workdir / self.spec.rendered_file_name).write_text(deck)

    def _environment(self, workdir: Path) -> dict[str, str]:
        return {
            **os.environ,
            **self.spec.env,
            "ALCOVE_WORKDIR": str(workdir),
            "ALCOVE_TRAJECTORY": TRAJECTORY_FILE,
            "ALCOVE_INPUT": self.spec.rendered_file_name,
            "ALCOVE_OUTPUT": self.spec.output_file,
            "ALCOVE_PARAMS": PARAMS_FILE,
        }

    def _execute(self, workdir: Path, cancel: CancelCheck | None) -> dict[str, Any]:
        """Run the command; returns ``{"exit_code": int}`` or ``{"failure": reason, ...}``."""
        with open(workdir / STDOUT_FILE, "wb") as out, open(workdir / STDERR_FILE, "wb") as err:
            try:
                proc = subprocess.Popen(
                    self.spec.argv,
                    cwd=workdir,
                    env=self._environment(workdir),
                    stdin=subprocess.DEVNULL,
                    stdout=out,
                    stderr=err,
                    start_new_session=True,  # own process group: a timeout kills the solver and its children
                )
            except OSError as exc:
                return {"failure": f"cannot start {self.spec.argv[0]!r}: {exc.strerror or exc}"}
            deadline = time.monotonic() + self.spec.timeout_s
            try:
                while True:
                    try:
                        code = proc.wait(timeout=POLL_SECONDS)
                        break
                    except subprocess.TimeoutExpired:
                        pass
                    if cancel is not None and cancel():
                        _kill_process_group(proc)
                        raise OracleCancelled(
                            f"command oracle '{self.spec.name}' cancelled (working directory {workdir})"
                        )
                    if time.monotonic() > deadline:
                        _kill_process_group(proc)
                        return {
                            "failure": f"timeout: the command ran longer than {self.spec.timeout_s:g} s and was killed"
                        }
            except BaseException:
                _kill_process_group(proc)  # KeyboardInterrupt, cancellation: never leave the solver running
                raise
        if code < 0:
            return {"exit_code": code, "failure": f"the command was killed by signal {_signal_name(-code)}"}
        if code != 0:
            last = _tail(workdir / STDERR_FILE, lines=1)
            return {
                "exit_code": code,
                "failure": f"the command exited with code {code}" + (f": {last}" if last else ""),
            }
        return {"exit_code": 0}

    def _solver_diagnostics(self, workdir: Path) -> dict[str, Any]:
        path = workdir / DIAGNOSTICS_FILE
        if not path.is_file():
            return {}
        try:
            data = json.loads(path.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise ValueError(f"{DIAGNOSTICS_FILE} is not valid JSON: {exc}") from None
        if not isinstance(data, dict):
            raise ValueError(f"{DIAGNOSTICS_FILE} must hold a JSON object")
        lifted = {k: data[k] for k in SUMMARY_DIAGNOSTICS if _is_number_or_none(data.get(k))}
        return {**lifted, "solver": data}


def _is_number_or_none(v: Any) -> bool:
    return v is None or (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v))


def _kill_process_group(proc: subprocess.Popen) -> None:
    """SIGTERM to the command's process group, SIGKILL after a grace period."""
    for sig, grace in ((signal.SIGTERM, TERMINATE_GRACE_SECONDS), (signal.SIGKILL, None)):
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(proc.pid, sig)
        try:
            proc.wait(timeout=grace)
            # the leader is gone; make sure no child of it survives in the group
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(proc.pid, signal.SIGKILL)
            return
        except subprocess.TimeoutExpired:
            continue


def _signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:
        return str(number)


def _tail(path: Path, lines: int = 20) -> str:
    try:
        text = path.read_text(errors="replace")
    except OSError:
        return ""
    return "\n".join(text.strip().splitlines()[-lines:])
