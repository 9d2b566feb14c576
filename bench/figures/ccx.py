"""Wall time of ``fe-headrest-3d-ccx`` (CalculiX) on the paper's example motion (target <= 300 s).

Run with ``python -m bench.run --only ccx``. The motion is
``alcove.science.oracles.fe_headrest.reference_motion()`` (1 s, 401 outputs at 0.0025 s,
first contact at t = 0.29 s); default parameters (8 mm elements in the contact zone). The
paper's LS-DYNA replay takes about 180 s on a laptop. Each run prints ccx's increments,
Newton iterations, the mesh and the peak force. The second figure runs two replays at once
(what two oracle workers do) and reports the wall time of the pair: with 2 free cores it is
close to one replay's. Skipped where ``ccx`` is not installed; not in ``--quick``.

``python -m bench.run --only "ccx mesh"``: mesh convergence at full length (the test
``test_peak_force_at_the_default_mesh_is_within_5_percent_of_a_refined_mesh`` runs the loading
half of the same press at 0.05 s outputs): a press of the validation suite's kind, used to tune
nothing (``PressMotion(start=0.26, depth=0.40, speed=1.0, dwell=0.05)``, 0.575 s, outputs
every 0.025 s, loading and unloading), at the default mesh (8 mm in the contact zone and on the
head) and at 6 mm. The figure is the peak force's relative difference [%] (target <= 5 %).

``python -m bench.run --only "ccx before/after"``: the example motion and a deeper press
(``DEEP_PRESS``, a deterministic construction: 0.25 -> 0.43 rad at 0.5 rad/s, held 0.25 s), each
replayed with the settings before (``BEFORE``: ccx computes every output, on the mesh with the wider
fine zone) and with the defaults (a subset computed, the rest interpolated; the fine zone fitted to
the head's reach). Each prints ccx's CPU time, increments, Newton
iterations, peak force and first contact of both, and the peak difference, the force RMS
difference (% of the peak) and the first-contact shift; the figure is the defaults' ccx CPU time
(targets: 60 s on the example motion, 120 s on the deeper press).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from typing import Any

from bench.harness import figure, timed


def _requires() -> str | None:
    from alcove.science.oracles.fe_headrest_3d import ccx_available

    return ccx_available()


def _setup() -> tuple[Any, Any]:
    from alcove.science.oracles.fe_headrest import reference_motion
    from alcove.science.oracles.fe_headrest_3d import CcxHeadrestOracle, CcxHeadrestParams

    return CcxHeadrestOracle(CcxHeadrestParams()), reference_motion()


def _replay(oracle: Any, trajectory: Any) -> Any:
    result = oracle.run(trajectory)
    assert result.ok, result.failure_reason
    d = result.diagnostics
    solver = d.get("solver", {})
    print(
        f"  ccx {solver.get('ccx_wall_time_s', 0):.1f} s wall / {solver.get('ccx_cpu_time_s', 0):.1f} s CPU, "
        f"{solver.get('increments')} increments "
        f"({solver.get('increment_attempts')} attempts), {d['newton_iterations']} Newton iterations, "
        f"{solver.get('computed_outputs', '-')} computed + "
        f"{solver.get('interpolated_outputs', 0)} interpolated outputs, "
        f"mesh {solver.get('mesh')}, peak force {solver.get('peak_force_n', 0):.1f} N, "
        f"peak moment {solver.get('peak_moment_nm', 0):.2f} N m, first contact {solver.get('first_contact_time_s')} s"
    )
    return result


@figure(
    "ccx: fe-headrest-3d-ccx on the paper example motion (1 s, 401 outputs), default mesh",
    "s",
    target=300.0,
    setup=_setup,
    reps=1,
    quick_reps=1,
    quick=False,
    requires=_requires,
    group="oracle",
    notes="default mesh: 8 mm contact zone / 30 mm far; node-to-surface penalty contact, friction 0.4",
)
def ccx_reference_motion(ctx: Any) -> float:
    oracle, trajectory = ctx
    return timed(lambda: _replay(oracle, trajectory))


@figure(
    "ccx: two fe-headrest-3d-ccx replays at once (2 oracle workers), default mesh",
    "s",
    target=300.0,
    setup=_setup,
    reps=1,
    quick_reps=1,
    quick=False,
    requires=_requires,
    group="oracle",
    notes="wall time of the pair; compare with one replay above (2 cores: about equal when the machine is idle)",
)
def ccx_two_in_parallel(ctx: Any) -> float:
    oracle, trajectory = ctx

    def pair() -> None:
        with ThreadPoolExecutor(2) as pool:
            for future in [pool.submit(_replay, oracle, trajectory) for _ in range(2)]:
                future.result()

    return timed(pair)


#: the mesh-convergence motion (a press of the validation suite's kind, used to tune nothing)
MESH_MOTION = {"start": 0.26, "depth": 0.40, "speed": 1.0, "dwell": 0.05}


def _mesh_setup() -> Any:
    from alcove.science.validation_suite import PressMotion, press_trajectory

    return press_trajectory(PressMotion(**MESH_MOTION), 0.025)


@figure(
    "ccx mesh: fe-headrest-3d-ccx peak force, default 8 mm mesh vs refined 6 mm (validation-suite press)",
    "%",
    target=5.0,
    setup=_mesh_setup,
    reps=1,
    quick_reps=1,
    quick=False,
    requires=_requires,
    group="oracle",
    notes="|F_8mm - F_6mm| / F_6mm of the peak |F|; 0.575 s press at 0.025 s outputs; contact zone and head together",
)
def ccx_mesh_convergence(trajectory: Any) -> float:
    import time

    import numpy as np

    from alcove.science.oracles.fe_headrest_3d import CcxHeadrestOracle, CcxHeadrestParams

    peaks = {}
    for h in (0.008, 0.006):
        start = time.perf_counter()
        params = CcxHeadrestParams(element_size_contact=h, head_element_size=h, output_dt=0.025)
        result = _replay(CcxHeadrestOracle(params), trajectory)
        peaks[h] = (
            float(np.max(np.linalg.norm(result.forces.force, axis=1))),
            float(np.max(np.abs(result.forces.moment[:, 1]))),
        )
        print(f"  {h * 1e3:.0f} mm: {time.perf_counter() - start:.0f} s wall, peak |F| {peaks[h][0]:.2f} N")
    (f8, m8), (f6, m6) = peaks[0.008], peaks[0.006]
    print(f"  peak |my| {m8:.3f} vs {m6:.3f} N m ({100 * abs(m8 - m6) / m6:.1f} %)")
    return 100.0 * abs(f8 - f6) / f6


# ---- before / after: fewer, cheaper increments, the same forces ----------------------------------

#: the deeper press of the comparison, a deterministic construction (a press of the validation
#: suite's kind, deeper and longer than the suite's: 0.25 -> 0.43 rad at 0.5 rad/s, held 0.25 s;
#: 1.6 s, 641 outputs, 419 of them with the undeformed head in the cushion)
DEEP_PRESS = {"start": 0.25, "depth": 0.43, "speed": 0.5, "dwell": 0.25}

#: the settings before: ccx computes every output (an increment ends at each) on the mesh with the
#: shared cushion's wider fine zone, graded at 1.3 outside it (2400 foam nodes), with ccx's 0.2 N
#: late residual criterion and a 0.005 N floor below the 0.05 N criterion
BEFORE: dict[str, Any] = {
    "solve_spacing": 0.0,
    "contact_half_width": 0.06,
    "contact_zone": (-0.06, 0.07),
    "element_growth": 1.3,
    "residual_floor": 0.005,
    "late_residual": 0.2,
}

COMPARISON_MOTIONS = ("example", "deep press")


def comparison_trajectory(name: str) -> Any:
    """The paper's example motion or the deeper press (``DEEP_PRESS`` at 0.0025 s)."""
    if name == "example":
        from alcove.science.oracles.fe_headrest import reference_motion

        return reference_motion()
    from alcove.science.validation_suite import PressMotion, press_trajectory

    return press_trajectory(PressMotion(**DEEP_PRESS), 0.0025)


def compare_forces(before: Any, after: Any) -> dict[str, float]:
    """Peak |F| difference [%], force RMS difference [% of the peak], first-contact shift [outputs]."""
    import numpy as np

    f0, f1 = before.forces.force, after.forces.force
    n0, n1 = np.linalg.norm(f0, axis=1), np.linalg.norm(f1, axis=1)
    peak = float(n0.max())
    rms = float(np.sqrt(np.mean(np.sum((f1 - f0) ** 2, axis=1))))
    c0, c1 = before.diagnostics["solver"]["first_contact_time_s"], after.diagnostics["solver"]["first_contact_time_s"]
    dt = float(before.forces.t[1] - before.forces.t[0])
    return {
        "peak_diff_percent": 100.0 * (float(n1.max()) - peak) / peak,
        "rms_diff_percent_of_peak": 100.0 * rms / peak,
        "first_contact_shift_outputs": (c1 - c0) / dt,
    }


def _before_after(name: str) -> float:
    from alcove.science.oracles.fe_headrest_3d import CcxHeadrestOracle, CcxHeadrestParams

    trajectory = comparison_trajectory(name)
    runs = {}
    for label, params in (("before", CcxHeadrestParams(**BEFORE)), ("after", CcxHeadrestParams())):
        print(f"  {name}, {label}:")
        runs[label] = _replay(CcxHeadrestOracle(params), trajectory)
    c = compare_forces(runs["before"], runs["after"])
    print(
        f"  after vs before: peak |F| {c['peak_diff_percent']:+.2f} % (target within 2 %), force RMS difference "
        f"{c['rms_diff_percent_of_peak']:.2f} % of the peak (target <= 1 %), first contact shifted by "
        f"{c['first_contact_shift_outputs']:+.0f} outputs (target within 1)"
    )
    cpu: float = runs["after"].diagnostics["solver"]["ccx_cpu_time_s"]
    return cpu


@figure(
    "ccx before/after: paper example motion, ccx CPU time with the defaults (before: every output computed)",
    "s",
    target=60.0,
    reps=1,
    quick_reps=1,
    quick=False,
    requires=_requires,
    group="oracle",
    notes="ccx's own CPU time (one core); prints before and after: CPU, increments, Newton iterations, peak, "
    "RMS difference, first contact",
)
def ccx_before_after_example(ctx: Any) -> float:
    return _before_after("example")


@figure(
    "ccx before/after: deeper press (0.25 -> 0.43 rad, held 0.25 s), ccx CPU time with the defaults",
    "s",
    target=120.0,
    reps=1,
    quick_reps=1,
    quick=False,
    requires=_requires,
    group="oracle",
    notes="DEEP_PRESS in bench/figures/ccx.py; ccx's own CPU time (one core); prints before and after",
)
def ccx_before_after_deep_press(ctx: Any) -> float:
    return _before_after("deep press")
