"""The preliminary data set that starts the active learning loop (paper, "Active Learning Loop").

``K`` joint configurations and velocities are drawn with a Latin hypercube
(``scipy.stats.qmc.LatinHypercube``) over the joint range of the preset and a symmetric
velocity range, and evaluated with the auxiliary penalty model (the ``aux-penalty``
oracle's formula). Samples are independent points, so they are dealt into ``chunks``
datasets named ``preliminary-00``, ... of origin ``preliminary``: the 70/30 split by
simulation then holds out a share of them instead of all or nothing.

Default K: about 30 % of the samples over the preset's joint range touch the cushion;
``DEFAULT_SAMPLES = 4000`` gives ~1200 contact samples, enough for the default MLP pair
to fit the penalty force and moment to ~1-3 % of their range on fresh samples
(``tests/science/surrogate/test_surrogate_preliminary.py`` checks it).

A chain model (:func:`chain_preliminary_pool`) is sampled the same way over a joint box
(positions and velocities of every joint; :func:`chain_box`: the initial pose +- 0.2 rad per
joint within the joint range, as the 1-DOF preset's range is theta0 +- 0.2 rad), the wrench
computed from the head's pose; the box of a neck chain reaches far deeper into the cushion than any motion the oracle
can replay, so samples whose head would indent the undeformed cushion by more than
``max_indentation`` are left out (default 10 mm, about the reach of the 1-DOF preset's joint
range, 8.8 mm at theta_max: the penalty force k p^2 stays below 600 N, the range of the
1-DOF preliminary data, instead of the 3.5 kN at the FE oracle's 24 mm reach).
"""

from __future__ import annotations

import numpy as np
from scipy.stats import qmc

from alcove.science.arrays import FloatArray
from alcove.science.geometry import HeadNeckPreset, PoseFunction, kinematics_from_pose, profile_gap, relative_kinematics
from alcove.science.oracles.aux_penalty import AuxPenaltyParams, aux_penalty_wrench
from alcove.science.surrogate.dataset import PoolDataError, PoolDataset

DEFAULT_SAMPLES = 4000
DEFAULT_VELOCITY_BOUND = 2.0  # rad/s
DEFAULT_CHUNKS = 10


def preliminary_pool(
    preset: HeadNeckPreset,
    samples: int = DEFAULT_SAMPLES,
    velocity_bound: float | tuple[float, float] = DEFAULT_VELOCITY_BOUND,
    q_bounds: tuple[float, float] | None = None,
    params: AuxPenaltyParams | None = None,
    seed: int = 0,
    chunks: int = DEFAULT_CHUNKS,
) -> list[PoolDataset]:
    """Latin hypercube preliminary data for the 1-DOF preset (origin ``preliminary``).

    ``q_bounds`` defaults to the preset's range ``(theta_min, theta_max)``; velocities are
    drawn from ``[-velocity_bound, velocity_bound]``, or from ``[lo, hi]`` for a pair.
    """
    if not isinstance(samples, (int, np.integer)) or samples < 2:
        raise PoolDataError("samples", f"must be an integer >= 2, got {samples!r}")
    if isinstance(velocity_bound, (tuple, list)):
        v_lo, v_hi = (float(v) for v in velocity_bound)
        if not (np.isfinite(v_lo) and np.isfinite(v_hi) and v_lo < v_hi):
            raise PoolDataError("velocity_bound", f"must be finite with lower < upper, got ({v_lo!r}, {v_hi!r})")
    elif np.isfinite(velocity_bound) and velocity_bound > 0:
        v_lo, v_hi = -float(velocity_bound), float(velocity_bound)
    else:
        raise PoolDataError("velocity_bound", f"must be a positive number, got {velocity_bound!r}")
    lo, hi = q_bounds if q_bounds is not None else (preset.theta_min, preset.theta_max)
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
        raise PoolDataError("q_bounds", f"must be finite with lower < upper, got ({lo!r}, {hi!r})")
    if not 1 <= chunks <= samples // 2:
        raise PoolDataError("chunks", f"must lie in 1..{samples // 2} (at least two samples per dataset), got {chunks}")
    unit = qmc.LatinHypercube(d=2, rng=np.random.default_rng(seed)).random(samples)
    x = qmc.scale(unit, [lo, v_lo], [hi, v_hi])
    q, qd = x[:, 0], x[:, 1]
    force, moment = aux_penalty_wrench(preset, params or AuxPenaltyParams(), relative_kinematics(preset, q, qd))
    return _chunked(q, qd, force, moment, samples, chunks)


DEFAULT_MAX_INDENTATION = 0.010  # m
#: rad: a chain's box spans its initial pose +- this per joint (the 1-DOF preset's range is theta0 +- 0.2 rad)
CHAIN_HALF_WIDTH = 0.2


def chain_box(q0: FloatArray, q_min: FloatArray, q_max: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The joint box of a chain's preliminary data: ``q0 +- CHAIN_HALF_WIDTH`` within the joint range."""
    q0 = np.asarray(q0, float)
    return np.maximum(q_min, q0 - CHAIN_HALF_WIDTH), np.minimum(q_max, q0 + CHAIN_HALF_WIDTH)


def chain_preliminary_pool(
    pose: PoseFunction,
    preset: HeadNeckPreset,
    q_bounds: tuple[FloatArray, FloatArray],
    samples: int = DEFAULT_SAMPLES,
    velocity_bound: float = DEFAULT_VELOCITY_BOUND,
    params: AuxPenaltyParams | None = None,
    seed: int = 0,
    chunks: int = DEFAULT_CHUNKS,
    max_indentation: float = DEFAULT_MAX_INDENTATION,
) -> list[PoolDataset]:
    """Latin hypercube preliminary data for a chain of n joints: q and qd of every joint drawn
    from ``q_bounds`` (two arrays of n) and ``[-velocity_bound, velocity_bound]``, the head's pose
    from ``pose`` (``ModelSpec.pose_function()``), the wrench of the auxiliary penalty model
    (``preset``: the head profile, ``ModelSpec.oracle_preset()``). Samples whose head would
    indent the cushion by more than ``max_indentation`` [m] are left out: the hypercube is drawn
    four times as large and the first ``samples`` acceptable points kept."""
    lo, hi = (np.asarray(b, float).ravel() for b in q_bounds)
    n = lo.size
    if not (lo.size == hi.size >= 1 and np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(lo < hi)):
        raise PoolDataError("q_bounds", f"must be finite with lower < upper per joint, got ({lo!r}, {hi!r})")
    if not isinstance(samples, (int, np.integer)) or samples < 2:
        raise PoolDataError("samples", f"must be an integer >= 2, got {samples!r}")
    if not (np.isfinite(velocity_bound) and velocity_bound > 0):
        raise PoolDataError("velocity_bound", f"must be a positive number, got {velocity_bound!r}")
    if not 1 <= chunks <= samples // 2:
        raise PoolDataError("chunks", f"must lie in 1..{samples // 2} (at least two samples per dataset), got {chunks}")
    drawn = 4 * samples
    unit = qmc.LatinHypercube(d=2 * n, rng=np.random.default_rng(seed)).random(drawn)
    x = qmc.scale(
        unit, np.concatenate([lo, np.full(n, -velocity_bound)]), np.concatenate([hi, np.full(n, velocity_bound)])
    )
    q, qd = x[:, :n], x[:, n:]
    poses = pose(q, qd)
    keep = np.flatnonzero(profile_gap(preset.profile, poses) >= -max_indentation)
    if keep.size < samples:
        raise PoolDataError(
            "samples",
            f"only {keep.size} of {drawn} drawn samples indent the cushion by at most {max_indentation * 1e3:g} mm; "
            f"ask for at most {keep.size}",
        )
    keep = keep[:samples]
    q, qd, poses = q[keep], qd[keep], poses[keep]
    force, moment = aux_penalty_wrench(preset, params or AuxPenaltyParams(), kinematics_from_pose(poses))
    return _chunked(q, qd, force, moment, samples, chunks)


def _chunked(
    q: FloatArray, qd: FloatArray, force: FloatArray, moment: FloatArray, samples: int, chunks: int
) -> list[PoolDataset]:
    """The samples dealt round-robin into ``chunks`` preliminary datasets (sample i to chunk i mod chunks)."""
    pool = []
    for c in range(chunks):
        idx = np.arange(c, samples, chunks)
        pool.append(
            PoolDataset(
                f"preliminary-{c:02d}",
                np.arange(idx.size, dtype=float),
                q[idx],
                qd[idx],
                force[idx],
                moment[idx],
                origin="preliminary",
            )
        )
    return pool


__all__ = [
    "CHAIN_HALF_WIDTH",
    "DEFAULT_CHUNKS",
    "DEFAULT_MAX_INDENTATION",
    "DEFAULT_SAMPLES",
    "DEFAULT_VELOCITY_BOUND",
    "chain_box",
    "chain_preliminary_pool",
    "preliminary_pool",
]
