"""Cost of the aux-penalty oracle and of running an oracle as an external program (command oracle).

The command figure runs the example entry ``aux-replay`` (examples/command-oracle): trajectory
and params files, a Python wrapper starting ``alcove oracle run`` in a subprocess, reading the
forces back. Compared with the in-process aux-penalty run it is the pure overhead of the
file contract, which an external solver pays once per run (LS-DYNA itself: ~180 s).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bench.harness import figure, timed

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "command-oracle"


def paper_like_trajectory():
    """1 s, 401 samples (the paper's output grid): the head meets the headrest, pushes and leaves."""
    from alcove.science.geometry import DEFAULT_PRESET
    from alcove.science.series import Trajectory

    t = np.linspace(0.0, 1.0, 401)
    return Trajectory(t, DEFAULT_PRESET.theta0 + 0.15 * np.sin(np.pi * t), 0.15 * np.pi * np.cos(np.pi * t))


def _aux_setup():
    from alcove.science.oracles.aux_penalty import AuxPenaltyOracle

    return AuxPenaltyOracle(), paper_like_trajectory()


def _command_setup():
    from alcove.science.oracles.command import load_command_catalogue
    from alcove.science.oracles.registry import build_oracle

    return build_oracle(
        "aux-replay", {}, catalogue=load_command_catalogue(EXAMPLES / "catalogue.yaml")
    ), paper_like_trajectory()


@figure("oracle aux-penalty, 401 samples", "ms", setup=_aux_setup, reps=20, quick_reps=5, group="oracles")
def aux_penalty_run(ctx) -> float:
    oracle, trajectory = ctx
    return 1e3 * timed(lambda: oracle.run(trajectory))


@figure(
    "oracle command (aux-replay external program), 401 samples",
    "s",
    setup=_command_setup,
    reps=5,
    quick_reps=2,
    group="oracles",
    notes="overhead of the external-program file contract: two Python processes + CSV I/O",
)
def command_aux_replay_run(ctx) -> float:
    oracle, trajectory = ctx

    def run() -> None:
        result = oracle.run(trajectory)
        assert result.ok, result.failure_reason

    return timed(run)
