"""alcove's fixed command of ``fe-headrest-3d-ccx``: run ccx on the deck, write the forces CSV.

Run as ``python -m alcove.science.oracles.fe_headrest_3d.driver`` in the working directory
that the command-oracle machinery prepared (the deck ``headrest.inp`` and ``job.json``).
It runs ``ccx -i headrest`` (its output in ``ccx.log``), reads the ``.dat`` file and writes
``forces.csv`` (``t,fx,fy,fz,mx,my,mz``: the contact force on the head and its moment about
the head COG, in the headrest frame) and ``diagnostics.json``. The head's wrench is minus
the reaction of the rigid body's reference and rotation nodes; the back face's reactions
give it a second time (the foam is in equilibrium), and a mismatch above
``reaction_tolerance`` x the peak fails the run. On any failure it exits with code 1 and
its last line on standard error is the reason (ccx's own ``*ERROR`` message where there is one).
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from alcove.science.arrays import FloatArray
from alcove.science.oracles.fe_headrest_3d.deck import (
    BACK_NODE_SET,
    DIAGNOSTICS_FILE,
    JOB_FILE,
    JOB_NAME,
    LOG_FILE,
    OUTPUT_FILE,
    REF_NODE_SET,
    ROT_NODE_SET,
)
from alcove.science.oracles.fe_headrest_3d.results import (
    CcxOutputError,
    NodeSeries,
    read_dat,
    read_sta,
    solver_errors,
)
from alcove.science.oracles.fe_headrest_3d.sampling import interpolate
from alcove.science.series import split_wrench, stack_wrench

FIRST_CONTACT_FRACTION = 1e-9  # of the peak force: above round-off, far below any touch (docs/fe-oracle.md)


class DriverFailure(RuntimeError):
    """The run failed; the message is the reason reported to alcove."""


def _at_times(series: NodeSeries, tau: FloatArray, what: str) -> FloatArray:
    """Values of ``series`` at the step times ``tau`` (ccx prints 7 significant digits)."""
    tol = 2e-6 * max(1.0, float(np.max(np.abs(tau))))
    idx = np.searchsorted(series.times, tau - tol)
    idx = np.minimum(idx, len(series.times) - 1)
    missing = np.abs(series.times[idx] - tau) > tol
    if np.any(missing):
        first = float(tau[np.argmax(missing)])
        reached = float(series.times[-1]) if len(series.times) else 0.0
        raise DriverFailure(
            f"ccx wrote no {what} at step time {first:.6g} (it reached {reached:.6g}): the step did not complete"
        )
    values: FloatArray = series.values[idx]
    return values


def wrench_from_dat(dat: dict[tuple[str, str], NodeSeries], job: dict[str, Any]) -> tuple[FloatArray, FloatArray]:
    """(head wrench from the reference/rotation nodes, the same from the back face), each (k, 6)."""
    tau = np.asarray(job["tau"], float)
    try:
        ref = dat[("forces", REF_NODE_SET)]
        rot = dat[("forces", ROT_NODE_SET)]
        back = dat[("forces", BACK_NODE_SET)]
    except KeyError as exc:
        raise DriverFailure(f"{JOB_NAME}.dat holds no reaction forces of set {exc.args[0][1]}") from None
    force = -_at_times(ref, tau, "reaction force of the head")[:, 0, :]
    moment = -_at_times(rot, tau, "reaction moment of the head")[:, 0, :]
    rf = _at_times(back, tau, "back-face reactions")  # (k, n, 3): force of the bar on the foam
    coords = dict(zip(job["back_nodes"], job["back_xyz"], strict=True))
    xyz = np.array([coords[n] for n in back.nodes], float)
    cog = np.asarray(job["cog"], float)  # (k, 3)
    lever = xyz[None, :, :] - cog[:, None, :]
    back_force = rf.sum(1)
    back_moment = np.cross(lever, rf).sum(1)
    return stack_wrench(force, moment), stack_wrench(back_force, back_moment)


def run(workdir: Path) -> dict[str, Any]:
    """Run the job in ``workdir``; returns the diagnostics (raises :class:`DriverFailure`)."""
    job = json.loads((workdir / JOB_FILE).read_text())
    t = np.asarray(job["t"], float)
    wrench = np.zeros((len(t), 6))
    # in a batch job: as many threads as the job has CPUs (its launcher's cpus_per_task)
    threads = int(os.environ.get("ALCOVE_JOB_CPUS") or job["threads"])
    diagnostics: dict[str, Any] = {"mesh": job.get("counts", {}), "ccx_run": False, "threads": threads}
    if job["tau"]:
        env = {**os.environ, "OMP_NUM_THREADS": str(threads), "CCX_NPROC_EQUATION_SOLVER": str(threads)}
        start = time.perf_counter()
        cpu_start = resource.getrusage(resource.RUSAGE_CHILDREN)
        with open(workdir / LOG_FILE, "wb") as log:
            try:
                code = subprocess.run(
                    [job["ccx"], "-i", JOB_NAME],
                    cwd=workdir,
                    env=env,
                    stdout=log,
                    stderr=subprocess.STDOUT,
                    stdin=subprocess.DEVNULL,
                    check=False,
                ).returncode
            except OSError as exc:
                raise DriverFailure(f"cannot start {job['ccx']!r}: {exc.strerror or exc}") from None
        diagnostics["ccx_run"] = True
        diagnostics["ccx_wall_time_s"] = time.perf_counter() - start
        cpu_end = resource.getrusage(resource.RUSAGE_CHILDREN)  # ccx's CPU time: the work, whatever the load
        diagnostics["ccx_cpu_time_s"] = (cpu_end.ru_utime + cpu_end.ru_stime) - (
            cpu_start.ru_utime + cpu_start.ru_stime
        )
        sta = read_sta(workdir / f"{JOB_NAME}.sta")
        diagnostics.update(
            increments=sta.increments,
            increment_attempts=sta.attempts,
            newton_iterations=sta.iterations,
            newton_iterations_all_attempts=sta.iterations_all,
            ccx_exit_code=code,
        )
        log_text = (workdir / LOG_FILE).read_text(errors="replace")
        errors = solver_errors(log_text)
        try:
            dat = read_dat(workdir / f"{JOB_NAME}.dat")
            head, back = wrench_from_dat(dat, job)
        except (CcxOutputError, DriverFailure) as exc:
            reason = errors[-1] if errors else f"ccx exited with code {code}" if code else ""
            raise DriverFailure(f"{exc}" + (f"; ccx: {reason}" if reason else "")) from None
        first = int(job["first_simulated"])
        tau_all = np.asarray(job.get("tau_all", job["tau"]), float)
        last = first + len(tau_all)  # the outputs after the step are 0 (the head is clear)
        if len(tau_all) == len(head):
            wrench[first:last] = head
        else:  # the outputs between the computed ones (sampling.py)
            tau = np.asarray(job["tau"], float)
            computed = np.searchsorted(tau_all, tau)
            filled = interpolate(tau, head, tau_all)
            filled[np.asarray(job["clear"], bool)] = 0.0
            filled[computed] = head
            wrench[first:last] = filled
        diagnostics.update(computed_outputs=len(head), interpolated_outputs=len(tau_all) - len(head))
        (head_force, head_moment), (back_force, back_moment) = split_wrench(head), split_wrench(back)
        peak = float(np.max(np.linalg.norm(head_force, axis=1)))
        mismatch = float(np.max(np.linalg.norm(head_force - back_force, axis=1)))
        mismatch_moment = float(np.max(np.linalg.norm(head_moment - back_moment, axis=1)))
        peak_moment = float(np.max(np.linalg.norm(head_moment, axis=1)))
        diagnostics.update(
            back_reaction_mismatch_n=mismatch,
            back_moment_mismatch_nm=mismatch_moment,
        )
        tol = float(job["reaction_tolerance"])
        if mismatch > tol * max(peak, 1.0):
            raise DriverFailure(f"head force and back-face reaction differ by {mismatch:.3g} N (peak {peak:.3g} N)")
        if mismatch_moment > tol * max(peak_moment, 0.1 * max(peak, 1.0)):
            raise DriverFailure(f"head moment and back-face reaction moment differ by {mismatch_moment:.3g} N m")
    force = np.linalg.norm(split_wrench(wrench)[0], axis=1)
    # first contact: the first output with a force above ccx's round-off (~1e-20 N while the head
    # is clear); a first touch is a single foam node, whose force grows from 0 like Hertz's d^1.5
    contact = (
        np.flatnonzero(force > FIRST_CONTACT_FRACTION * float(force.max())) if force.max() > 0 else np.array([], int)
    )
    diagnostics.update(
        peak_force_n=float(force.max()),
        peak_moment_nm=float(np.max(np.abs(wrench[:, 4]))),
        first_contact_time_s=float(t[contact[0]]) if contact.size else None,
        max_penetration_m=None,
        dissipated_energy_j=None,
    )
    diagnostics.setdefault("newton_iterations", 0)
    rows = ["t,fx,fy,fz,mx,my,mz"] + [
        ",".join(format(v, ".10g") for v in (ti, *w)) for ti, w in zip(t, wrench, strict=True)
    ]
    (workdir / OUTPUT_FILE).write_text("\n".join(rows) + "\n")
    (workdir / DIAGNOSTICS_FILE).write_text(json.dumps(diagnostics, indent=2) + "\n")
    return diagnostics


def main() -> int:
    try:
        run(Path.cwd())
    except DriverFailure as exc:
        print(f"fe-headrest-3d-ccx: {exc}", file=sys.stderr)
        return 1
    except (OSError, ValueError, KeyError) as exc:
        print(f"fe-headrest-3d-ccx: cannot run the job: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
