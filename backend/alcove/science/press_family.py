"""A parameterised family of press motions with history: press, dwell, partial unload, re-load.

The validation suite's motions (:mod:`.validation_suite`) press the head into the headrest and let
it off again. The oracle's friction remembers the path (sticking, the direction of slip), so
motions that reach the same angle along different histories load the cushion differently; this
family adds the histories. A motion goes through the waypoints

* ``start`` (at rest), the press to ``depth``,
* a partial unload that gives back the share ``release`` of the press (``release`` 1: all the way
  back to ``start``, the suite's simple press),
* a re-load that goes the share ``reload`` of the way back from there towards ``depth``
  (``reload`` 0: none), and
* the return to ``start``,

each segment a quintic blend (zero velocity and acceleration at both ends) whose largest angular
velocity is ``speed``, with a hold of ``dwell`` at every turning point. Six numbers make a motion;
:func:`family_motions` draws them as a seeded Latin hypercube (``scipy.stats.qmc``) from the box
:class:`PressFamily`, so a set of motions is reproducible from the box, its size and the seed.
With ``release`` 1 (and so no re-load) a motion is exactly the suite's :class:`PressMotion` of the
same start, depth, speed and dwell.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from itertools import pairwise

import numpy as np
from scipy.stats import qmc

from alcove.science.arrays import FloatArray
from alcove.science.errors import FieldError
from alcove.science.series import Trajectory

PARAMETERS = ("start", "depth", "speed", "dwell", "release", "reload")

#: largest velocity of the quintic blend s^3 (10 - 15 s + 6 s^2) over [0, 1]
BLEND_PEAK = 15.0 / 8.0


def blend(s: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The quintic blend s^3 (10 - 15 s + 6 s^2) from 0 to 1 and its derivative, held at 0 before
    s = 0 and at 1 after s = 1 (zero velocity and acceleration at both ends)."""
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10 - 15 * s + 6 * s**2), 30 * s**2 * (1 - s) ** 2


@dataclass(frozen=True)
class HistoryPress:
    """One motion of the family (module docstring): angles [rad], speed [rad/s], dwell [s], and the
    shares ``release`` and ``reload`` in [0, 1]."""

    start: float
    depth: float
    speed: float
    dwell: float
    release: float = 1.0
    reload: float = 0.0

    def __post_init__(self) -> None:
        values = [getattr(self, f.name) for f in fields(self)]
        if not all(np.isfinite(values)):
            raise ValueError(f"press motion: every parameter must be finite, got {asdict(self)}")
        if self.depth <= self.start:
            raise ValueError(f"press motion: depth {self.depth} rad must lie beyond start {self.start} rad")
        if self.speed <= 0 or self.dwell < 0:
            raise ValueError(f"press motion: speed must be > 0 and dwell >= 0, got {self.speed}, {self.dwell}")
        for name in ("release", "reload"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"press motion: {name} must lie in [0, 1], got {getattr(self, name)}")

    def waypoints(self) -> list[float]:
        """The angles the motion turns at, from ``start`` back to ``start`` (no zero-length segment)."""
        points = [self.start, self.depth]
        if self.release < 1.0:
            released = self.depth - self.release * (self.depth - self.start)
            points.append(released)
            if self.reload > 0.0:
                points.append(released + self.reload * (self.depth - released))
        points.append(self.start)
        return [p for i, p in enumerate(points) if i == 0 or p != points[i - 1]]

    def segment_times(self) -> list[float]:
        """Each segment's duration [s]: the blend over angle D peaks at 15 D / (8 T) = ``speed``."""
        w = self.waypoints()
        return [BLEND_PEAK * abs(b - a) / self.speed for a, b in pairwise(w)]

    @property
    def duration(self) -> float:
        times = self.segment_times()
        return sum(times) + self.dwell * (len(times) - 1)

    def trajectory(self, dt: float) -> Trajectory:
        """The motion sampled every ``dt`` [s] and at its end (exact angle and angular velocity)."""
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"press motion: dt must be a positive number, got {dt}")
        n = int(np.floor(self.duration / dt + 1e-9)) + 1
        t: FloatArray = dt * np.arange(n, dtype=np.float64)
        if t[-1] < self.duration - 1e-12:
            t = np.append(t, self.duration)
        w, times = self.waypoints(), self.segment_times()
        theta = np.full_like(t, w[0])
        theta_dot = np.zeros_like(t)
        t0 = 0.0
        for a, b, tp in zip(w[:-1], w[1:], times, strict=True):
            # a blend contributes its full rise after its end, nothing before its start (the suite's form)
            pos, vel = blend((t - t0) / tp)
            theta += (b - a) * pos
            theta_dot += (b - a) * vel / tp
            t0 += tp + self.dwell
        return Trajectory(t, theta, theta_dot)


class RangeError(FieldError):
    """A range of the box that cannot make motions; ``parameter`` names it (``start`` .. ``reload``)."""

    def __init__(self, what: str, parameter: str, reason: str):
        self.what, self.parameter = what, parameter
        super().__init__(f"{what} range {parameter}", reason)

    def __reduce__(self) -> tuple[type[RangeError], tuple[str, str, str]]:  # type: ignore[override]
        return type(self), (self.what, self.parameter, self.reason)


@dataclass(frozen=True)
class PressFamily:
    """The box the family's motions are drawn from: a (low, high) range per parameter (equal ends: fixed)."""

    start: tuple[float, float] = (0.15, 0.28)  # rad
    depth: tuple[float, float] = (0.34, 0.43)  # rad
    speed: tuple[float, float] = (0.3, 1.5)  # rad/s
    dwell: tuple[float, float] = (0.0, 0.3)  # s
    release: tuple[float, float] = (0.3, 1.0)  # share of the press the unload gives back
    reload: tuple[float, float] = (0.0, 1.0)  # share of the way back to depth the re-load goes

    def check(self, theta_min: float, theta_max: float, what: str = "press family") -> None:
        """Raise :class:`RangeError` naming the range (``what range name``) that is empty, not finite,
        or leaves the joint range or [0, 1]."""
        for name in PARAMETERS:
            lo, hi = getattr(self, name)
            if not (np.isfinite(lo) and np.isfinite(hi)) or lo > hi:
                raise RangeError(what, name, f"need finite lo <= hi, got ({lo}, {hi})")
        for name in ("start", "depth"):
            lo, hi = getattr(self, name)
            if lo < theta_min or hi > theta_max:
                raise RangeError(what, name, f"({lo}, {hi}) rad leaves the joint range [{theta_min}, {theta_max}] rad")
        if self.speed[0] <= 0:
            raise RangeError(what, "speed", f"must be > 0, got ({self.speed[0]}, {self.speed[1]}) rad/s")
        if self.dwell[0] < 0:
            raise RangeError(what, "dwell", f"must be >= 0, got ({self.dwell[0]}, {self.dwell[1]}) s")
        if self.start[1] >= self.depth[0]:
            raise RangeError(
                what, "start", f"every start angle must lie below every peak angle (depth from {self.depth[0]} rad)"
            )
        for name in ("release", "reload"):
            lo, hi = getattr(self, name)
            if lo < 0 or hi > 1:
                raise RangeError(what, name, f"({lo}, {hi}) leaves [0, 1]")


def family_motions(
    family: PressFamily, n: int, seed: int | list[int], theta_range: tuple[float, float]
) -> list[HistoryPress]:
    """``n`` motions of the family: a seeded Latin hypercube over its box (every range cut into n strata,
    one motion in each; centred-discrepancy optimised like the suite's), checked against the joint
    range ``theta_range``; ``seed`` an integer or a list of them (NumPy's seed sequence entropy)."""
    if n < 1:
        raise ValueError(f"press family: the number of motions must be >= 1, got {n}")
    family.check(*theta_range)
    sampler = qmc.LatinHypercube(d=len(PARAMETERS), optimization="random-cd", rng=np.random.default_rng(seed))
    unit = sampler.random(n)
    lo = np.array([getattr(family, p)[0] for p in PARAMETERS])
    hi = np.array([getattr(family, p)[1] for p in PARAMETERS])
    points = lo + unit * (hi - lo)
    return [HistoryPress(*(float(x) for x in p)) for p in points]


#: separates the family's acquisition stream from every other stream of a campaign seed
SEQUENCE_SALT = 0x9E55


def sequence_motion(family: PressFamily, seed: int, index: int, theta_range: tuple[float, float]) -> HistoryPress:
    """Motion ``index`` (0, 1, 2, ...) of the family's space-filling sequence for ``seed``: point
    ``index`` of a scrambled Sobol sequence (``scipy.stats.qmc.Sobol``, seeded by ``seed``) scaled
    to the box. Unlike :func:`family_motions` the sequence can be extended one motion at a time and
    every prefix is spread over the box (a prefix of 2^m points holds one point in each of 2^m
    equal cells of the low-discrepancy nets), so an acquisition that asks for motions 0 .. n-1
    over several iterations gets a space-filling design of n motions whatever n is."""
    if index < 0:
        raise ValueError(f"press family: the motion index must be >= 0, got {index}")
    family.check(*theta_range)
    sampler = qmc.Sobol(d=len(PARAMETERS), scramble=True, rng=np.random.default_rng([int(seed), SEQUENCE_SALT]))
    if index:
        sampler.fast_forward(index)
    unit = sampler.random(1)[0]
    lo = np.array([getattr(family, p)[0] for p in PARAMETERS])
    hi = np.array([getattr(family, p)[1] for p in PARAMETERS])
    return HistoryPress(*(float(x) for x in lo + unit * (hi - lo)))


__all__ = [
    "BLEND_PEAK",
    "PARAMETERS",
    "HistoryPress",
    "PressFamily",
    "RangeError",
    "blend",
    "family_motions",
    "sequence_motion",
]
