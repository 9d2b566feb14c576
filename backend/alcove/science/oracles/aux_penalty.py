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

:class:`AuxPenaltyOracle` (type ``aux-penalty``) wraps the model as an oracle: it makes the
preliminary data set and is the fast oracle of the tests and the ``command`` examples.
"""

from __future__ import annotations

import time
from typing import Annotated, ClassVar

import numpy as np
from pydantic import Field

from alcove.science.arrays import FloatArray
from alcove.science.geometry import DEFAULT_PRESET, HeadNeckPreset, RelativeKinematics, kinematics_from_pose
from alcove.science.oracles.base import CancelCheck, OracleCancelled, OracleParams, OracleResult, posed_trajectory
from alcove.science.series import ForceSeries, Trajectory
from alcove.science.spec_checks import quantity

K_PAPER_N_PER_MM2 = 6.0
D0_PAPER_NS_PER_MM = 0.1
P_REF_PAPER_MM = 2.0


HeadCoordinate = Annotated[
    float, quantity("coordinate in the head frame", "m", ge=-0.5, le=0.5, why="a point of the head")
]


class AuxPenaltyParams(OracleParams):
    """Parameters of the auxiliary penalty model, in SI units."""

    k: Annotated[float, quantity("quadratic stiffness k", "N/m^2", gt=0, le=1e9, why="paper: 6 N/mm^2 = 6e6 N/m^2")] = (
        K_PAPER_N_PER_MM2 * 1e6
    )
    d0: Annotated[
        float,
        quantity("damping d0", "N s/m", ge=0, le=1e5, why="paper: 0.1, evaluated in N, mm, s, i.e. 100 N s/m"),
    ] = D0_PAPER_NS_PER_MM * 1e3
    p_ref: Annotated[float, quantity("reference penetration p_ref", "m", gt=0, le=0.1, why="paper: 2 mm")] = (
        P_REF_PAPER_MM * 1e-3
    )
    r_sp: tuple[HeadCoordinate, HeadCoordinate, HeadCoordinate] | None = Field(
        None,
        description="contact point (x, y, z) in the head frame [m], each -0.5 to 0.5; "
        "default: the back point of the head profile",
    )


def contact_point(preset: HeadNeckPreset, params: AuxPenaltyParams) -> FloatArray:
    """The point r_sp in the head frame (3,)."""
    if params.r_sp is not None:
        return np.asarray(params.r_sp, float)
    bx, bz = preset.profile.back_point()
    return np.array([bx, 0.0, bz])


def aux_penalty_wrench(
    preset: HeadNeckPreset, params: AuxPenaltyParams, kin: RelativeKinematics
) -> tuple[FloatArray, FloatArray]:
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


def penetration(
    preset: HeadNeckPreset, params: AuxPenaltyParams, kin: RelativeKinematics
) -> tuple[FloatArray, FloatArray]:
    """Penetration p (n,) of the point r_sp into the headrest plane and its rate pdot (n,) [m, m/s]."""
    arm = np.einsum("nij,j->ni", kin.T_rel, contact_point(preset, params))
    return -(kin.r_rel + arm)[:, 0], -(kin.v_rel + np.cross(kin.omega_rel, arm))[:, 0]


def dissipated_energy(t: FloatArray, p: FloatArray, pdot: FloatArray, fx: FloatArray, k: float) -> float:
    """Work done by the head on the contact minus the change of the stored energy k p^3 / 3 [J].

    The work is the trapezoidal integral of fx * pdot (fx is the gated force magnitude along
    the normal). Its rate is d0 (1 - exp(-p/p_ref)) pdot^2 >= 0 while the force acts and
    -k p^2 pdot > 0 while the gate withholds it (only possible when pdot < 0), so it is
    non-negative up to quadrature error.
    """
    stored_start, stored_end = (k * max(float(pi), 0.0) ** 3 / 3.0 for pi in (p[0], p[-1]))
    return float(np.trapezoid(fx * pdot, t) - (stored_end - stored_start))


class AuxPenaltyOracle:
    """The auxiliary penalty model as an oracle (type ``aux-penalty``): fast, closed form.

    Replays the contact body's pose (``Trajectory.pose``; a 1-joint trajectory without one is
    the head-neck-1dof preset's) and returns the force and moment at the trajectory's own time
    samples. ``preset`` gives the head profile (r_sp defaults to its back point). Diagnostics: the point's maximum
    penetration, the dissipated energy and the number of samples in contact; there are no
    Newton iterations.
    """

    type_name: ClassVar[str] = "aux-penalty"

    def __init__(self, params: AuxPenaltyParams | None = None, preset: HeadNeckPreset = DEFAULT_PRESET):
        self.params = params if params is not None else AuxPenaltyParams()
        self.preset = preset

    def run(self, trajectory: Trajectory, cancel: CancelCheck | None = None) -> OracleResult:
        start = time.perf_counter()
        if cancel is not None and cancel():
            raise OracleCancelled("aux-penalty run cancelled before it started")
        trajectory = posed_trajectory(trajectory, self.preset)
        assert trajectory.pose is not None
        kin = kinematics_from_pose(trajectory.pose)
        force, moment = aux_penalty_wrench(self.preset, self.params, kin)
        p, pdot = penetration(self.preset, self.params, kin)
        in_contact = force[:, 0] > 0
        diagnostics = {
            "max_penetration_m": max(float(p.max()), 0.0),
            "dissipated_energy_j": dissipated_energy(trajectory.t, p, pdot, force[:, 0], self.params.k),
            "newton_iterations": None,
            "contact_samples": int(in_contact.sum()),
            "first_contact_t": float(trajectory.t[in_contact][0]) if in_contact.any() else None,
        }
        return OracleResult(
            ok=True,
            forces=ForceSeries(trajectory.t, force, moment + 0.0),  # + 0.0: no "-0" in CSV files
            kinematics=kin,
            diagnostics=diagnostics,
            wall_time=time.perf_counter() - start,
        )
