"""The paper's auxiliary penalty contact model (eqs. for f_i, F_aux, M_aux).

    f = k p^2 + pdot d0 (1 - exp(-|p| / p_ref)),   F = f n if p > 0 and f > 0 else 0,
    M = r_sp x F

for one point ``r_sp`` of the head (head frame) against the headrest plane (outward
normal n = x_H). p is the penetration of the point into the plane, pdot its rate.

Units. The paper gives k = 6 N/mm^2, d0 = 0.1 Ns/mm^2, p_ref = 2 mm and evaluates the
formula with p in mm and pdot in mm/s. The stiffness term is consistent (mm^2 * N/mm^2 =
N); the damping term with d0 in "Ns/mm^2" is not (it yields N/mm), so we take the formula
as evaluated in the paper's unit system, i.e. d0 acts as 0.1 N s/mm. In SI:
k = 6e6 N/m^2, d0 = 100 N s/m, p_ref = 0.002 m. ``tests/science/oracles`` checks
hand-computed values in both unit systems.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from alcove.science.geometry import HeadNeckPreset, RelativeKinematics
from alcove.science.oracles.base import OracleParams

K_PAPER_N_PER_MM2 = 6.0
D0_PAPER_NS_PER_MM = 0.1
P_REF_PAPER_MM = 2.0


class AuxPenaltyParams(OracleParams):
    """Parameters of the auxiliary penalty model, in SI units."""

    k: float = Field(K_PAPER_N_PER_MM2 * 1e6, gt=0, le=1e9, description="quadratic stiffness k [N/m^2] (paper: 6 N/mm^2)")
    d0: float = Field(D0_PAPER_NS_PER_MM * 1e3, ge=0, le=1e5, description="damping d0 [N s/m] (paper: 0.1, evaluated in N, mm, s)")
    p_ref: float = Field(P_REF_PAPER_MM * 1e-3, gt=0, le=0.1, description="reference penetration p_ref [m] (paper: 2 mm)")
    r_sp: tuple[float, float, float] | None = Field(
        None, description="contact point in the head frame [m]; default: the back point of the head profile"
    )


def contact_point(preset: HeadNeckPreset, params: AuxPenaltyParams) -> np.ndarray:
    """The point r_sp in the head frame (3,)."""
    if params.r_sp is not None:
        return np.asarray(params.r_sp, float)
    bx, bz = preset.profile.back_point()
    return np.array([bx, 0.0, bz])


def aux_penalty_wrench(preset: HeadNeckPreset, params: AuxPenaltyParams, kin: RelativeKinematics) -> tuple[np.ndarray, np.ndarray]:
    """Force (n, 3) and moment about the head frame origin (n, 3), in the headrest frame."""
    r_sp = contact_point(preset, params)
    arm = np.einsum("nij,j->ni", kin.T_rel, r_sp)  # r_sp expressed in H
    point = kin.r_rel + arm
    point_vel = kin.v_rel + np.cross(kin.omega_rel, arm)
    normal = np.array([1.0, 0.0, 0.0])
    p = -(point @ normal)
    pdot = -(point_vel @ normal)
    f = params.k * p**2 + pdot * params.d0 * (1.0 - np.exp(-np.abs(p) / params.p_ref))
    active = (p > 0) & (f > 0)
    force = np.where(active[:, None], f[:, None] * normal[None, :], 0.0)
    moment = np.cross(arm, force)
    return force, moment
