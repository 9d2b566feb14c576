"""The file contract of one ``command`` oracle run: what alcove writes, what the program writes.

All files live in a fresh working directory, which is the command's cwd:

* alcove writes ``trajectory.csv`` (``t,q_0,qd_0[,tau_0]``: s, rad, rad/s, N m),
  ``params.json`` (``dt_out`` and the entry's declared parameters) and, if the entry or the
  user provides a template, the rendered input deck (e.g. ``headrest.k``; its placeholders:
  :data:`TEMPLATE_PLACEHOLDERS`);
* the command writes the forces CSV (default ``forces.csv``, header ``t,fx,fy,fz,mx,my,mz``:
  s, N, N m; contact force on the head and its moment about the head frame origin, in the
  headrest frame) covering the trajectory's time span, optionally ``diagnostics.json``
  (a JSON object), and exits with code 0.

Environment of the command: the worker's environment, the entry's ``env``, and
``ALCOVE_WORKDIR``, ``ALCOVE_TRAJECTORY``, ``ALCOVE_INPUT``, ``ALCOVE_OUTPUT``,
``ALCOVE_PARAMS`` (:func:`run_environment`). The readers raise :class:`OutputError` saying
what is wrong with the program's output.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from pathlib import Path

from alcove.science.oracles.base import SUMMARY_DIAGNOSTICS
from alcove.science.series import ForceSeries, SeriesFormatError, Trajectory

TRAJECTORY_FILE = "trajectory.csv"
PARAMS_FILE = "params.json"
DIAGNOSTICS_FILE = "diagnostics.json"
STDOUT_FILE = "stdout.log"
STDERR_FILE = "stderr.log"
DEFAULT_OUTPUT_FILE = "forces.csv"
JOB_FILES = ("alcove-job.sh", "alcove-job-times.txt", "batch-stdout.log", "batch-stderr.log")
RESERVED_FILES = frozenset({TRAJECTORY_FILE, PARAMS_FILE, DIAGNOSTICS_FILE, STDOUT_FILE, STDERR_FILE, *JOB_FILES})
#: the environment variables of the file contract (:func:`run_environment`)
CONTRACT_VARIABLES = ("ALCOVE_WORKDIR", "ALCOVE_TRAJECTORY", "ALCOVE_INPUT", "ALCOVE_OUTPUT", "ALCOVE_PARAMS")

#: Placeholders every template may use (besides the entry's declared parameters).
TEMPLATE_PLACEHOLDERS: dict[str, str] = {
    "motion_curve": (
        "the head's absolute backward tilt head_angle + tilt (theta for the 1-DOF preset) over t as *DEFINE_CURVE "
        "data lines: t [s], angle [rad] (2 fields of 20 characters)"
    ),
    "head_x_curve": "x_H displacement of the head frame origin from its start [m] over t, as curve data lines",
    "head_z_curve": "z_H displacement of the head frame origin from its start [m] over t, as curve data lines",
    "head_rotation_curve": (
        "rotation of the head about y_H from its start [rad] over t (= head_angle(t0) - head_angle(t)), "
        "as curve data lines"
    ),
    "head_x0": "x_H of the head frame origin at the start [m]",
    "head_z0": "z_H of the head frame origin at the start [m]",
    "head_x0_mm": "the same in mm",
    "head_z0_mm": "the same in mm",
    "head_rotation0": (
        "rotation of the head frame about y_H relative to the headrest frame at the start [rad] (= -head_angle(t0))"
    ),
    "head_rotation0_deg": "the same in degrees",
    "theta_start": "the head's absolute tilt at the start, head_angle(t0) + tilt (theta for the 1-DOF preset) [rad]",
    "headrest_tilt": "backward tilt of the headrest [rad]",
    "t_start": "first time of the trajectory [s]",
    "t_end": "last time of the trajectory [s]",
    "duration": "t_end - t_start [s]",
    "n_samples": "number of trajectory samples",
    "dt_out": "requested output interval of the forces [s]",
    "trajectory_file": "name of the trajectory CSV in the working directory",
    "output_file": "name of the forces CSV the command must write",
}


class OutputError(ValueError):
    """The program's output breaks the contract; the message says how."""


def write_inputs(
    workdir: Path, trajectory: Trajectory, parameters: Mapping[str, float], deck: str | None, deck_file: str
) -> None:
    """Write ``trajectory.csv``, ``params.json`` (``parameters``) and the rendered deck, if any."""
    trajectory.to_csv(workdir / TRAJECTORY_FILE)
    (workdir / PARAMS_FILE).write_text(json.dumps(dict(parameters), indent=2) + "\n")
    if deck is not None:
        (workdir / deck_file).write_text(deck)


def run_environment(workdir: Path, input_file: str, output_file: str, extra: Mapping[str, str]) -> dict[str, str]:
    """The command's environment: the worker's, then ``extra`` (the entry's ``env``), then alcove's names."""
    return {
        **os.environ,
        **extra,
        "ALCOVE_WORKDIR": str(workdir),
        "ALCOVE_TRAJECTORY": TRAJECTORY_FILE,
        "ALCOVE_INPUT": input_file,
        "ALCOVE_OUTPUT": output_file,
        "ALCOVE_PARAMS": PARAMS_FILE,
    }


def read_forces(workdir: Path, output_file: str) -> ForceSeries:
    """The forces CSV the command wrote, validated (:class:`OutputError` if missing or malformed)."""
    path = workdir / output_file
    if not path.is_file():
        raise OutputError(f"the command exited with code 0 but wrote no {output_file}")
    try:
        return ForceSeries.from_csv(path)
    except SeriesFormatError as exc:
        raise OutputError(f"{output_file} is malformed: {exc}") from None


def read_solver_diagnostics(workdir: Path) -> dict[str, object]:
    """``diagnostics.json`` (optional) as ``{"solver": <the object>, <summary keys it holds>}``.

    The summary diagnostics every oracle reports (``SUMMARY_DIAGNOSTICS``) are lifted to the
    top level where the program gives them as finite numbers (or null).
    """
    path = workdir / DIAGNOSTICS_FILE
    if not path.is_file():
        return {}
    try:
        data = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise OutputError(f"{DIAGNOSTICS_FILE} is not valid JSON: {exc}") from None
    if not isinstance(data, dict):
        raise OutputError(f"{DIAGNOSTICS_FILE} must hold a JSON object")
    lifted = {k: data[k] for k in SUMMARY_DIAGNOSTICS if _is_number_or_none(data.get(k))}
    return {**lifted, "solver": data}


def _is_number_or_none(value: object) -> bool:
    if value is None:
        return True
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


__all__ = [
    "DEFAULT_OUTPUT_FILE",
    "DIAGNOSTICS_FILE",
    "PARAMS_FILE",
    "RESERVED_FILES",
    "STDERR_FILE",
    "STDOUT_FILE",
    "TEMPLATE_PLACEHOLDERS",
    "TRAJECTORY_FILE",
    "OutputError",
    "read_forces",
    "read_solver_diagnostics",
    "run_environment",
    "write_inputs",
]
