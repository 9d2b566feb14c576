"""The quality gate of a ``command`` oracle run: is the program's output usable as data?

The forces must cover the trajectory's time span (to a relative tolerance of 1e-6) with at
least two samples inside it; samples outside it are dropped. A run that fails the gate is
reported as ``ok=False`` (the campaign quarantines it), never used as data.
"""

from __future__ import annotations

from dataclasses import dataclass

from alcove.science.series import ForceSeries, Trajectory

TIME_TOLERANCE = 1e-6  # relative to the trajectory's time span (at least 1 s)


@dataclass(frozen=True)
class GateResult:
    """The forces within the trajectory's span, or why the output is not usable."""

    forces: ForceSeries | None
    failure: str | None = None


def forces_within_trajectory(forces: ForceSeries, trajectory: Trajectory, output_file: str) -> GateResult:
    """Check that ``forces`` cover ``trajectory`` and keep the samples within its time span."""
    t0, t1 = float(trajectory.t[0]), float(trajectory.t[-1])
    tol = TIME_TOLERANCE * max(1.0, t1 - t0)
    if forces.t[0] > t0 + tol or forces.t[-1] < t1 - tol:
        return GateResult(
            None,
            f"{output_file} covers t = [{forces.t[0]:.6g}, {forces.t[-1]:.6g}] s "
            f"but the trajectory spans [{t0:.6g}, {t1:.6g}] s",
        )
    inside = (forces.t >= t0 - tol) & (forces.t <= t1 + tol)
    if inside.sum() < 2:
        return GateResult(None, f"{output_file} has fewer than 2 samples within the trajectory's time span")
    return GateResult(ForceSeries(forces.t[inside], forces.force[inside], forces.moment[inside]))


__all__ = ["TIME_TOLERANCE", "GateResult", "forces_within_trajectory"]
