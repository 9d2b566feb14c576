#!/usr/bin/env python3
"""A real external program for the ``command`` oracle: replays the trajectory with alcove's own CLI.

It follows the file contract of docs/external-solvers.md exactly as an LS-DYNA wrapper would:
it runs in the working directory alcove prepared, reads ``trajectory.csv`` and ``params.json``,
runs the solver (here ``alcove oracle run --oracle ORACLE`` in a subprocess), and leaves
``forces.csv`` (header ``t,fx,fy,fz,mx,my,mz``) and ``diagnostics.json`` behind. Its exit
code is the solver's.

Usage (from a catalogue entry): ``replay_with_alcove.py [ORACLE]`` (default ``aux-penalty``).
The entry's declared parameters (``params.json`` minus ``dt_out``) are passed on to the
inner oracle as its parameters.
"""

import json
import os
import shutil
import subprocess
import sys


def alcove_command() -> list[str]:
    exe = shutil.which("alcove")
    return [exe] if exe else [sys.executable, "-m", "alcove_worker.cli.main"]


def main() -> int:
    oracle = sys.argv[1] if len(sys.argv) > 1 else "aux-penalty"
    trajectory = os.environ.get("ALCOVE_TRAJECTORY", "trajectory.csv")
    output = os.environ.get("ALCOVE_OUTPUT", "forces.csv")
    with open(os.environ.get("ALCOVE_PARAMS", "params.json")) as fh:
        params = json.load(fh)
    params.pop("dt_out", None)
    with open("inner-params.json", "w") as fh:
        json.dump(params, fh)
    run = subprocess.run(
        [*alcove_command(), "oracle", "run", "--oracle", oracle, "--params", "inner-params.json",
         "--trajectory", trajectory, "--out", output, "--json"],
        capture_output=True, text=True,
    )
    sys.stderr.write(run.stderr)
    if run.stdout.strip():
        summary = json.loads(run.stdout)
        with open("diagnostics.json", "w") as fh:
            json.dump(summary, fh, indent=2)
    return run.returncode


if __name__ == "__main__":
    sys.exit(main())
