#!/usr/bin/env python3
"""Post-processing for the LS-DYNA example: a head wrench table in model units -> alcove's forces.csv.

Input table (CSV with header ``t,fx,fy,fz,mx,my,mz``): the contact force on the head in the
model's global frame, which the example model puts in alcove's headrest frame H, and its
moment about the model's origin (the origin of H), in the model's units. alcove wants SI
units and the moment about the head frame origin (the head COG), so this script

* converts time, force and length (moments are force x length) to s, N, m;
* moves the moment to the head frame origin: M_head = M_origin - r_head x F, with
  r_head(t) the head origin in H from alcove's shared geometry for the trajectory.

Usage::

    to_forces_csv.py head_wrench.csv --trajectory trajectory.csv --out forces.csv \
        [--length-unit mm] [--force-unit N] [--time-unit s]
"""

import argparse
import sys

import numpy as np

from alcove.science.geometry import DEFAULT_PRESET, relative_kinematics
from alcove.science.series import ForceSeries, SeriesFormatError, Trajectory

LENGTH = {"m": 1.0, "mm": 1e-3}
FORCE = {"N": 1.0, "kN": 1e3}
TIME = {"s": 1.0, "ms": 1e-3}


def to_alcove(table: ForceSeries, trajectory: Trajectory, length: float = 1.0, force: float = 1.0, time: float = 1.0) -> ForceSeries:
    """Convert a head wrench about the model origin (model units) to alcove's convention."""
    t = table.t * time
    f = table.force * force
    m_origin = table.moment * force * length
    span = (trajectory.t[0], trajectory.t[-1])
    sampled = trajectory.resample(np.clip(t, *span))
    r_head = relative_kinematics(DEFAULT_PRESET, sampled.q[:, 0], sampled.qd[:, 0]).r_rel
    return ForceSeries(t, f, m_origin - np.cross(r_head, f))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("table")
    parser.add_argument("--trajectory", required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--length-unit", choices=LENGTH, default="mm")
    parser.add_argument("--force-unit", choices=FORCE, default="N")
    parser.add_argument("--time-unit", choices=TIME, default="s")
    args = parser.parse_args(argv)
    try:
        table = ForceSeries.from_csv(args.table)
        trajectory = Trajectory.from_csv(args.trajectory)
    except SeriesFormatError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    to_alcove(table, trajectory, LENGTH[args.length_unit], FORCE[args.force_unit], TIME[args.time_unit]).to_csv(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
