#!/usr/bin/env python3
"""A deliberately broken external solver, one failure per mode, for the command oracle's error paths.

Usage: ``failing_solver.py MODE`` with MODE one of

* ``exit-code``  prints a solver error on stderr and exits with code 3
* ``signal``     kills itself with SIGSEGV (a crashed solver)
* ``hang``       starts a child process that writes its pid to ``child.pid``, then both sleep
                 (the oracle's timeout must kill the whole process group)
* ``no-output``  exits with code 0 without writing forces.csv
* ``malformed``  writes forces.csv without the ``mz`` column
* ``nan``        writes forces.csv with a NaN
* ``short``      writes forces.csv covering only the first half of the trajectory
"""

import os
import signal
import subprocess
import sys
import time


def read_times() -> list[float]:
    with open(os.environ.get("ALCOVE_TRAJECTORY", "trajectory.csv")) as fh:
        next(fh)
        return [float(line.split(",")[0]) for line in fh if line.strip()]


def write_forces(times: list[float], header: str = "t,fx,fy,fz,mx,my,mz", value: str = "0") -> None:
    columns = header.count(",")
    with open(os.environ.get("ALCOVE_OUTPUT", "forces.csv"), "w") as fh:
        fh.write(header + "\n")
        for t in times:
            fh.write(f"{t!r}" + f",{value}" * columns + "\n")


def main() -> int:
    mode = sys.argv[1]
    if mode == "exit-code":
        print("solver: element 42 has a negative volume", file=sys.stderr)
        return 3
    if mode == "signal":
        os.kill(os.getpid(), signal.SIGSEGV)
    if mode == "hang":
        child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"])
        with open("child.pid", "w") as fh:
            fh.write(str(child.pid))
        time.sleep(600)
        return 0
    if mode == "no-output":
        return 0
    times = read_times()
    if mode == "malformed":
        write_forces(times, header="t,fx,fy,fz,mx,my")
    elif mode == "nan":
        write_forces(times, value="nan")
    elif mode == "short":
        write_forces(times[: len(times) // 2])
    else:
        print(f"unknown mode {mode!r}", file=sys.stderr)
        return 64
    return 0


if __name__ == "__main__":
    sys.exit(main())
