"""Parts 1 and 2: the multibody OCP solution with the auxiliary contact, and its FE replay."""

from __future__ import annotations

import json
import time
from typing import Any

from . import figures
from .record import PAPER, RELEVANT, TASK, Report, fmt, phase_bounds

FE_PARAMS_SHOWN = {"element_size_contact", "element_size_far", "output_dt", "slices", "out_of_plane_width"}


def part_multibody(rep: Report) -> Any:
    import numpy as np

    from alcove.science.ocp import aux_contact, solve_task, task_preset

    task = task_preset(TASK)
    t0 = time.perf_counter()
    sol = solve_task(task, aux_contact(task.preset()))
    wall = time.perf_counter() - t0
    rep.timings["multibody OCP solve (aux contact, cold)"] = wall
    if not sol.converged:
        raise RuntimeError(f"the OCP did not converge: {sol.status}")
    phases = phase_bounds(task)
    dq = sol.q[:, 0] - sol.q[0, 0]
    t1 = phases[0][2]
    p1, p2 = sol.t <= t1 + 1e-9, sol.t > t1 + 1e-9
    # interval torques (piecewise constant), assigned to a phase by the interval's midpoint
    u = sol.controls[:, 0]
    t_mid = 0.5 * (sol.t[:-1] + sol.t[1:])
    u2 = u[t_mid > t1]

    figures.multibody(rep.figure_path("multibody.png"), sol, dq, u, phases)

    s = "multibody"
    rep.add(s, "joint angle relative to the start, min", PAPER["angle"], dq.min(), "rad")
    rep.add(
        s,
        "joint angle relative to the start, max",
        PAPER["angle"],
        dq.max(),
        "rad",
        "positive toward the headrest (our frames)",
    )
    rep.add(s, "max |torque|, phase 1", PAPER["torque"], np.abs(u[t_mid <= t1]).max(), "N m")
    rep.add(s, "max |torque|, phase 2", PAPER["torque_phase2"], np.abs(u2).max() if u2.size else float("nan"), "N m")
    rep.facts.update(
        angle_max=float(np.abs(dq).max()),
        torque1=float(np.abs(u[t_mid <= t1]).max()),
        torque2=float(np.abs(u2).max()) if u2.size else float("nan"),
    )
    rep.add(
        s,
        "OCP wall time (cold: build + guess + solve)",
        "n/a",
        wall,
        "s",
        f"IPOPT {sol.status}, {sol.iterations} iterations",
    )
    rep.text(
        s,
        f"IPOPT: `{sol.status}` after {sol.iterations} iterations, cost {fmt(sol.cost)}, "
        f"{sol.controls.shape[0]} intervals, constraint violation {fmt(sol.constraint_violation)}, {wall:.2f} s.",
        f"Start angle theta0 = {fmt(sol.q[0, 0])} rad; at the end of phase 1 theta = {fmt(sol.q[p1][-1, 0])} rad, "
        f"at the end of phase 2 theta = {fmt(sol.q[p2][-1, 0] if p2.any() else float('nan'))} rad.",
    )
    return task, sol


def fe_params(quick: bool) -> dict[str, Any]:
    # the oracle's defaults in both modes: a replay takes a few seconds, and a coarser mesh or
    # step does not always converge in contact (quick would then test something else)
    return {}


def part_fe(rep: Report, task: Any, sol: Any) -> None:
    import numpy as np

    from alcove.science.ocp.replay import replay_trajectory
    from alcove.science.oracles.fe_headrest import reference_motion
    from alcove.science.oracles.registry import build_oracle

    params = fe_params(rep.quick)
    oracle = build_oracle("fe-headrest-2d", params, task.preset())
    arrays = {"t": sol.t, "q": sol.q, "qd": sol.qd, "tau": sol.tau}
    motions = [("OCP solution (phase 1)", replay_trajectory(arrays, task, 1, params.get("output_dt", 0.0025)))]
    if not rep.quick:
        motions.append(("paper's example motion", reference_motion()))
    results = []
    for label, traj in motions:
        t0 = time.perf_counter()
        res = oracle.run(traj)
        wall = time.perf_counter() - t0
        rep.timings[f"FE replay, {label}"] = wall
        if not res.ok:
            raise RuntimeError(f"FE replay of the {label} failed: {res.failure_reason}")
        results.append((label, res, wall))

    figures.fe_replay(rep.figure_path("fe_replay.png"), results)
    _approach(rep, task, sol, motions[0][1], results[0][1])

    s = "fe"
    for label, res, wall in results:
        d = res.diagnostics
        w = np.concatenate([res.forces.force, res.forces.moment], axis=1)
        fc = d.get("first_contact_time_s")
        rep.add(s, f"first contact, {label}", PAPER["first_contact"], fc if fc is not None else float("nan"), "s")
        key = "ocp" if label.startswith("OCP") else "ref"
        rep.facts[f"{key}_first_contact"] = fc if fc is not None else float("nan")
        rep.facts[f"{key}_peak_force"] = float(np.linalg.norm(w[:, :3], axis=1).max())
        rep.facts[f"{key}_peak_moment"] = float(np.linalg.norm(w[:, 3:], axis=1).max())
        for name, j, unit in RELEVANT:
            paper = PAPER["peak_moment"] if unit == "N m" else PAPER["peak_force"]
            rep.add(s, f"peak |{name}|, {label}", paper, np.abs(w[:, j]).max(), unit)
        rep.add(
            s,
            f"FE wall time, {label}",
            PAPER["fe_time"],
            wall,
            "s",
            f"{d.get('mesh_nodes')} nodes, {d.get('slices')} slice(s), {d.get('steps')} steps",
        )
        penetration_um = 1e6 * d.get("max_penetration_m", float("nan"))
        dissipated = d.get("dissipated_energy_j", float("nan"))
        work = d.get("work_by_head_j", float("nan"))
        rep.text(
            s,
            f"{label}: {len(res.forces)} output samples, {d.get('steps_with_contact')} steps in contact, "
            f"{d.get('newton_iterations_total')} Newton iterations, max penalty penetration "
            f"{fmt(penetration_um)} um, dissipated {fmt(dissipated)} J "
            f"of {fmt(work)} J done by the head; {wall:.1f} s.",
        )
    shown = oracle.params.model_dump(mode="json", include=FE_PARAMS_SHOWN)
    rep.text(s, f"Oracle parameters: {json.dumps(shown)}.")


def _approach(rep: Report, task: Any, sol: Any, traj: Any, res: Any) -> None:
    """How the OCP solution reaches the cushion: the speed at first contact, the torque before it
    against the one that holds the head at the start, and the force peaks (a bounce makes several)."""
    import numpy as np

    from .sweep import PEAK_PROMINENCE, force_peaks, holding_torque

    fc = res.diagnostics.get("first_contact_time_s")
    if fc is None:
        return
    speed = float(abs(np.interp(fc, traj.t, traj.qd[:, 0])))
    t_mid = 0.5 * (sol.t[:-1] + sol.t[1:])
    before = np.abs(sol.controls[t_mid < fc, 0])
    hold = abs(holding_torque(sol.chain, float(sol.q[0, 0])))
    peaks = force_peaks(np.linalg.norm(res.forces.force, axis=1))
    s = "multibody"
    rep.add(
        s,
        "holding torque at the start (cancels gravity at theta0)",
        "about 1.35 N m (its figure, before contact)",
        hold,
        "N m",
    )
    rep.add(
        s,
        "mean |torque| before first contact",
        "about 1.35 N m (its figure: actuation holds the head)",
        float(before.mean()),
        "N m",
    )
    rep.add(s, "angular speed at first contact (FE replay)", "a smooth approach (its figure)", speed, "rad/s")
    rep.add(
        s,
        "force peaks of |F| along the replay",
        "1 (a single press, its figure)",
        peaks,
        "",
        f"scipy.signal.find_peaks, prominence >= {PEAK_PROMINENCE:.0%} of the peak",
    )
    rep.facts.update(hold=hold, torque_before=float(before.mean()), contact_speed=speed, force_peaks=float(peaks))
