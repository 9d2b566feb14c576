"""The one interface every oracle implements.

An oracle replays a joint trajectory and returns the contact force and moment on the head
over time (headrest frame, moment about the head frame origin), the relative kinematics it
used, and run diagnostics. A run that fails the oracle's quality gate comes back with
``ok=False`` and a ``failure_reason``; its numbers must never be used as data.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol

import numpy as np
from pydantic import BaseModel, ConfigDict

from alcove.science.arrays import FloatArray
from alcove.science.errors import FieldError
from alcove.science.geometry import HeadNeckPreset, RelativeKinematics
from alcove.science.series import ForceSeries, SeriesFormatError, Trajectory

CancelCheck = Callable[[], bool]

#: Diagnostics every oracle reports (None where it has no such thing), shown by ``alcove
#: oracle run --json`` and the UI: deepest penetration [m], energy dissipated by the contact
#: [J], total Newton iterations.
SUMMARY_DIAGNOSTICS = ("max_penetration_m", "dissipated_energy_j", "newton_iterations")


class OracleInputError(FieldError):
    """Bad input to an oracle (trajectory or parameters); ``field`` names what is wrong."""


class OracleCancelled(RuntimeError):
    """The run was cancelled cooperatively through the cancel check."""


class OracleParams(BaseModel):
    """Base class of the validated parameter model of an oracle type.

    Unknown fields are refused, and so are infinite and NaN numbers (they pass bounds such
    as ``gt=0``).
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


@dataclass
class OracleResult:
    ok: bool
    forces: ForceSeries | None
    kinematics: RelativeKinematics | None
    diagnostics: dict[str, Any] = field(default_factory=dict)
    wall_time: float = 0.0
    failure_reason: str | None = None

    def summary(self) -> dict[str, Any]:
        """JSON-ready summary (status, wall time, peak force and the diagnostics)."""
        return {
            "status": "ok" if self.ok else "failed",
            "failure_reason": self.failure_reason,
            "wall_time_s": self.wall_time,
            "peak_force_n": None if self.forces is None else self.forces.peak_force,
            **self.diagnostics,
        }


class Oracle(Protocol):
    """What every oracle type provides (its parameters may be any :class:`OracleParams` subclass)."""

    type_name: ClassVar[str]

    @property
    def params(self) -> OracleParams: ...

    @property
    def preset(self) -> HeadNeckPreset: ...

    def run(self, trajectory: Trajectory, cancel: CancelCheck | None = None) -> OracleResult: ...


def validated_head_trajectory(
    trajectory: Any,
    preset: HeadNeckPreset,
    output_dt: float,
    indentation: Callable[[FloatArray], FloatArray],
    max_indentation: float,
) -> tuple[Trajectory, FloatArray]:
    """The checks every head-headrest FE oracle makes of its input, with errors naming the field:
    a 1-DOF trajectory (``q_0 = theta``) spanning at least one output interval, within the
    preset's joint range, that never indents the cushion beyond ``max_indentation`` [m].
    ``indentation(theta)`` is the oracle's own geometric depth [m] per sample. Returns the
    re-validated trajectory and that depth."""
    try:
        traj = Trajectory(trajectory.t, trajectory.q, trajectory.qd)  # (re-)validates time, NaN, shapes
    except SeriesFormatError as exc:
        raise OracleInputError(exc.field, exc.reason) from None
    except AttributeError:
        raise OracleInputError("trajectory", "expected a Trajectory with t, q and qd") from None
    if traj.ndof != 1:
        raise OracleInputError(
            "q", f"the head-neck preset has 1 degree of freedom (q_0 = theta), got {traj.ndof} columns"
        )
    span = traj.t[-1] - traj.t[0]
    if span < output_dt * (1 - 1e-9):
        raise OracleInputError("t", f"time span {span:g} s is shorter than one output interval ({output_dt:g} s)")
    theta = traj.q[:, 0]
    bad = np.flatnonzero((theta < preset.theta_min - 1e-12) | (theta > preset.theta_max + 1e-12))
    if bad.size:
        i = int(bad[0])
        raise OracleInputError(
            "q_0",
            f"theta = {theta[i]:.4g} rad at t = {traj.t[i]:.4g} s is outside the model's range "
            f"[{preset.theta_min}, {preset.theta_max}] rad",
        )
    depth = indentation(theta)
    if depth.max() > max_indentation:
        i = int(np.argmax(depth))
        raise OracleInputError(
            "q_0",
            f"at t = {traj.t[i]:.4g} s the head would indent the cushion by {depth[i] * 1e3:.1f} mm, "
            f"beyond the model's reach ({max_indentation * 1e3:.1f} mm = max_indentation_fraction x "
            "cushion_thickness)",
        )
    return traj, depth
