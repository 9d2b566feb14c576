"""Wall time of the ``fe-headrest-2d`` oracle on the paper's example motion (target <= 5 s).

Run with ``python -m bench.run --only fe-oracle`` (``--only fe-headrest`` also selects the
campaign figures, which run whole campaigns).

The motion is ``alcove.science.oracles.fe_headrest.reference_motion()``: 1 s, 401 outputs
at 0.0025 s, head at rest at theta0 = 0.232 rad, first contact at t = 0.29 s, pressed in
firmly to theta = 0.43 rad at t = 0.65 s and eased back to rest on the cushion at theta =
0.33 rad (285 steps in contact, peak force ~220 N). Default parameters: one plane-strain slice, 6 mm elements in
the contact zone (the figure's notes carry the mesh size). The paper's LS-DYNA run of the
same kind of replay takes about 180 s on a laptop.
"""

from __future__ import annotations

import time
from typing import Any

from bench.harness import figure, timed


def _setup() -> tuple[Any, Any]:
    from alcove.science.oracles.fe_headrest import FEHeadrestOracle, FEHeadrestParams, reference_motion

    oracle = FEHeadrestOracle(FEHeadrestParams())
    trajectory = reference_motion()
    cpu = time.process_time()
    result = oracle.run(trajectory)  # warm-up, and make sure the measured run is a valid one
    cpu = time.process_time() - cpu
    assert result.ok, result.failure_reason
    d = result.diagnostics
    print(
        f"  mesh {d['mesh_nodes']} nodes / {d['mesh_elements']} elements, {d['steps_with_contact']} contact steps, "
        f"{d['newton_iterations_total']} Newton iterations, peak force {d['peak_force_n']:.1f} N, "
        f"peak moment {d['peak_moment_nm']:.2f} N m, max penetration {d['max_penetration_m'] * 1e6:.1f} um, "
        f"warm-up run {cpu:.2f} s CPU (wall time on a loaded machine is longer)"
    )
    return oracle, trajectory


@figure(
    "fe-oracle: fe-headrest-2d on the paper example motion (1 s, 401 outputs), default mesh",
    "s",
    target=5.0,
    setup=_setup,
    reps=5,
    quick_reps=2,
    group="oracle",
    notes="default mesh: 6 mm contact zone / 15 mm far, 155 nodes, 120 Q1 elements, 1 slice",
)
def fe_reference_motion(ctx: Any) -> float:
    oracle, trajectory = ctx

    def run() -> None:
        result = oracle.run(trajectory)
        assert result.ok, result.failure_reason

    return timed(run)
