"""The part of an OCP solution that an oracle replays: the first phases of the motion,
optionally resampled on a finer time grid."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import CubicHermiteSpline

from alcove.science.series import Trajectory


def replay_trajectory(
    arrays: Mapping[str, NDArray[np.float64]], task: Any, phases: int | None, dt: float | None
) -> Trajectory:
    """The first ``phases`` phases of the solution (``t``, ``q``, ``qd``, ``tau``; None: all of it,
    as for a prescribed motion, which does not follow the task's phases); with
    ``dt``, resampled on a grid of that step with cubic Hermite interpolation (q with its
    derivative qd), the torque linearly. The trajectory carries the task model's pose
    function: its pose is the contact body's, computed from the joint state (also after
    an oracle resamples it)."""
    t, q, qd, tau = arrays["t"], arrays["q"], arrays["qd"], arrays["tau"]
    t_end = t[-1] if phases is None else t[0] + sum(ph.duration for ph in task.phases[:phases])
    pose = task.model.pose_function()  # the oracles read the head's pose, computed from the task's model
    if dt is None:
        m = t <= t_end + 1e-9
        return Trajectory(t[m], q[m], qd[m], tau[m], model=pose)
    n = math.floor((t_end - t[0]) / dt + 1e-9) + 1
    grid = np.minimum(t[0] + dt * np.arange(n), t_end)
    spline = CubicHermiteSpline(t, q, qd, axis=0)
    tau_g = np.stack([np.interp(grid, t, tau[:, j]) for j in range(q.shape[1])], -1)
    # the cubic may overshoot the joint range between nodes that sit on a bound
    q_g = np.clip(spline(grid), task.model.joint_min, task.model.joint_max)
    return Trajectory(grid, q_g, spline.derivative()(grid), tau_g, model=pose)
