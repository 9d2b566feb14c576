"""Replay time of a campaign's held-out validation suite (the default 8 press motions) in
``fe-headrest-2d``, one process, one motion after the other (a campaign's oracle workers
replay them in parallel where they are free; with one worker this is the serial cost, spread
over the campaign's first iterations).

Run with ``python -m bench.run --only validation-suite``. The motions are
``alcove.science.validation_suite.suite_trajectories(SuiteSpec(), DEFAULT_PRESET)``: start
0.15-0.28 rad, peak 0.34-0.43 rad, top speed 0.3-1.5 rad/s, dwell 0-0.3 s, 178-915 outputs at
0.0025 s each (peak |F| 56-216 N with the default mesh).
"""

from __future__ import annotations

from typing import Any

from bench.harness import figure, timed


def _setup() -> tuple[Any, Any]:
    from alcove.science.geometry import DEFAULT_PRESET
    from alcove.science.oracles.registry import build_oracle
    from alcove.science.validation_suite import SuiteSpec, suite_trajectories

    oracle = build_oracle("fe-headrest-2d", {}, DEFAULT_PRESET)
    motions = suite_trajectories(SuiteSpec(), DEFAULT_PRESET)
    print(f"  {len(motions)} motions, {sum(len(m.t) for m in motions)} samples in all")
    return oracle, motions


@figure(
    "validation-suite: replay of the 8 held-out press motions in fe-headrest-2d (serial, one process)",
    "s",
    setup=_setup,
    reps=2,
    quick_reps=1,
    quick=False,
    group="oracle",
    notes="default suite spec (8 motions, seed 0) and oracle mesh; no target",
)
def validation_suite_replay(ctx: Any) -> float:
    oracle, motions = ctx

    def run() -> None:
        for m in motions:
            result = oracle.run(m)
            assert result.ok, result.failure_reason

    return timed(run)
