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
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np
from scipy.stats import qmc

from alcove.science.arrays import FloatArray
from alcove.science.geometry import HeadNeckPreset, PoseFunction, profile_gap, signed_gap
from alcove.science.press_family import BLEND_PEAK, HistoryPress, PressFamily, blend, family_motions, sequence_motion
from alcove.science.series import Trajectory


@dataclass(frozen=True)
class SuiteRanges(PressFamily):
    """The box the motions are drawn from (angles in the preset's joint range): the press family's
    (:class:`alcove.science.press_family.PressFamily`), whose ``release`` (1, 1) and ``reload`` (0, 0)
    by default make every motion a simple press (:class:`PressMotion`); a ``release`` below 1 adds
    the partial unloads and re-loads of :class:`alcove.science.press_family.HistoryPress`."""

    start: tuple[float, float] = (0.15, 0.28)  # rad
    depth: tuple[float, float] = (0.34, 0.43)  # rad
    speed: tuple[float, float] = (0.3, 1.5)  # rad/s
    dwell: tuple[float, float] = (0.0, 0.3)  # s
    release: tuple[float, float] = (1.0, 1.0)  # share of the press the unload gives back
    reload: tuple[float, float] = (0.0, 0.0)  # share of the way back to the peak the re-load goes

    def check_for(self, preset: HeadNeckPreset | ChainSuiteModel, what: str = "validation suite") -> None:
        """:meth:`PressFamily.check` in the joint range of the suite's model."""
        self.check(preset.theta_min, preset.theta_max, what)

    @property
    def simple(self) -> bool:
        """Every motion a simple press (no unload before the return): the suite's four-parameter draw."""
        return self.release == (1.0, 1.0) and self.reload == (0.0, 0.0)

    def to_dict(self) -> dict[str, list[float]]:
        """The ranges as lists; a simple press's ``release`` and ``reload`` are left out (so a suite of
        simple presses has the digest it had before the family's parameters existed)."""
        d = {k: list(v) for k, v in asdict(self).items()}
        if self.simple:
            del d["release"], d["reload"]
        return d

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> SuiteRanges:
        return cls(**{k: (float(v[0]), float(v[1])) for k, v in data.items()})


#: the suite's parts: ``core`` (the motions the task's scenarios can reach; the suite's figures),
#: ``stress`` (beyond them: reported apart) and ``reference`` (the best-possible line's training
#: motions: never scored)
PARTS = ("core", "stress", "reference")

#: the smallest oracle budget of the best-possible line
FIRST_BUDGET = 4


def reference_budgets(n: int) -> list[int]:
    """The oracle budgets of a best-possible line of ``n`` motions: 4, 8, 16, ... below ``n``, and ``n``."""
    out, b = [], FIRST_BUDGET
    while b < n:
        out.append(b)
        b *= 2
    return [*out, n] if n > 0 else []


@dataclass(frozen=True)
class SuiteSpec:
    """What makes a suite: its size, seed, ranges and sampling step (and the model preset), and
    an optional stress part of ``stress_motions`` motions from the box ``stress``."""

    motions: int = 8
    seed: int = 0
    dt: float = 0.0025
    ranges: SuiteRanges = field(default_factory=SuiteRanges)
    stress_motions: int = 0
    stress: SuiteRanges | None = None
    #: motions of the core box's space-filling sequence the best-possible line is trained on
    reference_motions: int = 0

    def __post_init__(self) -> None:
        if self.stress_motions < 0:
            raise ValueError(f"validation suite stress motions: must be >= 0, got {self.stress_motions}")
        if self.reference_motions < 0:
            raise ValueError(f"validation suite reference motions: must be >= 0, got {self.reference_motions}")
        if self.stress_motions > 0 and self.stress is None:
            raise ValueError("validation suite stress: stress motions need the stress ranges")

    def part(self, index: int) -> str:
        """The part motion ``index`` belongs to (core, then stress, then reference motions)."""
        if index < self.motions:
            return PARTS[0]
        return PARTS[1] if index < self.motions + self.stress_motions else PARTS[2]

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"motions": self.motions, "seed": self.seed, "dt": self.dt, "ranges": self.ranges.to_dict()}
        if self.stress_motions > 0 and self.stress is not None:  # absent: the digest of a suite without one
            d["stress_motions"], d["stress"] = self.stress_motions, self.stress.to_dict()
        if self.reference_motions > 0:
            d["reference_motions"] = self.reference_motions
        return d

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> SuiteSpec:
        stress = data.get("stress")
        return cls(
            int(data["motions"]),
            int(data["seed"]),
            float(data["dt"]),
            SuiteRanges.from_dict(data.get("ranges") or {}),
            int(data.get("stress_motions", 0)),
            SuiteRanges.from_dict(stress) if stress else None,
            int(data.get("reference_motions", 0)),
        )

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

    def trajectory(self, dt: float) -> Trajectory:
        return press_trajectory(self, dt)


#: a motion of the suite: a simple press, or a press with a partial unload and re-load
SuiteMotion = PressMotion | HistoryPress


def suite_motion(params: dict[str, Any]) -> SuiteMotion:
    """The motion a suite stored (its parameters; ``part`` is not a motion parameter)."""
    values = {k: float(v) for k, v in params.items() if k != "part"}
    return HistoryPress(**values) if "release" in values else PressMotion(**values)


def _draw(
    ranges: SuiteRanges, n: int, seed: int | list[int], preset: HeadNeckPreset | ChainSuiteModel, what: str
) -> list[SuiteMotion]:
    ranges.check_for(preset, what)
    if not ranges.simple:
        return list(family_motions(ranges, n, seed, (preset.theta_min, preset.theta_max)))
    sampler = qmc.LatinHypercube(d=4, optimization="random-cd", rng=np.random.default_rng(seed))
    unit = sampler.random(n)
    lo = np.array([ranges.start[0], ranges.depth[0], ranges.speed[0], ranges.dwell[0]])
    hi = np.array([ranges.start[1], ranges.depth[1], ranges.speed[1], ranges.dwell[1]])
    pts = qmc.scale(unit, lo, hi) if np.all(hi > lo) else lo + unit * (hi - lo)
    return [PressMotion(*(float(x) for x in p)) for p in pts]


def motion_parameters(spec: SuiteSpec, preset: HeadNeckPreset | ChainSuiteModel) -> list[SuiteMotion]:
    """The suite's motions: its M core motions (a seeded Latin hypercube over the ranges: every range
    is cut into M strata and each stratum holds exactly one motion), then the stress part's motions
    (a Latin hypercube of their own over the stress box, from a stream of the same seed), then the
    reference motions (the first of the core box's space-filling sequence for the seed,
    :func:`alcove.science.press_family.sequence_motion`)."""
    if spec.motions < 1:
        raise ValueError(f"validation suite motions: must be >= 1, got {spec.motions}")
    out = _draw(spec.ranges, spec.motions, spec.seed, preset, "validation suite")
    if spec.stress_motions > 0 and spec.stress is not None:
        out += _draw(spec.stress, spec.stress_motions, [spec.seed, 1], preset, "validation suite stress")
    theta = (preset.theta_min, preset.theta_max)
    return out + [sequence_motion(spec.ranges, spec.seed, i, theta) for i in range(spec.reference_motions)]


#: rad: the shallowest peak angle lies this far beyond first contact, the deepest start angle this far before it
CONTACT_MARGIN = 0.03
#: rad: the deepest peak angle lies this far inside the joint limit
LIMIT_MARGIN = 0.002
#: the histories a task-derived suite adds: an unload that gives back 30 % to all of the press, and
#: a re-load that goes none to all of the way back to the peak
HISTORY_RELEASE, HISTORY_RELOAD = (0.3, 1.0), (0.0, 1.0)


def task_ranges(
    model: HeadNeckPreset | ChainSuiteModel,
    theta_contact: float,
    start_angles: tuple[float, float] | None = None,
    top_speed: float | None = None,
) -> SuiteRanges:
    """The suite's box derived from a task (angles are the suite model's reference angle):

    * ``depth``: from ``CONTACT_MARGIN`` beyond first contact ``theta_contact`` to ``LIMIT_MARGIN``
      inside the joint limit: every depth the task's motions can press to;
    * ``start``: the default start angles widened to cover the task's initial angles
      ``start_angles`` (a ranged or fixed initial angle), at most ``CONTACT_MARGIN`` before first
      contact (the head starts clear of the cushion) and inside the joint range;
    * ``speed``: the default speeds, up to the task's fastest initial speed ``top_speed`` if higher;
    * ``dwell``: the default holds; ``release`` and ``reload``: the histories (``HISTORY_RELEASE``,
      ``HISTORY_RELOAD``).

    With the paper's preset this is the default box (0.15 to 0.28 rad, 0.34 to 0.43 rad, 0.3 to
    1.5 rad/s, 0 to 0.3 s) with the histories added."""
    base = SuiteRanges()
    start_lo, start_hi = base.start
    if start_angles is not None:
        start_lo, start_hi = min(start_lo, start_angles[0]), max(start_hi, start_angles[1])
    last_start = theta_contact - CONTACT_MARGIN
    start = (max(model.theta_min, min(start_lo, last_start)), min(start_hi, last_start))
    depth = (theta_contact + CONTACT_MARGIN, model.theta_max - LIMIT_MARGIN)
    speed = (base.speed[0], max(base.speed[1], top_speed or 0.0))
    return SuiteRanges(start, depth, speed, base.dwell, HISTORY_RELEASE, HISTORY_RELOAD)


def stress_ranges(core: SuiteRanges) -> SuiteRanges:
    """The stress part's box: the core's, with speeds beyond its top speed (up to twice it)."""
    return replace(core, speed=(core.speed[1], 2.0 * core.speed[1]))


def with_ranges(box: SuiteRanges, given: dict[str, tuple[float, float]]) -> SuiteRanges:
    """``box`` with the ranges a user set (by parameter name) in place of its own."""
    return replace(box, **given)


def press_trajectory(m: PressMotion, dt: float) -> Trajectory:
    """The motion sampled every ``dt`` (exact angular velocity)."""
    n = int(np.floor(m.duration / dt + 1e-9)) + 1
    t: FloatArray = dt * np.arange(n, dtype=np.float64)
    if t[-1] < m.duration - 1e-12:
        t = np.append(t, m.duration)
    tp, d = m.press_time, m.depth - m.start
    up, up_d = blend(t / tp)
    down, down_d = blend((t - tp - m.dwell) / tp)
    theta = m.start + d * (up - down)
    theta_dot = d * (up_d - down_d) / tp
    return Trajectory(t, theta, theta_dot)


def suite_trajectories(spec: SuiteSpec, preset: HeadNeckPreset) -> list[Trajectory]:
    return [m.trajectory(spec.dt) for m in motion_parameters(spec, preset)]


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


def chain_press_trajectory(m: SuiteMotion, dt: float, suite: ChainSuiteModel, pose: PoseFunction) -> Trajectory:
    """A suite motion of a chain: the motion's reference angle followed along the chain's joint
    line, with the head's pose from ``pose``."""
    ref = m.trajectory(dt)
    q, qd = suite.joints(ref.q[:, 0], ref.qd[:, 0])
    return Trajectory(ref.t, q, qd, model=pose)


SuiteModel = HeadNeckPreset | ChainSuiteModel


def suite_model_from_dict(data: dict[str, Any]) -> SuiteModel:
    """The model a suite stored (:meth:`HeadNeckPreset.to_dict` or :meth:`ChainSuiteModel.to_dict`)."""
    if "chain_suite" in data:
        return ChainSuiteModel.from_dict(data)
    return HeadNeckPreset.from_dict(data)


__all__ = [
    "FIRST_BUDGET",
    "PARTS",
    "ChainSuiteModel",
    "PressMotion",
    "SuiteMotion",
    "SuiteRanges",
    "SuiteSpec",
    "chain_press_trajectory",
    "chain_suite_model",
    "motion_parameters",
    "press_trajectory",
    "reference_budgets",
    "stress_ranges",
    "suite_model_from_dict",
    "suite_motion",
    "suite_trajectories",
    "task_ranges",
    "with_ranges",
]
