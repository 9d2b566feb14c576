"""Rigid indenters and node-to-surface penalty contact with regularized Coulomb friction.

A rigid body is a shape in its own body frame (x, z) placed in the headrest frame H by a
planar pose ``(r, angle)``: a body point ``l`` sits at ``r + rot2(angle) @ l`` (the
convention of ``alcove.science.geometry``). ``closest(l)`` returns the signed distance
``g`` of body-frame points from the body surface (``g < 0``: inside, i.e. penetrating),
the outward unit normal and the unit tangent at the closest surface point.

Per surface node i of the cushion (tributary length ``L_i``, per unit out-of-plane width)
the incremental potential of one step is

    penalty:   k / 2 * L_i * min(g_i, 0)^2
    friction:  mu * fn_i * (sqrt(s_i^2 + eps^2) - eps)

where ``s_i`` is the tangential slip of the node relative to the body over the step
(measured in the body frame, so a rolling/sliding head is handled exactly) and ``fn_i``
the node's normal force at the end of the previous step (lagged, which keeps each step a
minimisation problem). ``eps`` = regularization velocity x dt: below it friction is
viscous-like, above it Coulomb (|f_t| -> mu fn).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from alcove.science.arrays import FloatArray


@dataclass(frozen=True)
class RigidEllipse:
    """Ellipse with centre (cx, cz) and semi-axes (ax, az) in the body frame (the head profile)."""

    cx: float
    cz: float
    ax: float
    az: float

    def closest(self, points: FloatArray, iterations: int = 4) -> tuple[FloatArray, FloatArray, FloatArray]:
        lx = points[:, 0] - self.cx
        lz = points[:, 1] - self.cz
        a, b = self.ax, self.az
        # Newton on f(s) = (l - p(s)) . p'(s) = 0 from the elliptic angle of l: converges
        # quadratically for the near-surface points that matter for contact
        s = np.arctan2(lz * a, lx * b)
        for _ in range(iterations):
            c, sn = np.cos(s), np.sin(s)
            px, pz = a * c, b * sn
            f = -(lx - px) * a * sn + (lz - pz) * b * c
            df = -(a * a * sn * sn + b * b * c * c) - (lx - px) * px - (lz - pz) * pz
            df = np.minimum(df, -(a * a * sn * sn + b * b * c * c))
            s = s - np.maximum(np.minimum(f / df, 0.3), -0.3)
        c, sn = np.cos(s), np.sin(s)
        nx, nz = b * c, a * sn
        norm = np.sqrt(nx * nx + nz * nz)
        nx, nz = nx / norm, nz / norm
        gap = (lx - a * c) * nx + (lz - b * sn) * nz
        normal = np.stack([nx, nz], -1)
        tangent = np.stack([-nz, nx], -1)
        return gap, normal, tangent


@dataclass(frozen=True)
class RigidHalfPlane:
    """The half-plane x <= 0 of the body frame (a flat rigid plate with outward normal +x)."""

    def closest(self, points: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        n = points.shape[0]
        normal = np.tile([1.0, 0.0], (n, 1))
        tangent = np.tile([0.0, 1.0], (n, 1))
        return points[:, 0].copy(), normal, tangent


def rotation(angle: float) -> FloatArray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


@dataclass
class ContactState:
    """Per surface node, evaluated at the current iterate."""

    gap: FloatArray  # (m,) signed distance [m]
    normal: FloatArray  # (m, 2) outward body normal in H
    tangent: FloatArray  # (m, 2) tangent in H
    slip: FloatArray  # (m,) tangential slip over the step [m]
    force: FloatArray  # (m, 2) force of the body on each cushion node, per unit width [N/m]
    stiffness: FloatArray  # (m, 2, 2) d(force on node)/d(node position), negated (a stiffness)
    energy: float  # penalty + friction incremental potential [J/m]
    normal_force: FloatArray  # (m,) penalty force magnitude [N/m]


@dataclass
class PenaltyContact:
    """Node-to-rigid-body penalty contact with lagged regularized Coulomb friction."""

    body: RigidEllipse | RigidHalfPlane
    lengths: FloatArray  # (m,) tributary lengths of the surface nodes [m]
    penalty: float  # [Pa/m]
    friction: float = 0.0
    slip_regularization: float = 1e-5  # [m]

    def evaluate(
        self,
        x: FloatArray,
        pose: tuple[FloatArray, float],
        local_prev: FloatArray | None,
        normal_force_prev: FloatArray | None,
        with_stiffness: bool = True,
    ) -> ContactState:
        r, angle = pose
        R = rotation(angle)
        local = (x - r) @ R
        gap, n_loc, t_loc = self.body.closest(local)
        normal = n_loc @ R.T
        tangent = t_loc @ R.T
        pen = np.minimum(gap, 0.0)
        kL = self.penalty * self.lengths
        fn = -kL * pen  # >= 0
        force = fn[:, None] * normal
        energy = 0.5 * float(np.sum(kL * pen**2))
        active = gap < 0
        stiff = np.zeros((x.shape[0], 2, 2))
        if with_stiffness:
            stiff += (kL * active)[:, None, None] * normal[:, :, None] * normal[:, None, :]
        slip = np.zeros_like(gap)
        if self.friction > 0 and local_prev is not None and normal_force_prev is not None:
            slip = np.einsum("ij,ij->i", local - local_prev, t_loc)
            eps = self.slip_regularization
            root = np.sqrt(slip**2 + eps**2)
            cap = self.friction * normal_force_prev
            energy += float(np.sum(cap * (root - eps)))
            force -= (cap * slip / root)[:, None] * tangent
            if with_stiffness:
                stiff += (cap * eps**2 / root**3)[:, None, None] * tangent[:, :, None] * tangent[:, None, :]
        return ContactState(gap, normal, tangent, slip, force, stiff, energy, fn)

    def local_coordinates(self, x: FloatArray, pose: tuple[FloatArray, float]) -> FloatArray:
        r, angle = pose
        return (x - r) @ rotation(angle)
