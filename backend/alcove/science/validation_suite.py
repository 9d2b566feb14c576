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

A chain model (:class:`ChainSuiteModel`) has the same motions, drawn from the same ranges of
the 1-DOF preset's angle theta, each followed along a straight line in joint space: from
the chain's initial pose along the direction in which the head's gap to the cushion closes
fastest (the gap's steepest descent), through the pose of first contact, scaled so that the
gap closes at the 1-DOF preset's rate at first contact. A motion then presses the chain's
head about as deep as the 1-DOF preset's motion of the same parameters, whatever the chain.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from scipy.stats import qmc

from alcove.science.arrays import FloatArray
from alcove.science.geometry import HeadNeckPreset, PoseFunction, profile_gap, signed_gap
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

    def check(self, preset: HeadNeckPreset | ChainSuiteModel) -> None:
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

    def digest(self, preset: HeadNeckPreset | ChainSuiteModel) -> str:
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


def motion_parameters(spec: SuiteSpec, preset: HeadNeckPreset | ChainSuiteModel) -> list[PressMotion]:
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


@dataclass(frozen=True)
class ChainSuiteModel:
    """The suite's model for a chain task: the task's model (``ModelSpec`` as JSON) and the joint
    line its motions follow, ``q(theta) = q_contact + scale (theta - theta_contact) direction``
    (``theta_contact``: the 1-DOF preset's first contact, the reference of the suite's ranges).
    Its :meth:`to_dict` is what the suite stores and digests; ``theta_min``, ``theta_max`` are
    the reference angles whose line poses stay within the chain's joint range."""

    model: dict[str, Any]
    q_contact: tuple[float, ...]
    direction: tuple[float, ...]
    scale: float
    theta_contact: float
    theta_min: float
    theta_max: float

    def to_dict(self) -> dict[str, Any]:
        return {"chain_suite": asdict(self)}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ChainSuiteModel:
        d = dict(data["chain_suite"])
        d["q_contact"], d["direction"] = tuple(d["q_contact"]), tuple(d["direction"])
        return cls(**d)

    def joints(self, theta: FloatArray, theta_dot: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Joint positions and velocities (n, ndof) of the line at reference angles and rates (n,)."""
        e = np.asarray(self.direction)
        q = np.asarray(self.q_contact) + self.scale * (np.asarray(theta)[:, None] - self.theta_contact) * e
        return q, self.scale * np.asarray(theta_dot)[:, None] * e


def chain_suite_model(
    model: dict[str, Any],
    pose: PoseFunction,
    preset: HeadNeckPreset,
    q_start: FloatArray,
    q_min: FloatArray,
    q_max: FloatArray,
    reference: HeadNeckPreset | None = None,
) -> ChainSuiteModel:
    """The joint line of a chain's suite (the module docstring): ``pose`` and ``preset`` (its head
    profile) give the gap, ``q_start`` the initial pose; ``reference`` (default: the paper's
    1-DOF preset) the first contact and gap rate the line is scaled to. SciPy's ``brentq`` finds
    the first contact along the line; the gradient is a central difference (step 1e-6 rad)."""
    from scipy.optimize import brentq

    ref = reference or HeadNeckPreset()
    q0 = np.asarray(q_start, float)
    n = q0.size

    def gap(q: FloatArray) -> FloatArray:
        q = np.atleast_2d(q)
        return profile_gap(preset.profile, pose(q, np.zeros_like(q)))

    h = 1e-6
    steps = np.eye(n) * h
    grad = (gap(q0 + steps) - gap(q0 - steps)) / (2 * h)
    norm = float(np.linalg.norm(grad))
    g0 = float(gap(q0)[0])
    if not (norm > 0 and g0 > 0):
        raise ValueError(f"validation suite: the head must start clear of the cushion (gap {g0:.3g} m)")
    e = -grad / norm

    def along(s: float) -> float:
        return float(gap(q0 + s * e)[0])

    s_c = brentq(along, 0.0, 2.0, xtol=1e-12) if along(2.0) < 0 else None
    if s_c is None:
        raise ValueError("validation suite: the head does not reach the cushion within 2 rad along the line")
    rate_chain = (along(s_c + h) - along(s_c - h)) / (2 * h)
    theta_c = ref.theta_contact
    rate_ref = float((signed_gap(ref, theta_c + h) - signed_gap(ref, theta_c - h))[0] / (2 * h))
    scale = rate_ref / rate_chain
    q_c = q0 + s_c * e
    # the reference angles whose line poses stay within the joint range
    lo, hi = ref.theta_min, ref.theta_max
    for j in range(n):
        if abs(e[j] * scale) < 1e-12:
            continue
        a, b = ((np.array([q_min[j], q_max[j]]) - q_c[j]) / (scale * e[j])) + theta_c
        lo, hi = max(lo, min(a, b)), min(hi, max(a, b))
    return ChainSuiteModel(model, tuple(q_c.tolist()), tuple(e.tolist()), float(scale), theta_c, lo, hi)


def chain_press_trajectory(m: PressMotion, dt: float, suite: ChainSuiteModel, pose: PoseFunction) -> Trajectory:
    """A suite motion of a chain: :func:`press_trajectory`'s reference angle followed along the
    chain's joint line, with the head's pose from ``pose``."""
    ref = press_trajectory(m, dt)
    q, qd = suite.joints(ref.q[:, 0], ref.qd[:, 0])
    return Trajectory(ref.t, q, qd, model=pose)


SuiteModel = HeadNeckPreset | ChainSuiteModel


def suite_model_from_dict(data: dict[str, Any]) -> SuiteModel:
    """The model a suite stored (:meth:`HeadNeckPreset.to_dict` or :meth:`ChainSuiteModel.to_dict`)."""
    if "chain_suite" in data:
        return ChainSuiteModel.from_dict(data)
    return HeadNeckPreset.from_dict(data)


__all__ = [
    "ChainSuiteModel",
    "PressMotion",
    "SuiteRanges",
    "SuiteSpec",
    "chain_press_trajectory",
    "chain_suite_model",
    "motion_parameters",
    "press_trajectory",
    "suite_model_from_dict",
    "suite_trajectories",
]
