"""A reference head motion like the paper's example FE run (phase 1, 1 s).

There is no published trajectory file, so this is built to the paper's description: the
head starts at rest at theta0 = 0.232 rad clear of the headrest, swings back along its
circular path, touches the cushion at about t = 0.29 s (theta_contact = 0.31 rad),
presses in firmly, up to ``theta_peak`` = 0.43 rad (the end of the joint range, 0.432 rad)
at ``t_peak`` = 0.65 s, and eases back to ``theta_end`` (resting on
the cushion) at t = 1 s. Both legs are C2 quintic blends (zero velocity and acceleration
at their ends), sampled at 0.0025 s (401 samples), with the exact angular velocity.
"""

from __future__ import annotations

import numpy as np

from alcove.science.arrays import FloatArray
from alcove.science.geometry import DEFAULT_PRESET, HeadNeckPreset
from alcove.science.series import Trajectory


def _blend(s: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Quintic smoothstep and its derivative on s in [0, 1]."""
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10 - 15 * s + 6 * s**2), 30 * s**2 * (1 - s) ** 2


def reference_motion(
    preset: HeadNeckPreset = DEFAULT_PRESET,
    theta_peak: float = 0.43,
    t_peak: float = 0.65,
    theta_end: float = 0.33,
    duration: float = 1.0,
    dt: float = 0.0025,
    time_scale: float = 1.0,
) -> Trajectory:
    """The reference motion; ``time_scale`` < 1 plays the same path faster (for rate tests)."""
    n = round(duration * time_scale / dt) + 1
    t = np.linspace(0.0, duration * time_scale, n)
    tau = t / time_scale
    up, up_d = _blend(tau / t_peak)
    down, down_d = _blend((tau - t_peak) / (duration - t_peak))
    rise = theta_peak - preset.theta0
    fall = theta_end - theta_peak
    theta = preset.theta0 + rise * up + fall * down
    theta_dot = (rise * up_d / t_peak + fall * down_d / (duration - t_peak)) / time_scale
    return Trajectory(t, theta, theta_dot)
