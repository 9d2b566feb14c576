"""The held-out validation suite: M prescribed press motions, never in a training pool.

Each motion presses the head into the headrest and lets it off again: from rest at a start
angle it swings back with a quintic blend (zero velocity and acceleration at both ends) to a
peak angle, dwells there, and returns to the start angle with the same blend. Four numbers
make a motion, drawn as a Latin hypercube (``scipy.stats.qmc``, centred-discrepancy optimised) from the box of
:class:`SuiteRanges` and a seed, so a suite is reproducible from its spec alone:

* ``start``: the start angle [rad] (the head is at rest, normally clear of the cushion);
* ``depth``: the peak angle [rad] (how far into the cushion; at most the joint limit);
* ``speed``: the largest angular velocity of the press and the release [rad/s]
  (a quintic blend over an angle D in a time T peaks at 15 D / (8 T));
* ``dwell``: the time held at the peak angle [s].

These are motions an OCP does not produce (the campaign's in-loop error is measured on the
OCP's own optimum): the suite measures how the surrogate generalises to the range of the
model, not along the campaign's own motion.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from scipy.stats import qmc

from alcove.science.arrays import FloatArray
from alcove.science.geometry import HeadNeckPreset
from alcove.science.series import Trajectory

#: largest velocity of the quintic blend s^3 (10 - 15 s + 6 s^2) over [0, 1]
BLEND_PEAK = 15.0 / 8.0


@dataclass(frozen=True)
class SuiteRanges:
    """The box the motions are drawn from (angles in the preset's joint range)."""

    start: tuple[float, float] = (0.15, 0.28)  # rad
    depth: tuple[float, float] = (0.34, 0.43)  # rad
    speed: tuple[float, float] = (0.3, 1.5)  # rad/s
    dwell: tuple[float, float] = (0.0, 0.3)  # s

    def check(self, preset: HeadNeckPreset) -> None:
        for name in ("start", "depth", "speed", "dwell"):
            lo, hi = getattr(self, name)
            if not (np.isfinite(lo) and np.isfinite(hi)) or lo > hi:
                raise ValueError(f"validation suite range {name}: need finite lo <= hi, got ({lo}, {hi})")
        for name in ("start", "depth"):
            lo, hi = getattr(self, name)
            if lo < preset.theta_min or hi > preset.theta_max:
                raise ValueError(
                    f"validation suite range {name}: ({lo}, {hi}) rad leaves the joint range "
                    f"[{preset.theta_min}, {preset.theta_max}] rad"
                )
        if self.speed[0] <= 0 or self.dwell[0] < 0:
            raise ValueError("validation suite ranges: speed must be > 0 and dwell >= 0")
        if self.start[1] >= self.depth[0]:
            raise ValueError("validation suite ranges: every start angle must lie below every peak angle")


@dataclass(frozen=True)
class SuiteSpec:
    """What makes a suite: its size, seed, ranges and sampling step (and the model preset)."""

    motions: int = 8
    seed: int = 0
    dt: float = 0.0025
    ranges: SuiteRanges = field(default_factory=SuiteRanges)

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["ranges"] = {k: list(v) for k, v in d["ranges"].items()}
        return d

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> SuiteSpec:
        r = data.get("ranges") or {}
        ranges = SuiteRanges(**{k: (float(v[0]), float(v[1])) for k, v in r.items()})
        return cls(int(data["motions"]), int(data["seed"]), float(data["dt"]), ranges)

    def digest(self, preset: HeadNeckPreset) -> str:
        """sha256 over the spec and the preset: suites with equal digests are the same motions."""
        payload = json.dumps({"spec": self.to_dict(), "preset": preset.to_dict()}, sort_keys=True)
        return hashlib.sha256(payload.encode()).hexdigest()


@dataclass(frozen=True)
class PressMotion:
    start: float
    depth: float
    speed: float
    dwell: float

    @property
    def press_time(self) -> float:
        return BLEND_PEAK * (self.depth - self.start) / self.speed

    @property
    def duration(self) -> float:
        return 2 * self.press_time + self.dwell


def motion_parameters(spec: SuiteSpec, preset: HeadNeckPreset) -> list[PressMotion]:
    """The suite's M motions (a seeded Latin hypercube over the ranges: every range is cut
    into M strata and each stratum holds exactly one motion)."""
    if spec.motions < 1:
        raise ValueError(f"validation suite motions: must be >= 1, got {spec.motions}")
    spec.ranges.check(preset)
    sampler = qmc.LatinHypercube(d=4, optimization="random-cd", rng=np.random.default_rng(spec.seed))
    unit = sampler.random(spec.motions)
    r = spec.ranges
    lo = np.array([r.start[0], r.depth[0], r.speed[0], r.dwell[0]])
    hi = np.array([r.start[1], r.depth[1], r.speed[1], r.dwell[1]])
    pts = qmc.scale(unit, lo, hi) if np.all(hi > lo) else lo + unit * (hi - lo)
    return [PressMotion(*(float(x) for x in p)) for p in pts]


def _blend(s: FloatArray) -> tuple[FloatArray, FloatArray]:
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10 - 15 * s + 6 * s**2), 30 * s**2 * (1 - s) ** 2


def press_trajectory(m: PressMotion, dt: float) -> Trajectory:
    """The motion sampled every ``dt`` (exact angular velocity)."""
    n = int(np.floor(m.duration / dt + 1e-9)) + 1
    t: FloatArray = dt * np.arange(n, dtype=np.float64)
    if t[-1] < m.duration - 1e-12:
        t = np.append(t, m.duration)
    tp, d = m.press_time, m.depth - m.start
    up, up_d = _blend(t / tp)
    down, down_d = _blend((t - tp - m.dwell) / tp)
    theta = m.start + d * (up - down)
    theta_dot = d * (up_d - down_d) / tp
    return Trajectory(t, theta, theta_dot)


def suite_trajectories(spec: SuiteSpec, preset: HeadNeckPreset) -> list[Trajectory]:
    return [press_trajectory(m, spec.dt) for m in motion_parameters(spec, preset)]


__all__ = [
    "PressMotion",
    "SuiteRanges",
    "SuiteSpec",
    "motion_parameters",
    "press_trajectory",
    "suite_trajectories",
]
