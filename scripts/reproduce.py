"""Reproduce the paper's proof of concept with alcove and write ``docs/reproduction.md``.

``make reproduce`` (or ``.venv/bin/python scripts/reproduce.py``) runs, in a fresh embedded
store (SQLite + artifacts in ``--data-dir``, a temporary folder by default):

1. the multibody solution of the ``head-headrest-2phase`` task with the auxiliary contact
   (DMOCC + IPOPT): joint angle relative to the start and torque, phases shaded;
2. an FE replay of that motion with ``fe-headrest-2d`` (first contact, force and moment
   curves, peaks), and of the paper's example motion (``reference_motion``);
3. an active-learning campaign over ``--iterations`` iterations (default 200, the paper's)
   through a spawned ``alcove worker`` on the embedded broker, as ``alcove campaign run`` does
   (``--inline`` runs the steps in this process instead: same protocol and rows, no broker):
   force and moment RMSE per iteration on a log axis with a rolling median, the last
   iteration's true vs predicted curves, the first and last RMSE, the campaign's wall time
   and its per-step breakdown (bare compute vs orchestration);
4. the paper's remedy ideas against the baseline at the same iteration count: down-weighting
   the preliminary data, and warm-starting a campaign on an adjusted task from the baseline
   campaign (a fork) instead of from the preliminary data. ``--remedy-iterations`` defaults
   to as many as fit in ``--budget-min`` (35 min for the whole run), estimated from the
   baseline's own iteration times.

Progress goes to stderr (a line per part and, during a campaign, every 30 s).
The figures need matplotlib, the ``reproduce`` extra (``pip install -e '.[reproduce]'``;
``make reproduce`` installs it); without it the script says so and stops before running.
Every number in the markdown comes from this run. ``--quick`` is a smoke run (the
aux-penalty oracle and a small preliminary set for the campaigns, 3 + 1 iterations); its
output is not a reproduction.

The code is in ``scripts/reproduction/`` (see its ``__init__``).
"""

from __future__ import annotations

from reproduction.cli import app  # scripts/ is on sys.path: it holds this script

if __name__ == "__main__":
    app()
