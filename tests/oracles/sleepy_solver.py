#!/usr/bin/env python3
"""A tiny command-oracle program for the batch-launcher tests: sleeps ``SECONDS`` (first
argument, default 0; with ``burn`` as second argument it computes that long instead, as a
solver holding one CPU would; with ``hog:MB`` it holds MB megabytes while it sleeps), then
writes zero forces on the trajectory's time grid, as the file contract asks. Each run appends
one line (its job id, folder and CPU count) to the file named by ``SLEEPY_RUN_LOG``, if set, so
a test can count how often a call really ran."""

import os
import sys
import time


def main() -> int:
    seconds = float(sys.argv[1]) if len(sys.argv) > 1 else 0.0
    log = os.environ.get("SLEEPY_RUN_LOG")
    if log:
        with open(log, "a") as fh:
            job = os.environ.get("SLURM_JOB_ID") or os.environ.get("PBS_JOBID") or "-"
            fh.write(f"{job} {os.getcwd()} {os.environ.get('ALCOVE_JOB_CPUS', '-')}\n")
    if sys.argv[2:3] and sys.argv[2].startswith("hog:"):  # holds that many MB while it sleeps
        held = b"x" * (int(sys.argv[2][4:]) * 1024 * 1024)
        time.sleep(seconds)
        del held
    elif sys.argv[2:3] == ["burn"]:
        end = time.process_time() + seconds
        while time.process_time() < end:
            sum(i * i for i in range(1000))
    else:
        time.sleep(seconds)
    with open(os.environ.get("ALCOVE_TRAJECTORY", "trajectory.csv")) as fh:
        next(fh)
        times = [line.split(",")[0] for line in fh if line.strip()]
    with open(os.environ.get("ALCOVE_OUTPUT", "forces.csv"), "w") as fh:
        fh.write("t,fx,fy,fz,mx,my,mz\n")
        fh.writelines(f"{t},0,0,0,0,0,0\n" for t in times)
    return 0


if __name__ == "__main__":
    sys.exit(main())
