"""The resolved multi-phase problem the DMOCC transcription takes (NumPy only, no CasADi).

:meth:`alcove.science.ocp.task_spec.TaskSpec.discrete_problem` resolves a user's task into
these numbers: every default filled in, bounds and targets as arrays of one value per joint.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from alcove.science.arrays import FloatArray, IntArray


@dataclass(frozen=True)
class PhaseGrid:
    """One phase, resolved: duration, intervals, weights, bounds (ndof arrays), target pose at its end."""

    duration: float
    intervals: int
    w_tau: float
    w_T: float
    q_min: FloatArray
    q_max: FloatArray
    tau_max: FloatArray
    target_q: FloatArray | None = None

    @property
    def step(self) -> float:
        return self.duration / self.intervals


@dataclass(frozen=True)
class DiscreteProblem:
    """A resolved multi-phase problem. ``None`` boundary entries are free."""

    phases: tuple[PhaseGrid, ...]
    q_start: FloatArray | None
    qd_start: FloatArray | None
    q_end: FloatArray | None = None
    qd_end: FloatArray | None = None
    endpoint_w_q: float = 0.0
    endpoint_q_ref: FloatArray | None = None
    endpoint_w_qd: float = 0.0

    @property
    def intervals(self) -> int:
        return sum(ph.intervals for ph in self.phases)

    def steps(self) -> FloatArray:
        """Step of every interval (N,)."""
        return np.concatenate([np.full(ph.intervals, ph.step) for ph in self.phases])

    def time_grid(self) -> FloatArray:
        """Node times t_0..t_N (N + 1,)."""
        return np.concatenate([[0.0], np.cumsum(self.steps())])

    def phase_of_interval(self) -> IntArray:
        """Index of the phase of every interval (N,)."""
        return np.concatenate([np.full(ph.intervals, m, dtype=np.int64) for m, ph in enumerate(self.phases)])

    def phase_end_nodes(self) -> list[int]:
        return [int(k) for k in np.cumsum([ph.intervals for ph in self.phases])]


__all__ = ["DiscreteProblem", "PhaseGrid"]
