"""Frames and geometry shared by the multibody model, the oracles and the surrogate.

This module is the single source of truth for where the head and the headrest are.
Everything here is pure NumPy (plus helpers that accept CasADi symbols) and imports
neither the web nor the database layer.

Conventions (all SI units: m, s, rad, N, N m)
---------------------------------------------
World frame W
    Origin at the C7/T1 joint. x forward (the way the face looks), z up, y = z x x
    (to the left). All motion is planar in the x-z plane; rotations are about y.

Head (contact body) frame B
    Origin at the head centre of gravity (COG). z_B along the head axis (from the joint
    to the COG), x_B forward. The head's absolute angle ``theta`` is measured from the
    vertical, positive *toward the headrest* (a backward tilt). In 3D the head
    orientation is ``R_WB = R_y(-theta)``.

Headrest frame H
    Fixed in space. Origin on the undeformed front surface of the cushion, x_H = outward
    surface normal (pointing from the cushion toward the head), z_H up along the
    surface, y_H = y_W. The headrest is tilted back by ``tilt`` rad: ``R_WH = R_y(-tilt)``.

Forces and moments reported by oracles and predicted by surrogates are the contact
force on the head and its moment about the head frame origin, expressed in H
(``fx, fy, fz, mx, my, mz``). A force that pushes the head away from the cushion has
``fx > 0``.

The planar angle of a body is its backward tilt; a rotation by a planar angle ``phi``
maps the local (x, z) coordinates to world coordinates as ``[[cos, -sin], [sin, cos]]``
applied to ``(x, z)`` with ``x -> x cos(phi) - z sin(phi)``, ``z -> x sin(phi) + z cos(phi)``
(this is R_y(-phi) restricted to the x-z plane).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from alcove.science.arrays import FloatArray

if TYPE_CHECKING:  # CasADi is imported only by the symbolic kinematics, when they are built
    from alcove.science.symbolic import Symbolic

GRAVITY = 9.81
#: rad: every body model's joints, and the headrest, tilt less than 90 degrees either way from the vertical
ANGLE_LIMIT = math.pi / 2
#: rad/s: the fastest joint rotation a model takes (head angular velocities in crashes peak at about 30-50 rad/s)
MAX_ANGULAR_VELOCITY = 100.0


def rot2(phi: float | FloatArray) -> FloatArray:
    """Planar rotation for a backward tilt ``phi`` acting on (x, z) column vectors.

    For an array ``phi`` of shape (n,), returns shape (n, 2, 2).
    """
    c, s = np.cos(phi), np.sin(phi)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


def rot3_from_tilt(phi: float | FloatArray) -> FloatArray:
    """3D rotation matrix R_y(-phi) (shape (3, 3) or (n, 3, 3))."""
    phi = np.asarray(phi, dtype=float)
    c, s = np.cos(phi), np.sin(phi)
    z, o = np.zeros_like(phi), np.ones_like(phi)
    return np.stack([np.stack([c, z, -s], -1), np.stack([z, o, z], -1), np.stack([s, z, c], -1)], -2)


@dataclass(frozen=True)
class HeadProfile:
    """Occipital contact profile of the head: an ellipse in head-frame (x, z) coordinates.

    Centre ``(cx, cz)`` and semi-axes ``ax`` (front-back) and ``az`` (up-down). The
    ellipse is not centred on the head frame origin, so the contact normal does not pass
    through the moment reference point and the moment is informative.

    Its most posterior point, where the head first touches the headrest, lies ``ax`` =
    9.5 cm behind and ``-cz`` = 5 cm below the head COG: the head COG is 2.2-4.3 cm above
    the Frankfort plane (Beier et al. 1980, 21 cadaver heads), while the occiput that bears
    on a headrest (around and below the inion) lies near the level of the ear canals, and
    headrests are only required to reach about the head COG height (FMVSS 202a), so the
    contact is on the lower back of the head (docs/fe-oracle.md).
    """

    cx: float = 0.0
    cz: float = -0.05
    ax: float = 0.095
    az: float = 0.110

    def back_point(self) -> FloatArray:
        """Most posterior point (-x_B direction) in head-frame (x, z)."""
        return np.array([self.cx - self.ax, self.cz])

    def points(self, n: int = 400, arc: tuple[float, float] = (0.5 * math.pi, 1.5 * math.pi)) -> FloatArray:
        """Sample ``n`` points (head-frame x, z) on the back half of the ellipse."""
        s = np.linspace(arc[0], arc[1], n)
        return np.stack([self.cx + self.ax * np.cos(s), self.cz + self.az * np.sin(s)], -1)


@dataclass(frozen=True)
class HeadNeckPreset:
    """The paper's 1-DOF head-neck model and its headrest (preset ``head-neck-1dof``).

    Anthropometry after de Leva (1996), 50th percentile male; all values editable.
    The headrest is placed so that the head first touches it at ``theta_contact``, then
    moved by ``headrest_offset`` along its outward normal x_H (positive: toward the head,
    which then touches it earlier; a scenario's "headrest offset"); ``tilt`` is the
    headrest's backward inclination.
    """

    mass: float = 5.0  # kg
    com_distance: float = 0.12  # m, joint -> head COG
    inertia_joint: float = 0.10  # kg m^2, about the joint
    theta_min: float = 0.032  # rad
    theta_max: float = 0.432  # rad
    theta0: float = 0.232  # rad, initial angle (at rest, not touching)
    torque_limit: float = 30.0  # N m
    gravity: float = GRAVITY
    theta_contact: float = 0.31  # rad, first contact with the undeformed headrest
    tilt: float = 0.31  # rad, headrest inclination (x_H = normal)
    headrest_offset: float = 0.0  # m, headrest moved along x_H from its theta_contact placement
    profile: HeadProfile = field(default_factory=HeadProfile)

    # ---- derived geometry -------------------------------------------------------
    @property
    def inertia_com(self) -> float:
        return self.inertia_joint - self.mass * self.com_distance**2

    @property
    def headrest_origin(self) -> FloatArray:
        """World (x, z) of the headrest frame origin: the head's back point at ``theta_contact``,
        moved by ``headrest_offset`` along the headrest normal x_H = (cos tilt, sin tilt)."""
        origin = self.head_point_world(self.profile.back_point(), self.theta_contact)
        if self.headrest_offset == 0.0:  # the paper's placement, bit for bit
            return origin
        normal = np.array([math.cos(self.tilt), math.sin(self.tilt)])
        moved: FloatArray = origin + self.headrest_offset * normal
        return moved

    def head_origin_world(self, theta: float) -> FloatArray:
        """World (x, z) of the head frame origin (COG) at the head angle ``theta``."""
        d = self.com_distance
        return np.array([-d * np.sin(theta), d * np.cos(theta)])

    def head_point_world(self, p_head: FloatArray, theta: float) -> FloatArray:
        """World (x, z) of a point given in head-frame (x, z)."""
        world: FloatArray = self.head_origin_world(theta) + rot2(theta) @ np.asarray(p_head, float)
        return world

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> HeadNeckPreset:
        data = dict(data)
        prof = data.pop("profile", None)
        obj = cls(**data)
        if prof is not None:
            obj = replace(obj, profile=HeadProfile(**prof))
        return obj


@dataclass(frozen=True)
class RelativeKinematics:
    """Head relative to the headrest, everything in the headrest frame H.

    Arrays have a leading time axis of length n.
    r_rel (n, 3), v_rel (n, 3), T_rel (n, 3, 3), omega_rel (n, 3).
    """

    r_rel: FloatArray
    v_rel: FloatArray
    T_rel: FloatArray
    omega_rel: FloatArray

    @property
    def angle(self) -> FloatArray:
        """Planar relative tilt (head tilt minus headrest tilt), shape (n,)."""
        return np.arctan2(-self.T_rel[:, 0, 2], self.T_rel[:, 0, 0])


def relative_kinematics(preset: HeadNeckPreset, theta: FloatArray, theta_dot: FloatArray) -> RelativeKinematics:
    """Relative kinematics of the head w.r.t. the headrest for the 1-DOF preset (NumPy)."""
    theta = np.atleast_1d(np.asarray(theta, float))
    theta_dot = np.atleast_1d(np.asarray(theta_dot, float))
    d = preset.com_distance
    beta = preset.tilt
    # world position/velocity of the head origin
    pos = np.stack([-d * np.sin(theta), d * np.cos(theta)], -1) - preset.headrest_origin
    vel = np.stack([-d * np.cos(theta) * theta_dot, -d * np.sin(theta) * theta_dot], -1)
    RT = rot2(-beta)  # world -> headrest
    pos_h = pos @ RT.T
    vel_h = vel @ RT.T
    n = theta.shape[0]
    zeros = np.zeros(n)
    r_rel = np.stack([pos_h[:, 0], zeros, pos_h[:, 1]], -1)
    v_rel = np.stack([vel_h[:, 0], zeros, vel_h[:, 1]], -1)
    T_rel = rot3_from_tilt(theta - beta)
    omega_rel = np.stack([zeros, -theta_dot, zeros], -1)
    return RelativeKinematics(r_rel=r_rel, v_rel=v_rel, T_rel=T_rel, omega_rel=omega_rel)


#: The contact body's planar pose and twist relative to the headrest, in H: its frame origin's
#: position and velocity along x_H and z_H [m, m/s], its tilt relative to the headrest
#: (backward positive, ``angle = phi - tilt``) and that tilt's rate [rad, rad/s]
#: (``omega_rel = (0, -head_omega, 0)``). The columns of a trajectory's pose (``Trajectory.pose``).
POSE_COLUMNS: tuple[str, ...] = ("head_x", "head_z", "head_angle", "head_vx", "head_vz", "head_omega")

#: ``(q (n, ndof), qd (n, ndof)) -> pose (n, 6)``: a model's head pose as a function of its joint state
PoseFunction = Callable[[FloatArray, FloatArray], FloatArray]


def kinematics_from_pose(pose: FloatArray) -> RelativeKinematics:
    """The relative kinematics (:class:`RelativeKinematics`) of planar head poses (n, 6): what
    the oracles, the auxiliary model and the surrogate's features read. For poses of the 1-DOF
    preset (:func:`preset_pose`) they are the same numbers, bit for bit, as
    :func:`relative_kinematics` (the same operations on the same values)."""
    pose = np.asarray(pose, float).reshape(-1, len(POSE_COLUMNS))
    zeros = np.zeros(pose.shape[0])
    return RelativeKinematics(
        r_rel=np.stack([pose[:, 0], zeros, pose[:, 1]], -1),
        v_rel=np.stack([pose[:, 3], zeros, pose[:, 4]], -1),
        T_rel=rot3_from_tilt(pose[:, 2]),
        omega_rel=np.stack([zeros, -pose[:, 5], zeros], -1),
    )


def pose_from_kinematics(kin: RelativeKinematics) -> FloatArray:
    """The planar pose (n, 6) of relative kinematics (the inverse of :func:`kinematics_from_pose`)."""
    pose: FloatArray = np.stack(
        [kin.r_rel[:, 0], kin.r_rel[:, 2], kin.angle, kin.v_rel[:, 0], kin.v_rel[:, 2], -kin.omega_rel[:, 1]], -1
    )
    return pose


def preset_pose(preset: HeadNeckPreset, q: FloatArray, qd: FloatArray) -> FloatArray:
    """The head pose (n, 6) of the 1-DOF preset at joint states q, qd ((n,) or (n, 1); ``q_0 = theta``),
    headrest offset included: ``head_angle = theta - tilt`` and ``head_omega = theta_dot``."""
    theta = np.asarray(q, float).reshape(-1)
    theta_dot = np.asarray(qd, float).reshape(-1)
    kin = relative_kinematics(preset, theta, theta_dot)
    pose: FloatArray = np.stack(
        [kin.r_rel[:, 0], kin.r_rel[:, 2], theta - preset.tilt, kin.v_rel[:, 0], kin.v_rel[:, 2], theta_dot], -1
    )
    return pose


@dataclass(frozen=True)
class PresetPose:
    """:func:`preset_pose` of one preset as a :data:`PoseFunction` (checking that the joint state
    has one column); ``preset`` tells an oracle the head's joint path (e.g. from first contact)."""

    preset: HeadNeckPreset

    def __call__(self, q: FloatArray, qd: FloatArray) -> FloatArray:
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        if q.ndim == 2 and q.shape[1] != 1:
            raise ValueError(f"q: the head-neck-1dof preset has 1 joint, got {q.shape[1]} columns")
        return preset_pose(self.preset, q, qd)


def preset_pose_function(preset: HeadNeckPreset) -> PresetPose:
    """:func:`preset_pose` for one preset (:class:`PresetPose`)."""
    return PresetPose(preset)


def kinematics_from_pose_symbolic(pose: Symbolic) -> tuple[Symbolic, Symbolic, Symbolic, Symbolic]:
    """CasADi version of :func:`kinematics_from_pose` for one pose (6 x 1, SX or MX)."""
    import casadi as ca

    c, s = ca.cos(pose[2]), ca.sin(pose[2])
    T_rel = ca.vertcat(ca.horzcat(c, 0, -s), ca.horzcat(0, 1, 0), ca.horzcat(s, 0, c))
    return (
        ca.vertcat(pose[0], 0, pose[1]),
        ca.vertcat(pose[3], 0, pose[4]),
        T_rel,
        ca.vertcat(0, -pose[5], 0),
    )


def profile_gap(profile: HeadProfile, pose: FloatArray) -> FloatArray:
    """Signed gap [m] between the head profile at planar poses (n, >= 3) and the undeformed
    headrest plane x_H = 0 (the closed form of :func:`signed_gap`, for any model's pose)."""
    pose = np.asarray(pose, float)
    c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
    gap: FloatArray = (
        pose[:, 0] + c * profile.cx - s * profile.cz - np.sqrt((profile.ax * c) ** 2 + (profile.az * s) ** 2)
    )
    return gap


def head_pose_in_headrest(preset: HeadNeckPreset, theta: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Planar pose of the head frame in H: (x, z) of its origin, shape (n, 2), and tilt (n,)."""
    kin = relative_kinematics(preset, theta, np.zeros_like(np.atleast_1d(theta)))
    return kin.r_rel[:, [0, 2]], np.atleast_1d(np.asarray(theta, float)) - preset.tilt


def signed_gap(preset: HeadNeckPreset, theta: float | FloatArray) -> FloatArray:
    """Signed gap [m] between the head profile and the undeformed headrest surface, along its normal x_H.

    The smallest x_H coordinate of the profile ellipse (the whole ellipse, in closed form):
    with the relative tilt ``a = theta - tilt`` and the head origin at ``r`` in H, a profile
    point (cx + ax cos s, cz + az sin s) has ``x_H = r_x + cos(a) (cx + ax cos s) - sin(a) (cz + az sin s)``,
    whose minimum over s is ``r_x + cos(a) cx - sin(a) cz - sqrt((ax cos a)^2 + (az sin a)^2)``.
    Positive: the head is clear of the cushion by that distance; zero at first contact
    (``theta_contact`` when ``tilt = theta_contact``); negative: the undeformed cushion is penetrated.
    Smooth in ``theta`` (the square root's argument is >= min(ax, az)^2 > 0).
    """
    theta = np.atleast_1d(np.asarray(theta, float))
    r, a = head_pose_in_headrest(preset, theta)
    pr = preset.profile
    c, s = np.cos(a), np.sin(a)
    gap: FloatArray = r[:, 0] + c * pr.cx - s * pr.cz - np.sqrt((pr.ax * c) ** 2 + (pr.az * s) ** 2)
    return gap


def signed_gap_symbolic(preset: HeadNeckPreset, theta: Symbolic) -> Symbolic:
    """CasADi version of :func:`signed_gap` for one scalar angle (SX or MX)."""
    import casadi as ca

    r_rel = relative_kinematics_symbolic(preset, theta, 0.0)[0]
    pr = preset.profile
    a = theta - preset.tilt
    c, s = ca.cos(a), ca.sin(a)
    return r_rel[0] + c * pr.cx - s * pr.cz - ca.sqrt((pr.ax * c) ** 2 + (pr.az * s) ** 2)


def first_contact_angle(preset: HeadNeckPreset) -> float:
    """The head angle [rad] at which the head profile first touches the undeformed headrest
    (the root of :func:`signed_gap`): ``theta_contact`` for the paper's placement
    (``headrest_offset = 0``, ``tilt = theta_contact``), earlier for a headrest moved toward
    the head. Found with SciPy's ``brentq`` within 1 rad either side of ``theta_contact``
    (the gap falls monotonically as the head tilts back there)."""
    from scipy.optimize import brentq

    if preset.headrest_offset == 0.0 and preset.tilt == preset.theta_contact:
        return preset.theta_contact

    def gap(theta: float) -> float:
        return float(signed_gap(preset, theta)[0])

    lo, hi = preset.theta_contact - 1.0, preset.theta_contact + 1.0
    if not gap(lo) > 0.0 > gap(hi):
        raise ValueError(f"no first contact within {lo:.3g}..{hi:.3g} rad (headrest offset {preset.headrest_offset} m)")
    return float(brentq(gap, lo, hi, xtol=1e-12))


DEFAULT_PRESET = HeadNeckPreset()

__all__ = [
    "DEFAULT_PRESET",
    "GRAVITY",
    "POSE_COLUMNS",
    "HeadNeckPreset",
    "HeadProfile",
    "PoseFunction",
    "PresetPose",
    "RelativeKinematics",
    "first_contact_angle",
    "head_pose_in_headrest",
    "kinematics_from_pose",
    "kinematics_from_pose_symbolic",
    "pose_from_kinematics",
    "preset_pose",
    "preset_pose_function",
    "profile_gap",
    "relative_kinematics",
    "relative_kinematics_symbolic",
    "rot2",
    "rot3_from_tilt",
    "signed_gap",
    "signed_gap_symbolic",
]


def relative_kinematics_symbolic(
    preset: HeadNeckPreset, theta: Symbolic, theta_dot: Symbolic | float
) -> tuple[Symbolic, Symbolic, Symbolic, Symbolic]:
    """CasADi (SX/MX) version of :func:`relative_kinematics` for one scalar state.

    Returns ``(r_rel (3,1), v_rel (3,1), T_rel (3,3), omega_rel (3,1))``; used to build
    feature maps and contact models inside the OCP.
    """
    import casadi as ca

    d = preset.com_distance
    beta = preset.tilt
    o = preset.headrest_origin
    px = -d * ca.sin(theta) - o[0]
    pz = d * ca.cos(theta) - o[1]
    vx = -d * ca.cos(theta) * theta_dot
    vz = -d * ca.sin(theta) * theta_dot
    cb, sb = math.cos(beta), math.sin(beta)
    # world -> headrest: rot2(-beta)
    r_rel = ca.vertcat(cb * px + sb * pz, 0, -sb * px + cb * pz)
    v_rel = ca.vertcat(cb * vx + sb * vz, 0, -sb * vx + cb * vz)
    a = theta - beta
    c, s = ca.cos(a), ca.sin(a)
    T_rel = ca.vertcat(ca.horzcat(c, 0, -s), ca.horzcat(0, 1, 0), ca.horzcat(s, 0, c))
    omega_rel = ca.vertcat(0, -theta_dot, 0)
    return r_rel, v_rel, T_rel, omega_rel
