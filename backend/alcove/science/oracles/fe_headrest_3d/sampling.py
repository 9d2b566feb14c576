"""Which outputs ccx computes, and the interpolation that fills in the others.

Every computed output ends a ccx increment (``*TIME POINTS``), so the outputs ccx computes
bound its work from below. Where the motion and the force are smooth, a few computed outputs
and an interpolant give the others; where the force changes fast, every output is computed:

* around a **first touch or a separation** of the undeformed head (a single foam node's force
  grows from 0 like Hertz's d^1.5), and around every **stop or reversal** of the head's
  motion (x, z, rotation, indentation) while it is near the cushion: friction flips within a
  stick distance there and the force-time curve has a kink. Within ``stride`` outputs of such
  an event every output is computed;
* elsewhere every ``stride``-th output, refined by an **error estimate**: the same interpolant
  is applied to a force proxy known before the run, the undeformed head's indentation d to the
  power 3/2 (Hertz), and an interval is halved while the interpolated proxy deviates from the
  true one by more than ``tolerance`` x its peak anywhere inside.

The interpolant is scipy's modified Akima spline (``makima``): cubic and local (a kink or a
dense window does not ring into the neighbouring intervals, unlike a global cubic spline), and
it reproduces the computed outputs exactly (second-order accurate between them; on the forces the
interpolation error is of the order of the contact's own output-to-output noise, measured in
docs/fe-oracle.md). Where the undeformed head is clear of the cushion
an interpolated output is exactly 0: the foam is elastic and the contact rate independent, so
nothing touches a head that is clear of the undeformed cushion.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import Akima1DInterpolator

from alcove.science.arrays import FloatArray, IndexArray

#: a pose or indentation change per output below this counts as standing still [m or rad]
STILL = 1e-9
#: outputs computed on either side of a first touch, separation, stop or reversal
EVENT_HALF_WIDTH = 1


def interpolate(t_known: FloatArray, values: FloatArray, t: FloatArray) -> FloatArray:
    """``values`` (k, ...) at ``t_known`` (increasing) interpolated to ``t`` (inside their span)."""
    if len(t_known) < 3:  # makima needs 3 points; 2 give a straight line
        return (
            np.stack([np.interp(t, t_known, v) for v in np.moveaxis(values, -1, 0)], -1)
            if values.ndim > 1
            else (np.interp(t, t_known, values))
        )
    out: FloatArray = Akima1DInterpolator(t_known, values, method="makima", axis=0)(t)
    return out


def _events(depth: FloatArray, pose: FloatArray, near: np.ndarray) -> IndexArray:
    """Output indices of first touches, separations, stops and reversals near the cushion."""
    touching = depth > 0.0
    events = [np.flatnonzero(touching[1:] != touching[:-1]) + 1]
    for signal in (*pose.T, depth):
        step = np.diff(signal)
        direction = np.sign(step) * (np.abs(step) > STILL)
        change = np.flatnonzero(direction[1:] != direction[:-1]) + 1
        events.append(change[near[change]])
    return np.unique(np.concatenate(events)).astype(np.int64)


def computed_outputs(t: FloatArray, depth: FloatArray, pose: FloatArray, stride: int, tolerance: float) -> IndexArray:
    """Indices of the outputs ccx computes (the first and the last always).

    ``t`` (n,) output times; ``depth`` (n,) the undeformed head's indentation of the undeformed
    cushion (negative: clear); ``pose`` (n, 3) the head's x, z and rotation; ``stride`` the
    largest spacing of computed outputs [outputs]; ``tolerance`` the refinement criterion,
    relative to the proxy's peak.
    """
    n = len(t)
    if stride <= 1 or n <= 2:
        return np.arange(n, dtype=np.int64)
    keep = np.zeros(n, bool)
    keep[::stride] = True
    keep[-1] = True
    near = np.convolve(depth > 0.0, np.ones(2 * stride + 1), "same") > 0  # within stride outputs of contact
    # the windows leave out outputs where the head is clear (their force is 0) but the one next to contact
    touching = depth > 0.0
    edge = touching | np.r_[touching[1:], False] | np.r_[False, touching[:-1]]
    for e in _events(depth, pose, near):
        window = slice(max(0, e - EVENT_HALF_WIDTH), e + EVENT_HALF_WIDTH + 1)
        keep[window] |= edge[window]
    proxy = np.maximum(depth, 0.0) ** 1.5
    scale = float(proxy.max())
    if scale > 0.0:
        while True:
            idx = np.flatnonzero(keep)
            error = np.abs(interpolate(t[idx], proxy[idx], t) - proxy)
            worst = np.maximum.reduceat(error, idx[:-1])  # the largest error in [idx[j], idx[j + 1])
            split = [
                (a + b) // 2
                for a, b, e in zip(idx[:-1], idx[1:], worst, strict=True)
                if b - a > 1 and e > tolerance * scale
            ]
            if not split:
                break
            keep[split] = True
    return np.flatnonzero(keep).astype(np.int64)


__all__ = ["computed_outputs", "interpolate"]
