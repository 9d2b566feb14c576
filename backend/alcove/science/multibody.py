"""Planar serial chain of rigid links with revolute joints (Lagrangian mechanics).

Frames and sign conventions are those of :mod:`alcove.science.geometry`: world x forward,
z up, motion in the x-z plane, rotations about y. A planar angle is a *backward tilt*
``phi`` (rotation ``R_y(-phi)``), so the angular velocity of a body is ``omega_y = -phi_dot``.

Coordinates. ``q_0`` is the absolute angle of link 0 from the vertical; ``q_i`` (i >= 1) is
the angle of link i relative to link i-1, so link i has the absolute angle
``phi_i = q_0 + ... + q_i``. For the one-link head-neck preset ``q_0 = theta``.

The base frame sits at ``base`` (world x, z) tilted back by ``base_angle``, so link 0 has
the absolute angle ``phi_0 = base_angle + q_0`` (``base_angle = 0``: ``q_0`` is absolute).
Link i starts at its joint, points along its body z axis and carries its centre of gravity
at ``(com_x, com_distance)`` in its frame (x forward, z along the link); the next joint
sits at ``length`` along the axis. The *contact body* (the head) is rigidly attached to
link ``contact_link`` (default: the last): its frame origin is at ``contact_origin`` in that
link's frame (default: the link's centre of gravity, the head frame of the geometry
module) and it is tilted back by ``contact_angle`` relative to the link. It carries the
head profile ``profile``. The headrest frame H is fixed in space.

Joints may have passive elements: a linear spring ``-k_i (q_i - q_rest_i)`` (part of the
potential, so the chain stays a Lagrangian system) and a linear damper ``-c_i qd_i`` (a
non-conservative force, applied like the torques).

Equations of motion (L = T - V, V = gravity + springs)::

    M(q) qdd + C(q, qd) = tau + g(q) - c qd + J(q)^T w

with ``M`` the mass matrix, ``C = Mdot qd - dT/dq`` the Coriolis/centrifugal terms,
``g = -dV/dq`` the generalized gravity and spring force and ``w = [F; M]`` the contact force on the
contact body and its moment about the body frame origin, both in H. ``J`` (6 x n) maps joint
velocities to the body twist in H, ``[v; omega] = J qd``; by virtual power its transpose
maps the wrench to generalized forces.

Everything is written once with CasADi operations, which accept SX/MX symbols and numbers;
the NumPy entry points evaluate compiled ``casadi.Function`` objects over many samples.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import casadi as ca
import numpy as np

from alcove.science.arrays import FloatArray
from alcove.science.geometry import GRAVITY, HeadNeckPreset, HeadProfile, RelativeKinematics
from alcove.science.symbolic import Symbolic


@dataclass(frozen=True)
class Link:
    """A rigid link: mass [kg], joint-to-next-joint length [m], COG distance from its joint
    along the link axis [m], moment of inertia about its COG [kg m^2] and the COG's forward
    offset from the link axis [m] (``com_x``)."""

    mass: float
    com_distance: float
    inertia_com: float
    length: float = 0.0
    com_x: float = 0.0

    def __post_init__(self) -> None:
        if not self.mass > 0:
            raise ValueError(f"mass: must be > 0, got {self.mass}")
        if not self.inertia_com >= 0:
            raise ValueError(f"inertia_com: must be >= 0, got {self.inertia_com}")


@dataclass(frozen=True)
class Headrest:
    """Headrest frame H: world (x, z) of its origin and its backward tilt [rad] (x_H = normal)."""

    origin: tuple[float, float] = (0.0, 0.0)
    tilt: float = 0.0


@dataclass(frozen=True, eq=False)
class PlanarChain:
    """A planar serial chain of ``n >= 1`` links with joint ranges and torque limits."""

    links: tuple[Link, ...]
    q_min: tuple[float, ...]
    q_max: tuple[float, ...]
    torque_limit: tuple[float, ...]
    gravity: float = GRAVITY
    base: tuple[float, float] = (0.0, 0.0)
    headrest: Headrest = field(default_factory=Headrest)
    base_angle: float = 0.0
    #: joint springs k_i [N m/rad] about q_rest_i [rad] and dampers c_i [N m s/rad]; None: none
    stiffness: tuple[float, ...] | None = None
    q_rest: tuple[float, ...] | None = None
    damping: tuple[float, ...] | None = None
    #: the contact body: index of the link carrying it (negative: from the end), its origin
    #: in that link's frame (None: the link's COG), its backward tilt relative to the link
    contact_link: int = -1
    contact_origin: tuple[float, float] | None = None
    contact_angle: float = 0.0
    profile: HeadProfile = field(default_factory=HeadProfile)

    def __post_init__(self) -> None:
        n = len(self.links)
        if n < 1:
            raise ValueError("links: a chain needs at least one link")
        for name in ("q_min", "q_max", "torque_limit", "stiffness", "q_rest", "damping"):
            value = getattr(self, name)
            if value is not None and len(value) != n:
                raise ValueError(f"{name}: expected {n} values, got {len(value)}")
        for name in ("stiffness", "damping"):
            value = getattr(self, name)
            if value is not None and any(not v >= 0 for v in value):
                raise ValueError(f"{name}: every value must be >= 0")
        if not -n <= self.contact_link < n:
            raise ValueError(f"contact_link: must index one of the {n} links, got {self.contact_link}")
        for i, (lo, hi) in enumerate(zip(self.q_min, self.q_max, strict=False)):
            if not lo < hi:
                raise ValueError(f"q_min[{i}]: must be below q_max[{i}] ({lo} >= {hi})")
        if any(not t > 0 for t in self.torque_limit):
            raise ValueError("torque_limit: every limit must be > 0")

    # ---- construction --------------------------------------------------------------
    @classmethod
    def from_preset(cls, preset: HeadNeckPreset) -> PlanarChain:
        """The 1-DOF head-neck chain (q_0 = theta) with the preset's headrest."""
        o = preset.headrest_origin
        head = Link(preset.mass, preset.com_distance, preset.inertia_com, preset.com_distance)
        return cls(
            links=(head,),
            q_min=(preset.theta_min,),
            q_max=(preset.theta_max,),
            torque_limit=(preset.torque_limit,),
            gravity=preset.gravity,
            headrest=Headrest((float(o[0]), float(o[1])), preset.tilt),
            profile=preset.profile,
        )

    @property
    def ndof(self) -> int:
        return len(self.links)

    # ---- kinematics (CasADi expressions of SX or MX symbols) ------------------------
    # Terms whose parameter is zero are left out (not multiplied by 0), so the default
    # chain is the same expression graph as before these options existed: the 1-DOF preset
    # gives bit-identical numbers.
    def angles(self, q: Symbolic) -> list[Symbolic]:
        """Absolute angles phi_i of the links (list of scalars)."""
        out = [q[0] + self.base_angle if self.base_angle else q[0]]
        for i in range(1, self.ndof):
            out.append(out[-1] + q[i])
        return out

    @staticmethod
    def _point(joint: Symbolic | ca.DM, phi: Symbolic, x: float, z: float) -> Symbolic:
        """World (x, z) of the point (x, z) of a link frame at ``joint`` with angle ``phi``."""
        axis = ca.vertcat(-ca.sin(phi), ca.cos(phi))  # rot2(phi) @ (0, 1)
        out = joint + z * axis
        if x:
            out = out + x * ca.vertcat(ca.cos(phi), ca.sin(phi))  # rot2(phi) @ (1, 0)
        return out

    def joint_positions(self, q: Symbolic) -> list[Symbolic | ca.DM]:
        """World (x, z) of every joint and of the end of the last link (list of n + 1 2x1)."""
        joint: ca.DM | Symbolic = ca.DM(self.base)
        out: list[Symbolic | ca.DM] = [joint]
        for link, phi in zip(self.links, self.angles(q), strict=True):
            joint = joint + link.length * ca.vertcat(-ca.sin(phi), ca.cos(phi))
            out.append(joint)
        return out

    def com_positions(self, q: Symbolic) -> list[Symbolic]:
        """World (x, z) of every link's COG (list of 2x1)."""
        joints = self.joint_positions(q)
        return [
            self._point(joint, phi, link.com_x, link.com_distance)
            for link, joint, phi in zip(self.links, joints, self.angles(q), strict=False)
        ]

    def potential_energy(self, q: Symbolic) -> Symbolic:
        """V(q) = sum m_i g z_i (zero at the height of the base joint) + sum k_i (q_i - q_rest_i)^2 / 2."""
        heights = [link.mass * self.gravity * c[1] for link, c in zip(self.links, self.com_positions(q), strict=True)]
        energy = heights[0]
        for height in heights[1:]:
            energy = energy + height
        if self.stiffness is not None and any(self.stiffness):
            rest = ca.DM(self.q_rest if self.q_rest is not None else [0.0] * self.ndof)
            energy = energy + 0.5 * ca.dot(ca.DM(self.stiffness), (q - rest) ** 2)
        return energy

    def damping_force(self, qd: Symbolic) -> Symbolic | None:
        """-c qd, the joint dampers' generalized force (None without dampers)."""
        if self.damping is None or not any(self.damping):
            return None
        return -ca.DM(self.damping) * qd

    def contact_pose_world(self, q: Symbolic) -> tuple[Symbolic, Symbolic]:
        """World (x, z) of the contact body frame origin and its absolute angle."""
        k = self.contact_link % self.ndof
        phi = self.angles(q)[k]
        if self.contact_origin is None:
            pos = self.com_positions(q)[k]
        else:
            pos = self._point(self.joint_positions(q)[k], phi, *self.contact_origin)
        return pos, (phi + self.contact_angle if self.contact_angle else phi)

    def generalized_contact_force_expr(self, q: Symbolic, wrench: Symbolic) -> Symbolic:
        """J(q)^T w for symbols."""
        return ca.mtimes(self._fn_jacobian(q).T, wrench)

    # ---- compiled functions ----------------------------------------------------------
    @cached_property
    def _sym(self) -> tuple[ca.SX, ca.SX]:
        return ca.SX.sym("q", self.ndof), ca.SX.sym("qd", self.ndof)

    @cached_property
    def _fn_mass(self) -> ca.Function:
        q, _ = self._sym
        M = ca.SX.zeros(self.ndof, self.ndof)
        for i, (link, c) in enumerate(zip(self.links, self.com_positions(q), strict=False)):
            Jv = ca.jacobian(c, q)
            Jw = ca.DM([[1.0 if j <= i else 0.0 for j in range(self.ndof)]])
            M += link.mass * ca.mtimes(Jv.T, Jv) + link.inertia_com * ca.mtimes(Jw.T, Jw)
        M = 0.5 * (M + M.T)
        return ca.Function("mass_matrix", [q], [ca.simplify(M)], ["q"], ["M"])

    @cached_property
    def _fn_relkin(self) -> ca.Function:
        q, qd = self._sym
        pos, phi = self.contact_pose_world(q)
        vel = ca.mtimes(ca.jacobian(pos, q), qd)
        phid = ca.jacobian(phi, q) @ qd
        beta = self.headrest.tilt
        cb, sb = math.cos(beta), math.sin(beta)
        rel = pos - ca.DM(self.headrest.origin)
        # world -> headrest: rot2(-beta)
        r_rel = ca.vertcat(cb * rel[0] + sb * rel[1], 0, -sb * rel[0] + cb * rel[1])
        v_rel = ca.vertcat(cb * vel[0] + sb * vel[1], 0, -sb * vel[0] + cb * vel[1])
        c, s = ca.cos(phi - beta), ca.sin(phi - beta)
        T_rel = ca.vertcat(ca.horzcat(c, 0, -s), ca.horzcat(0, 1, 0), ca.horzcat(s, 0, c))
        omega_rel = ca.vertcat(0, -phid, 0)
        return ca.Function(
            "relative_kinematics",
            [q, qd],
            [r_rel, v_rel, T_rel, omega_rel],
            ["q", "qd"],
            ["r_rel", "v_rel", "T_rel", "omega_rel"],
        )

    @cached_property
    def _fn_jacobian(self) -> ca.Function:
        q, qd = self._sym
        _, v_rel, _, omega_rel = self._fn_relkin.call([q, qd])
        J = ca.vertcat(ca.jacobian(v_rel, qd), ca.jacobian(omega_rel, qd))
        return ca.Function("contact_jacobian", [q], [J], ["q"], ["J"])

    @cached_property
    def mass_matrix(self) -> ca.Function:
        """M(q) as a casadi.Function (q -> M)."""
        return self._fn_mass

    @cached_property
    def coriolis(self) -> ca.Function:
        """C(q, qd) = Mdot qd - dT/dq as a casadi.Function."""
        q, qd = self._sym
        M = self._fn_mass(q)
        T = 0.5 * ca.dot(qd, ca.mtimes(M, qd))
        C = ca.mtimes(ca.jacobian(ca.mtimes(M, qd), q), qd) - ca.gradient(T, q)
        return ca.Function("coriolis", [q, qd], [C], ["q", "qd"], ["C"])

    @cached_property
    def gravity_force(self) -> ca.Function:
        """Generalized gravity (and joint spring) force g(q) = -dV/dq (on the right-hand side of the EOM)."""
        q, _ = self._sym
        return ca.Function("gravity_force", [q], [-ca.gradient(self.potential_energy(q), q)], ["q"], ["g"])

    @cached_property
    def lagrangian(self) -> ca.Function:
        q, qd = self._sym
        L = 0.5 * ca.dot(qd, ca.mtimes(self._fn_mass(q), qd)) - self.potential_energy(q)
        return ca.Function("lagrangian", [q, qd], [L], ["q", "qd"], ["L"])

    @cached_property
    def energy(self) -> ca.Function:
        q, qd = self._sym
        E = 0.5 * ca.dot(qd, ca.mtimes(self._fn_mass(q), qd)) + self.potential_energy(q)
        return ca.Function("energy", [q, qd], [E], ["q", "qd"], ["E"])

    @cached_property
    def relative_kinematics_function(self) -> ca.Function:
        """(q, qd) -> (r_rel, v_rel, T_rel, omega_rel) of the contact body in H (callable on
        SX/MX symbols: the symbolic kinematics a surrogate needs for this chain)."""
        return self._fn_relkin

    @cached_property
    def head_pose_function(self) -> ca.Function:
        """(q, qd) -> [x, z, angle, vx, vz, omega] (6x1) of the contact body in H: its origin's
        position and velocity along x_H and z_H [m, m/s], its tilt relative to the headrest
        (backward positive) and that tilt's rate [rad, rad/s] (``omega = -omega_y``)."""
        q, qd = self._sym
        _, phi = self.contact_pose_world(q)
        r_rel, v_rel, _, _ = self._fn_relkin.call([q, qd])
        angle = phi - self.headrest.tilt
        rate = ca.jtimes(angle, q, qd)
        out = ca.vertcat(r_rel[0], r_rel[2], angle, v_rel[0], v_rel[2], rate)
        return ca.Function("head_pose", [q, qd], [out], ["q", "qd"], ["pose"])

    @cached_property
    def contact_jacobian(self) -> ca.Function:
        """q -> J (6 x n) with [v_rel; omega_rel] = J qd in H."""
        return self._fn_jacobian

    @cached_property
    def forward_dynamics(self) -> ca.Function:
        """(q, qd, tau, wrench) -> qdd."""
        q, qd = self._sym
        tau = ca.SX.sym("tau", self.ndof)
        w = ca.SX.sym("wrench", 6)
        rhs = tau + self.gravity_force(q) + ca.mtimes(self._fn_jacobian(q).T, w) - self.coriolis(q, qd)
        damping = self.damping_force(qd)
        if damping is not None:
            rhs = rhs + damping
        qdd = ca.solve(self._fn_mass(q), rhs)
        return ca.Function("forward_dynamics", [q, qd, tau, w], [qdd], ["q", "qd", "tau", "wrench"], ["qdd"])

    # ---- NumPy evaluation ---------------------------------------------------------
    def _as_samples(self, x: FloatArray) -> FloatArray:
        x = np.asarray(x, float)
        if x.ndim == 0 or (x.ndim == 1 and self.ndof == 1):
            x = x.reshape(-1, 1)
        elif x.ndim == 1:
            x = x.reshape(1, -1)
        if x.shape[1] != self.ndof:
            raise ValueError(f"q: expected {self.ndof} columns, got {x.shape[1]}")
        return x

    def relative_kinematics(self, q: FloatArray, qd: FloatArray) -> RelativeKinematics:
        """NumPy relative kinematics for samples q, qd of shape (n, ndof) (or (n,) for 1 DOF)."""
        q, qd = self._as_samples(q), self._as_samples(qd)
        n = q.shape[0]
        r, v, T, w = (np.asarray(out) for out in self._fn_relkin.map(n).call([q.T, qd.T]))
        return RelativeKinematics(r_rel=r.T, v_rel=v.T, T_rel=T.reshape(3, n, 3).transpose(1, 0, 2), omega_rel=w.T)

    def head_pose(self, q: FloatArray, qd: FloatArray) -> FloatArray:
        """The contact body's planar pose and twist in H for samples: (n, 6) with the columns
        ``head_x, head_z, head_angle, head_vx, head_vz, head_omega`` (m, rad, m/s, rad/s)."""
        q, qd = self._as_samples(q), self._as_samples(qd)
        pose: FloatArray = np.asarray(self.head_pose_function.map(q.shape[0])(q.T, qd.T)).T
        return pose

    def generalized_contact_force(self, q: FloatArray, wrench: FloatArray) -> FloatArray:
        """J(q)^T w for samples: q (n, ndof), wrench (n, 6) -> (n, ndof)."""
        q = self._as_samples(q)
        wrench = np.asarray(wrench, float).reshape(-1, 6)
        J = np.asarray(self._fn_jacobian.map(q.shape[0])(q.T)).reshape(6, q.shape[0], self.ndof).transpose(1, 0, 2)
        forces: FloatArray = np.einsum("nij,ni->nj", J, wrench)
        return forces


__all__ = ["Headrest", "Link", "PlanarChain"]
