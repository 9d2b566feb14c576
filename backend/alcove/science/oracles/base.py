"""The one interface every oracle implements.

An oracle replays a trajectory and returns the contact force and moment on the head over
time (headrest frame, moment about the head frame origin), the relative kinematics it used,
and run diagnostics. It reads the contact body's pose and twist relative to the headrest
(``Trajectory.pose``), never a joint angle, so it works for any chain; a 1-joint trajectory
without a pose is the head-neck-1dof preset's (:func:`posed_trajectory`). A run that fails
the oracle's quality gate comes back with ``ok=False`` and a ``failure_reason``; its numbers must never be used as data.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol

import numpy as np
from pydantic import BaseModel, ConfigDict

from alcove.science.arrays import FloatArray
from alcove.science.errors import FieldError
from alcove.science.geometry import (
    POSE_COLUMNS,
    HeadNeckPreset,
    HeadProfile,
    RelativeKinematics,
    preset_pose_function,
)
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


def posed_trajectory(trajectory: Any, preset: HeadNeckPreset) -> Trajectory:
    """The trajectory (re-validated: time, NaN, shapes) with the contact body's pose, which is
    all an oracle reads: its own pose columns, or for a 1-joint trajectory without them (a file
    from before the pose columns existed) the pose of the head-neck-1dof preset ``preset``,
    headrest offset included, recomputed from the joint state whenever the oracle resamples."""
    try:
        traj = Trajectory(
            trajectory.t,
            trajectory.q,
            trajectory.qd,
            getattr(trajectory, "tau", None),
            getattr(trajectory, "pose", None),
            getattr(trajectory, "model", None),
        )
    except SeriesFormatError as exc:
        raise OracleInputError(exc.field, exc.reason) from None
    except AttributeError:
        raise OracleInputError("trajectory", "expected a Trajectory with t, q and qd") from None
    if traj.pose is None:
        if traj.ndof != 1:
            raise OracleInputError(
                POSE_COLUMNS[0],
                f"a trajectory of {traj.ndof} joints needs the contact body's pose ({', '.join(POSE_COLUMNS)}); "
                "only a 1-joint trajectory of the head-neck-1dof preset may leave it out",
            )
        traj = traj.with_model(preset_pose_function(preset))
    return traj


def sample_label(traj: Trajectory, i: int) -> str:
    """``sample i (t = ... s)``: how an input error names a sample."""
    return f"sample {i} (t = {traj.t[i]:.4g} s)"


def validated_head_trajectory(
    trajectory: Any,
    preset: HeadNeckPreset,
    output_dt: float,
    indentation: Callable[[FloatArray], FloatArray],
    max_indentation: float,
) -> tuple[Trajectory, FloatArray]:
    """The checks every head-headrest FE oracle makes of its input, with errors naming the field,
    the sample and the reason: a trajectory with the contact body's pose (:func:`posed_trajectory`)
    spanning at least one output interval whose head never indents the cushion beyond
    ``max_indentation`` [m] (what the foam block can take). ``indentation(pose)`` is the oracle's
    own geometric depth [m] per sample. Returns the trajectory and that depth."""
    traj = posed_trajectory(trajectory, preset)
    span = traj.t[-1] - traj.t[0]
    if span < output_dt * (1 - 1e-9):
        raise OracleInputError("t", f"time span {span:g} s is shorter than one output interval ({output_dt:g} s)")
    assert traj.pose is not None
    depth = indentation(traj.pose)
    if depth.max() > max_indentation:
        i = int(np.argmax(depth))
        raise OracleInputError(
            "head_x",
            f"{sample_label(traj, i)}: the head would indent the cushion by {depth[i] * 1e3:.1f} mm, "
            f"beyond what the foam block can take ({max_indentation * 1e3:.1f} mm = max_indentation_fraction x "
            "cushion_thickness)",
        )
    return traj, depth


def check_contact_within_cushion(
    traj: Trajectory, depth: FloatArray, profile: HeadProfile, bottom: float, top: float
) -> None:
    """The head leaving the modelled region: raise :class:`OracleInputError` naming the first
    sample (among those with ``depth > 0``) whose undeformed profile would enter the cushion
    (x_H < 0) outside its height, z_H in [``bottom``, ``top``]."""
    touching = np.flatnonzero(depth > 0)
    if not touching.size:
        return
    assert traj.pose is not None
    pose = traj.pose[touching]
    pts = profile.points(200)
    c, s = np.cos(pose[:, 2])[:, None], np.sin(pose[:, 2])[:, None]
    x = pose[:, :1] + c * pts[None, :, 0] - s * pts[None, :, 1]
    z = pose[:, 1:2] + s * pts[None, :, 0] + c * pts[None, :, 1]
    beyond = np.any((x < 0) & ((z < bottom) | (z > top)), axis=1)
    if np.any(beyond):
        i = int(touching[np.argmax(beyond)])
        raise OracleInputError(
            "head_z",
            f"{sample_label(traj, i)}: the head would touch the cushion beyond its ends, outside the modelled "
            f"region (z_H in [{bottom:g}, {top:g}] m)",
        )
