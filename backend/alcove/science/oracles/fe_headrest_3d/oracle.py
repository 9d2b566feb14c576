"""``fe-headrest-3d-ccx``: the 3D headrest model in CalculiX, run through the command-oracle machinery.

alcove writes the deck (:mod:`.deck`) and ``job.json`` into the working directory and runs
its own fixed command, ``python -m alcove.science.oracles.fe_headrest_3d.driver``, which
runs ``ccx`` and writes the forces CSV (:mod:`.driver`). Working directory, timeout, output
contract and quality gate are those of every ``command`` oracle
(:class:`~alcove.science.oracles.command.CommandOracle`); no user supplies a command, an
argument or a template. The head follows the trajectory's pose (``Trajectory.pose``, the
contact body's pose relative to the headrest, whatever the chain) as in ``fe-headrest-2d``:
the deck's rigid-body amplitude curves are its x_H, z_H displacements and rotation.
"""

from __future__ import annotations

import json
import math
import shutil
import sys
import time
from typing import Any, ClassVar

import numpy as np

from alcove.science.arrays import FloatArray
from alcove.science.geometry import DEFAULT_PRESET, HeadNeckPreset, HeadProfile
from alcove.science.oracles.base import (
    SUMMARY_DIAGNOSTICS,
    CancelCheck,
    OracleResult,
    check_contact_within_cushion,
    posed_trajectory,
    validated_head_trajectory,
)
from alcove.science.oracles.command.batch import BatchJobBook
from alcove.science.oracles.command.launcher import LOCAL, LauncherSpec
from alcove.science.oracles.command.oracle import CommandOracle
from alcove.science.oracles.command.spec import CommandOracleParams, CommandOracleSpec
from alcove.science.oracles.fe_headrest_3d.deck import (
    HEAD_LAYER,
    JOB_FILE,
    JOB_NAME,
    OUTPUT_FILE,
    Contact,
    FoamMaterial,
    HeadMotion,
    StepControl,
    place,
    write_deck,
)
from alcove.science.oracles.fe_headrest_3d.mesh import HexMesh, block_axes, ellipsoid_cap, foam_block
from alcove.science.oracles.fe_headrest_3d.params import CcxHeadrestParams
from alcove.science.oracles.fe_headrest_3d.sampling import computed_outputs
from alcove.science.series import Trajectory

TYPE_NAME = "fe-headrest-3d-ccx"
CCX_PROGRAM = "ccx"
CCX_PACKAGE = "calculix-ccx"
CAP_AZIMUTH = math.radians(60.0)
CAP_ELEVATION = (math.radians(-65.0), math.radians(65.0))
END_TOLERANCE = 1e-7  # of the span (at least 1 s): an output this close to the end is at the end
APPROACH_STEP = 5e-4  # m of approach per output interval when the head starts in contact


def ccx_available() -> str | None:
    """None if ``ccx`` is on PATH, else why not (naming the package)."""
    if shutil.which(CCX_PROGRAM) is None:
        return f"the CalculiX solver '{CCX_PROGRAM}' is not on PATH (install the package {CCX_PACKAGE})"
    return None


def signed_gap(preset: HeadNeckPreset, r: FloatArray, angle: FloatArray, semi_axes: tuple[float, float]) -> FloatArray:
    """Distance of the undeformed head from the cushion plane x_H = 0 (negative: indentation)."""
    pr = preset.profile
    ax, az = semi_axes
    c, s = np.cos(angle), np.sin(angle)
    x_centre = r[:, 0] + c * pr.cx - s * pr.cz
    gap: FloatArray = x_centre - np.sqrt((ax * c) ** 2 + (az * s) ** 2)
    return gap


class _CcxCommand(CommandOracle):
    """The command oracle with alcove's deck and job file as its inputs."""

    def __init__(
        self, spec: CommandOracleSpec, params: CommandOracleParams, preset: HeadNeckPreset, files: dict[str, str]
    ):
        super().__init__(spec, params, preset)
        self._files = files

    def _rendered_deck(self, trajectory: Trajectory) -> str | None:
        return self._files[self.spec.rendered_file_name]

    def _extra_inputs(self, trajectory: Trajectory) -> dict[str, str]:
        return {k: v for k, v in self._files.items() if k != self.spec.rendered_file_name}


class CcxHeadrestOracle:
    """3D FE headrest oracle in CalculiX (``fe-headrest-3d-ccx``)."""

    type_name: ClassVar[str] = TYPE_NAME

    def __init__(
        self,
        params: CcxHeadrestParams | None = None,
        preset: HeadNeckPreset = DEFAULT_PRESET,
        launcher: LauncherSpec = LOCAL,
    ) -> None:
        self.params = params if params is not None else CcxHeadrestParams()
        self.preset = preset
        #: where ccx runs: on the oracle worker, or one batch job per call (the administrator's
        #: ``launchers`` section of the command catalogue); a job's CPUs are ccx's threads
        self.launcher = launcher
        p = self.params
        pr = preset.profile
        self.semi_axes_xz = p.head_semi_axes_xz or (pr.ax, pr.az)
        self.block = foam_block(
            *block_axes(
                p.cushion_thickness,
                p.cushion_width,
                p.cushion_height,
                p.cushion_bottom,
                p.element_size_contact,
                p.element_size_far,
                p.contact_half_width,
                p.contact_zone,
                p.element_growth,
            )
        )
        ax, az = self.semi_axes_xz
        self.head = ellipsoid_cap(
            (pr.cx, pr.cz),
            (ax, p.head_half_breadth, az),
            CAP_AZIMUTH,
            CAP_ELEVATION,
            p.head_element_size,
            HEAD_LAYER,
        )

    # ---- input -------------------------------------------------------------------------
    def _validated(self, trajectory: Any) -> Trajectory:
        p = self.params

        def indentation(pose: FloatArray) -> FloatArray:
            return -signed_gap(self.preset, pose[:, :2], pose[:, 2], self.semi_axes_xz)

        traj, depth = validated_head_trajectory(
            trajectory, self.preset, p.output_dt, indentation, p.max_indentation_fraction * p.cushion_thickness
        )
        pr = self.preset.profile
        head = HeadProfile(pr.cx, pr.cz, *self.semi_axes_xz)
        check_contact_within_cushion(traj, depth, head, p.cushion_bottom, p.cushion_bottom + p.cushion_height)
        return traj

    # ---- the job -----------------------------------------------------------------------
    def job_files(self, trajectory: Trajectory) -> tuple[dict[str, str], dict[str, Any]]:
        """The deck and ``job.json`` for a (validated) trajectory, and the job's description."""
        p = self.params
        t0, t1 = float(trajectory.t[0]), float(trajectory.t[-1])
        n_out = math.floor((t1 - t0) / p.output_dt + 1e-9) + 1
        t_out = t0 + p.output_dt * np.arange(n_out, dtype=np.float64)
        # the outputs must reach the trajectory's end (the command oracle's gate): a span that is
        # not a whole number of output intervals ends with one shorter interval (or, closer than
        # 1e-3 of an interval, with the last output moved onto the end)
        short = t1 - float(t_out[-1])
        if short > END_TOLERANCE * max(1.0, t1 - t0):
            if short < 1e-3 * p.output_dt and n_out > 1:
                t_out[-1] = t1
            else:
                t_out = np.append(t_out, t1)
                n_out += 1
        pose = trajectory.resample(t_out).pose
        if pose is None:  # a trajectory that was not validated: the 1-DOF preset's joint-only form
            pose = posed_trajectory(trajectory, self.preset).resample(t_out).pose
        assert pose is not None
        r, a = pose[:, :2], pose[:, 2]
        gap = signed_gap(self.preset, r, a, self.semi_axes_xz)
        near = np.flatnonzero(gap < p.clearance)
        job: dict[str, Any] = {
            "ccx": CCX_PROGRAM,
            "threads": p.threads,
            "t": t_out.tolist(),
            "tau": [],
            "first_simulated": n_out,
            "reaction_tolerance": p.reaction_tolerance,
        }
        if near.size == 0:  # the head never comes near the cushion: the force is 0, nothing to solve
            job["counts"] = {}
            return {
                JOB_NAME + ".inp": "** no contact: nothing to solve\n",
                JOB_FILE: json.dumps(job),
            }, job
        k = int(near[0])
        if k > 0:  # start one output step before the head comes within the clearance
            start, shift, lead = k - 1, 0.0, 0.0
            first_out = k
        else:  # in contact (or close) at the start: approach from the clearance first
            start, first_out = 0, 0
            shift = p.clearance - float(gap[0])
            lead = p.output_dt * max(2, math.ceil(shift / APPROACH_STEP))
        r0 = r[start] + np.array([shift, 0.0])
        a0 = float(a[start])
        tau_path = lead + (t_out[start:] - t_out[start])
        ux, uz = r[start:, 0] - r0[0], r[start:, 1] - r0[1]
        rot = -(a[start:] - a0)
        if lead > 0:
            tau_path = np.concatenate([[0.0], tau_path])
            ux, uz, rot = (np.concatenate([[0.0], v]) for v in (ux, uz, rot))
        # the step ends one output after the head last comes within the clearance: after that the
        # cushion is unloaded (elastic foam) and the force is 0, as before the start
        end = min(n_out, int(near[-1]) + 2)
        tau_path, ux, uz, rot = (v[: len(v) - (n_out - end)] for v in (tau_path, ux, uz, rot))
        out_tau = lead + (t_out[first_out:end] - t_out[start])
        computed = computed_outputs(
            out_tau, -gap[first_out:end], pose[first_out:end], p.solve_stride, p.interpolation_tolerance
        )
        motion = HeadMotion(tau_path, ux, uz, rot, out_tau[computed])
        head = HexMesh(place(self.head.nodes, (float(r0[0]), float(r0[1])), a0), self.head.elements)
        dt = p.output_dt
        deck = write_deck(
            self.block,
            head,
            (float(r0[0]), 0.0, float(r0[1])),
            FoamMaterial.from_beta(p.foam_terms),
            Contact(p.penalty, p.friction, p.stick_slope, p.contact_formulation),
            motion,
            StepControl(
                dt * p.max_increment_fraction,
                dt * p.solve_stride * p.max_increment_fraction,
                dt * p.min_increment_fraction,
                residual_floor=p.residual_floor,
                late_residual=p.late_residual,
            ),
            p.foam_element,
        )
        cog = np.stack([r[first_out:end, 0], np.zeros(end - first_out), r[first_out:end, 1]], -1)[computed]
        job.update(
            tau=motion.output_tau.tolist(),
            # the outputs between the computed ones are interpolated; those where the undeformed
            # head is clear of the cushion are 0 (sampling.py)
            tau_all=out_tau.tolist(),
            clear=(gap[first_out:end] >= 0.0).tolist(),
            first_simulated=first_out,
            cog=cog.tolist(),
            back_nodes=deck.back_nodes.tolist(),
            back_xyz=deck.back_coordinates.tolist(),
            counts=deck.counts,
        )
        return {JOB_NAME + ".inp": deck.text, JOB_FILE: json.dumps(job)}, job

    def spec(self) -> CommandOracleSpec:
        return CommandOracleSpec(
            name=TYPE_NAME,
            argv=[sys.executable, "-m", "alcove.science.oracles.fe_headrest_3d.driver"],
            description="3D headrest model in CalculiX (alcove's own deck and command)",
            input_file=JOB_NAME + ".inp",
            allow_user_template=False,
            output_file=OUTPUT_FILE,
            timeout_s=self.params.timeout_s,
            launcher=self.launcher,
        )

    @property
    def runs_as_batch_jobs(self) -> bool:
        return self.launcher.is_batch

    # ---- run -----------------------------------------------------------------------------
    def run(
        self, trajectory: Trajectory, cancel: CancelCheck | None = None, batch_book: BatchJobBook | None = None
    ) -> OracleResult:
        """Replay ``trajectory``; with a batch launcher the call is one batch job kept in ``batch_book``."""
        start = time.perf_counter()
        traj = self._validated(trajectory)
        missing = None if self.launcher.is_batch else ccx_available()  # a batch job finds ccx on its node
        if missing is not None:
            return OracleResult(False, None, None, dict.fromkeys(SUMMARY_DIAGNOSTICS), 0.0, f"{TYPE_NAME}: {missing}")
        files, job = self.job_files(traj)
        command = _CcxCommand(
            self.spec(),
            CommandOracleParams(dt_out=self.params.output_dt, keep_workdir=self.params.keep_workdir),
            self.preset,
            files,
        )
        result = command.run(traj, cancel, batch_book)
        result.diagnostics["mesh_foam_elements"] = job.get("counts", {}).get("foam_elements")
        result.wall_time = time.perf_counter() - start
        if result.failure_reason is not None:
            result.failure_reason = result.failure_reason.replace(f"command oracle '{TYPE_NAME}'", TYPE_NAME)
        return result


__all__ = ["CCX_PACKAGE", "CCX_PROGRAM", "TYPE_NAME", "CcxHeadrestOracle", "ccx_available", "signed_gap"]
