"""What the Slurm tests share: the test program and whether the local Slurm cluster answers."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

#: a tiny command-oracle program: sleeps, writes zero forces, logs each run
SOLVER = Path(__file__).with_name("sleepy_solver.py")


def slurm_is_up() -> str | None:
    """None when Slurm answers, else why not (start it with ``.ci/slurm-up``)."""
    if shutil.which("sbatch") is None or shutil.which("squeue") is None:
        return "Slurm's commands (sbatch, squeue) are not installed: run .ci/slurm-up"
    got = subprocess.run(["sinfo", "-h", "-o", "%T"], capture_output=True, text=True, timeout=20)
    if got.returncode != 0 or not any(s in got.stdout for s in ("idle", "mixed", "alloc")):
        return f"no Slurm node is up (sinfo: {got.stdout.strip() or got.stderr.strip()}): run .ci/slurm-up"
    return None
