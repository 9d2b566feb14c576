"""The paper's 19 input features of the contact surrogate, in NumPy and CasADi.

From the relative kinematics of the head w.r.t. the headrest (all in the current
headrest frame H, see :mod:`alcove.science.geometry`), which are those of the contact body's
planar pose and twist (:func:`pose_features`; any chain's head, never a joint angle):

====================  ===  =========================================================
r_rel                  3   position of the head frame origin
v_rel                  3   its velocity
T6                     6   first two columns of T_rel (column-major: T00 T10 T20 T01 T11 T21)
omega_rel              3   relative angular velocity
|r_rel|^2, |v_rel|^2   2
alpha_rel^2            1   squared relative rotation angle, alpha = arccos((tr T - 1) / 2)
|omega_rel|^2          1
====================  ===  =========================================================

``alpha_rel^2`` is not computed with arccos, whose derivative is infinite at alpha = 0
(where the OCP needs gradients). With ``c = cos(alpha) = (tr T - 1)/2`` and
``s2 = sin(alpha)^2 = |vee(T - T^T)|^2 / 4`` we use ``alpha = atan2(sqrt(s2), c)`` away
from the identity and, for small angles (``s2 < SMALL_ANGLE_S2``, ``c > 0``), the series
``arcsin(x)^2 = x^2 + x^4/3 + 8 x^6/45 + 4 x^8/35 + ...`` in ``x^2 = s2``, which is smooth
with ``d(alpha^2)/d(s2) = 1`` at the identity. The two branches agree to ~1e-17 relative
at the switch.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, TypeVar

import numpy as np

from alcove.science.arrays import FloatArray
from alcove.science.geometry import RelativeKinematics, kinematics_from_pose

if TYPE_CHECKING:  # CasADi is imported only by the symbolic features, when they are built
    import casadi as ca

    from alcove.science.symbolic import Symbolic

    SeriesArgument = TypeVar("SeriesArgument", FloatArray, ca.SX, ca.MX)

FEATURE_NAMES: tuple[str, ...] = (
    "r_x", "r_y", "r_z",
    "v_x", "v_y", "v_z",
    "T_00", "T_10", "T_20", "T_01", "T_11", "T_21",
    "omega_x", "omega_y", "omega_z",
    "r_sq", "v_sq", "alpha_sq", "omega_sq",
)  # fmt: skip
N_FEATURES = len(FEATURE_NAMES)

#: below this value of sin(alpha)^2 (alpha < ~0.01 rad) the series branch is used
SMALL_ANGLE_S2 = 1e-4
# arcsin(x)^2 = sum_n (2x)^(2n) / (2 n^2 binom(2n, n)); coefficients of s2^1..s2^4
_ARCSIN_SQ_SERIES = (1.0, 1.0 / 3.0, 8.0 / 45.0, 4.0 / 35.0)


def _series(s2: SeriesArgument) -> SeriesArgument:
    """The truncated series of arcsin(sqrt(s2))^2 (Horner's scheme), for arrays or symbols."""
    out = s2 * _ARCSIN_SQ_SERIES[-1]
    for coef in reversed(_ARCSIN_SQ_SERIES[:-1]):
        out = (out + coef) * s2
    return out


def rotation_cos_sin2(T: FloatArray) -> tuple[FloatArray, FloatArray]:
    """cos(alpha) and sin(alpha)^2 of rotation matrices T (n, 3, 3)."""
    c = 0.5 * (np.trace(T, axis1=1, axis2=2) - 1.0)
    w = np.stack([T[:, 2, 1] - T[:, 1, 2], T[:, 0, 2] - T[:, 2, 0], T[:, 1, 0] - T[:, 0, 1]], -1)
    return c, 0.25 * np.sum(w**2, axis=1)


def alpha_squared(T: FloatArray) -> FloatArray:
    """Squared rotation angle of rotation matrices T (n, 3, 3), smooth at alpha = 0."""
    c, s2 = rotation_cos_sin2(np.asarray(T, float))
    small = (s2 < SMALL_ANGLE_S2) & (c > 0)
    with np.errstate(invalid="ignore"):
        large = np.arctan2(np.sqrt(s2), c) ** 2
    return np.where(small, _series(s2), large)


def features(kin: RelativeKinematics) -> FloatArray:
    """Feature matrix (n, 19) from a batch of relative kinematics."""
    r, v, T, w = (np.asarray(a, float) for a in (kin.r_rel, kin.v_rel, kin.T_rel, kin.omega_rel))
    T6 = np.concatenate([T[:, :, 0], T[:, :, 1]], axis=1)
    squares = np.stack([np.sum(r**2, 1), np.sum(v**2, 1), alpha_squared(T), np.sum(w**2, 1)], -1)
    return np.concatenate([r, v, T6, w, squares], axis=1)


def pose_features(pose: FloatArray) -> FloatArray:
    """Feature matrix (n, 19) of the contact body's planar poses and twists in H (n, 6; the columns
    :data:`alcove.science.geometry.POSE_COLUMNS`)."""
    return features(kinematics_from_pose(pose))


def alpha_squared_symbolic(T: Symbolic) -> Symbolic:
    """CasADi version of :func:`alpha_squared` for one 3x3 rotation (SX or MX)."""
    import casadi as ca

    c = 0.5 * (ca.trace(T) - 1.0)
    s2 = 0.25 * ((T[2, 1] - T[1, 2]) ** 2 + (T[0, 2] - T[2, 0]) ** 2 + (T[1, 0] - T[0, 1]) ** 2)
    small = ca.logic_and(s2 < SMALL_ANGLE_S2, c > 0)
    # if_else evaluates both branches but masks the untaken one (and its derivative), so
    # the infinite derivative of sqrt at s2 = 0 never reaches the result
    return ca.if_else(small, _series(s2), ca.atan2(ca.sqrt(s2), c) ** 2)


def features_symbolic(r_rel: Symbolic, v_rel: Symbolic, T_rel: Symbolic, omega_rel: Symbolic) -> Symbolic:
    """CasADi feature vector (19 x 1) from symbolic relative kinematics (as returned by
    :func:`alcove.science.geometry.relative_kinematics_symbolic`)."""
    import casadi as ca

    return ca.vertcat(
        r_rel,
        v_rel,
        T_rel[:, 0],
        T_rel[:, 1],
        omega_rel,
        ca.sumsqr(r_rel),
        ca.sumsqr(v_rel),
        alpha_squared_symbolic(T_rel),
        ca.sumsqr(omega_rel),
    )


__all__ = [
    "FEATURE_NAMES",
    "N_FEATURES",
    "SMALL_ANGLE_S2",
    "alpha_squared",
    "alpha_squared_symbolic",
    "features",
    "features_symbolic",
    "pose_features",
    "rotation_cos_sin2",
]
