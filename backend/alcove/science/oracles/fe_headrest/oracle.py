"""The ``fe-headrest-2d`` oracle: replay a head trajectory against a plane-strain FE cushion.

The head is rigid and follows the trajectory's pose exactly (``Trajectory.pose``, the
contact body's pose relative to the headrest, whatever the chain); its occipital profile is
the preset's ellipse. The cushion is
a hyperfoam block whose front face is the plane x_H = 0 and whose back face is tied to
the rigid headrest bar. Output: the contact force on the head and its moment about the
moment reference point (default: the head frame origin), both in the headrest frame H, at
every ``output_dt``; plus the relative kinematics used and run diagnostics. A run that
fails the quality gate returns ``ok=False`` with the reason and no force data.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from alcove.science.arrays import FloatArray
from alcove.science.geometry import (
    DEFAULT_PRESET,
    HeadNeckPreset,
    HeadProfile,
    PresetPose,
    first_contact_angle,
    kinematics_from_pose,
)
from alcove.science.oracles.base import (
    CancelCheck,
    OracleCancelled,
    OracleResult,
    check_contact_within_cushion,
    validated_head_trajectory,
)
from alcove.science.oracles.fe_headrest.contact import PenaltyContact, RigidEllipse
from alcove.science.oracles.fe_headrest.foam import Hyperfoam
from alcove.science.oracles.fe_headrest.mesh import CushionMesh, build_cushion_mesh
from alcove.science.oracles.fe_headrest.params import FEHeadrestParams
from alcove.science.oracles.fe_headrest.solver import CushionSolver, single_threaded_blas
from alcove.science.series import ForceSeries, Trajectory


@dataclass(frozen=True)
class Slice:
    """One plane-strain section through the head at out-of-plane offset y, of width ``width``."""

    profile: RigidEllipse
    width: float
    offset: float


def head_slices(preset: HeadNeckPreset, params: FEHeadrestParams) -> list[Slice]:
    """Sections of the head: its ellipse shrunk as an ellipsoid of half breadth ``head_half_breadth``."""
    pr = preset.profile
    if params.slices == 1:
        return [Slice(RigidEllipse(pr.cx, pr.cz, pr.ax, pr.az), params.out_of_plane_width, 0.0)]
    hb, n = params.head_half_breadth, params.slices
    out = []
    for k in range(n):  # strips over [0, hb], each standing for itself and its mirror image
        y = (k + 0.5) * hb / n
        shrink = math.sqrt(1.0 - (y / hb) ** 2)
        out.append(Slice(RigidEllipse(pr.cx, pr.cz, pr.ax * shrink, pr.az * shrink), 2.0 * hb / n, y))
    return out


def profile_indentation(profile: HeadProfile, pose: FloatArray) -> FloatArray:
    """Depth of the undeformed head profile (ellipse) below the cushion surface x_H = 0 (>= 0)
    at planar head poses (n, >= 3: head_x, head_z, head_angle, ...)."""
    pr = profile
    c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
    x_centre = pose[:, 0] + c * pr.cx - s * pr.cz
    reach = np.sqrt((pr.ax * c) ** 2 + (pr.az * s) ** 2)
    return np.maximum(0.0, reach - x_centre)


class FEHeadrestOracle:
    """Nonlinear plane-strain FE headrest oracle (``fe-headrest-2d``)."""

    type_name: ClassVar[str] = "fe-headrest-2d"

    def __init__(self, params: FEHeadrestParams | None = None, preset: HeadNeckPreset = DEFAULT_PRESET) -> None:
        self.params = params if params is not None else FEHeadrestParams()
        self.preset = preset
        p = self.params
        self.law = Hyperfoam(tuple(p.foam_mu), tuple(p.foam_alpha), tuple(p.foam_beta))
        self.mesh: CushionMesh = build_cushion_mesh(
            p.cushion_thickness,
            p.cushion_height,
            p.cushion_bottom,
            p.element_size_contact,
            p.element_size_far,
            p.contact_zone,
        )
        self.slices = head_slices(preset, p)

    # ---- input -------------------------------------------------------------------------
    def _validated(self, trajectory: Any) -> Trajectory:
        p = self.params
        traj, depth = validated_head_trajectory(
            trajectory,
            self.preset,
            p.output_dt,
            lambda pose: profile_indentation(self.preset.profile, pose),
            p.max_indentation_fraction * p.cushion_thickness,
        )
        self._check_contact_within_cushion(traj, depth)
        return traj

    def _check_contact_within_cushion(self, traj: Trajectory, depth: FloatArray) -> None:
        bottom = self.params.cushion_bottom
        check_contact_within_cushion(traj, depth, self.preset.profile, bottom, bottom + self.params.cushion_height)

    def _preload(
        self, solvers: list[CushionSolver], traj: Trajectory, dt: float
    ) -> tuple[list[float], str | None] | None:
        """A trajectory that starts with the head in the cushion starts from static equilibrium.

        The head is moved quasi-statically (no viscous stress) from first contact to the start
        pose, in steps of at most ~0.5 mm of indentation; the energy stored then is the initial
        energy of the balance. The path: for the 1-DOF preset's joint trajectory, the head's own
        (theta from first contact); for a pose alone, at the start orientation along the cushion
        normal -x_H. Returns None if the head starts clear.
        """
        assert traj.pose is not None
        pose_start = traj.pose[0]
        depth = float(profile_indentation(self.preset.profile, pose_start[None, :])[0])
        if depth <= 0.0:
            return None
        n = max(4, int(np.ceil(depth / 5e-4)))
        if isinstance(traj.model, PresetPose):
            theta_start = float(traj.q[0, 0])
            path = np.linspace(min(first_contact_angle(traj.model.preset), theta_start), theta_start, n + 1)[1:]
            poses = traj.model(path, np.zeros_like(path))
            r, a = poses[:, :2], poses[:, 2]
        else:
            steps = np.linspace(0.0, 1.0, n + 1)[1:]
            r = np.stack([pose_start[0] + depth * (1.0 - steps), np.full(n, pose_start[1])], -1)
            a = np.full(n, pose_start[2])
        stored, failure = [], None
        for j, solver in enumerate(solvers):
            viscosity, solver.viscosity = solver.viscosity, 0.0
            try:
                for k in range(n):
                    res = solver.step((r[k], float(a[k])), dt)
                    if not res.converged and failure is None:
                        failure = f"Newton did not converge while pressing the head to its initial pose (slice {j})"
            finally:
                solver.viscosity = viscosity
            solver.u_old = solver.u.copy()  # at rest at the start
            solver.u_older = solver.u.copy()
            stored.append(res.stored_energy)
        return stored, failure

    # ---- run -----------------------------------------------------------------------------
    def run(self, trajectory: Trajectory, cancel: CancelCheck | None = None) -> OracleResult:
        with single_threaded_blas():
            return self._run(trajectory, cancel)

    def _run(self, trajectory: Trajectory, cancel: CancelCheck | None) -> OracleResult:
        start = time.perf_counter()
        p = self.params
        traj = self._validated(trajectory)
        t0, t1 = float(traj.t[0]), float(traj.t[-1])
        n_out = math.floor((t1 - t0) / p.output_dt + 1e-9) + 1
        t_out = t0 + p.output_dt * np.arange(n_out, dtype=np.float64)
        n_fine = (n_out - 1) * p.substeps + 1
        dt = p.output_dt / p.substeps
        t_fine = np.minimum(t0 + dt * np.arange(n_fine), t1)
        fine = traj.resample(t_fine)
        assert fine.pose is not None
        r_all, a_all = fine.pose[:, :2], fine.pose[:, 2]

        solvers = [
            CushionSolver(
                self.mesh,
                self.law,
                PenaltyContact(
                    s.profile,
                    self.mesh.surface_lengths,
                    p.penalty,
                    p.friction,
                    p.friction_regularization_velocity * dt,
                ),
                viscosity=p.viscosity,
                newton_tol=p.newton_tolerance,
                max_iterations=p.newton_max_iterations,
            )
            for s in self.slices
        ]
        widths = np.array([s.width for s in self.slices])
        force = np.zeros((n_fine, 2))
        moment_origin = np.zeros(n_fine)  # about the head frame origin
        bar = np.zeros((n_fine, 2))
        bar_moment = np.zeros(n_fine)
        stored = np.zeros(n_fine)
        max_pen = 0.0
        it_total = it_max = 0
        visc = fric = 0.0
        contact_steps = 0
        first_contact: float | None = None
        failure: str | None = None
        stored_start = 0.0
        preload_steps = self._preload(solvers, fine, dt)
        if preload_steps is not None:
            failure = preload_steps[1]
            stored_start = float(sum(w * e for w, e in zip(widths, preload_steps[0], strict=False)))
        for k in range(n_fine if failure is None else 0):
            if cancel is not None and k % p.substeps == 0 and cancel():
                raise OracleCancelled(f"cancelled at t = {t_fine[k]:.4g} s")
            pose = (r_all[k], float(a_all[k]))
            touching = False
            for j, solver in enumerate(solvers):
                res = solver.step(pose, dt)
                w = widths[j]
                force[k] += w * res.force_on_body
                moment_origin[k] += w * res.moment_on_body
                bar[k] += w * res.bar_reaction
                bar_moment[k] += w * res.bar_moment
                stored[k] += w * res.stored_energy
                visc += w * res.viscous_dissipation
                fric += w * res.friction_dissipation
                it_total += res.iterations
                it_max = max(it_max, res.iterations)
                max_pen = max(max_pen, res.max_penetration)
                touching |= res.contact_nodes > 0
                if not res.converged and failure is None:
                    failure = (
                        f"Newton did not converge at t = {t_fine[k]:.4g} s (slice {j}, residual {res.residual:.3g})"
                    )
            if touching:
                contact_steps += 1
                if first_contact is None:
                    first_contact = float(t_fine[k])
            if failure is None and max_pen > p.max_penetration:
                failure = (
                    f"penetration {max_pen * 1e3:.3g} mm exceeds max_penetration {p.max_penetration * 1e3:.3g} mm "
                    f"at t = {t_fine[k]:.4g} s"
                )
            if failure is not None:
                break

        # energy balance: work done by the head on the cushion (trapezoid rule) vs stored energy
        dr = np.diff(r_all, axis=0)
        da = np.diff(a_all)
        f_mid = 0.5 * (force[1:] + force[:-1])
        m_mid = 0.5 * (moment_origin[1:] + moment_origin[:-1])
        work_steps = -np.einsum("ij,ij->i", f_mid, dr) + m_mid * da
        work = float(np.sum(work_steps))
        # energy scale of the run: the most work ever put in (a closed elastic cycle nets ~0)
        energy_scale = max(float(np.max(np.abs(np.cumsum(work_steps)), initial=0.0)) + stored_start, 1e-12)
        dissipated = work - (float(stored[-1]) - stored_start)
        peak = float(np.max(np.linalg.norm(force, axis=1)))
        mismatch = float(np.max(np.linalg.norm(force - bar, axis=1)))
        mismatch_moment = float(np.max(np.abs(moment_origin - bar_moment)))
        moment_scale = max(float(np.max(np.abs(moment_origin))), 0.1 * peak, 0.1)  # 0.1 m: a head-sized lever

        # outputs at output times, moment about the configured reference point
        idx = np.arange(n_out) * p.substeps
        r_out, a_out = r_all[idx], a_all[idx]
        if p.moment_point_frame == "head":
            c, s = np.cos(a_out), np.sin(a_out)
            mx, mz = p.moment_point
            ref = r_out + np.stack([c * mx - s * mz, s * mx + c * mz], -1)
        else:
            ref = np.tile(np.asarray(p.moment_point, float), (n_out, 1))
        d = r_out - ref
        f_out = force[idx]
        m_out = moment_origin[idx] + d[:, 1] * f_out[:, 0] - d[:, 0] * f_out[:, 1]
        zeros = np.zeros(n_out)
        out = traj.resample(t_out)
        assert out.pose is not None
        kin = kinematics_from_pose(out.pose)

        energy_ok = dissipated >= -p.energy_tolerance * energy_scale
        if failure is None and max_pen > p.max_penetration:
            failure = f"penetration {max_pen * 1e3:.3g} mm exceeds max_penetration {p.max_penetration * 1e3:.3g} mm"
        if failure is None and not energy_ok:
            failure = f"energy balance violated: dissipation {dissipated:.4g} J < 0 (work by the head {work:.4g} J)"
        if failure is None and mismatch > p.reaction_tolerance * max(peak, 1.0):
            failure = f"contact force and bar reaction differ by {mismatch:.3g} N (peak force {peak:.3g} N)"
        if failure is None and mismatch_moment > p.reaction_tolerance * moment_scale:
            failure = f"contact moment and bar reaction moment differ by {mismatch_moment:.3g} N m"
        diagnostics: dict[str, Any] = {
            "max_penetration_m": max_pen,
            "dissipated_energy_j": dissipated,
            "viscous_dissipation_j": float(visc),
            "friction_dissipation_j": float(fric),
            "work_by_head_j": work,
            "stored_energy_end_j": float(stored[-1]),
            "stored_energy_start_j": stored_start,
            "energy_balance_ok": bool(energy_ok),
            "newton_iterations": int(it_total),  # the summary key every oracle reports (registry.SUMMARY_DIAGNOSTICS)
            "newton_iterations_total": int(it_total),
            "newton_iterations_max": int(it_max),  # most iterations in one step (one slice)
            "steps": int(n_fine),
            "steps_with_contact": int(contact_steps),
            "first_contact_time_s": first_contact,
            "peak_force_n": peak,
            "peak_moment_nm": float(np.max(np.abs(m_out))),
            "bar_reaction_mismatch_n": mismatch,
            "bar_moment_mismatch_nm": mismatch_moment,
            "mesh_nodes": self.mesh.n_nodes,
            "mesh_elements": self.mesh.n_elements,
            "slices": len(self.slices),
        }
        wall = time.perf_counter() - start
        if failure is not None:
            return OracleResult(False, None, kin, diagnostics, wall, failure)
        forces = ForceSeries(
            t_out, np.stack([f_out[:, 0], zeros, f_out[:, 1]], -1), np.stack([zeros, m_out, zeros], -1)
        )
        return OracleResult(True, forces, kin, diagnostics, wall, None)
