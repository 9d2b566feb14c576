"""The one interface every oracle implements.

An oracle replays a joint trajectory and returns the contact force and moment on the head
over time (headrest frame, moment about the head frame origin), the relative kinematics it
used, and run diagnostics. A run that fails the oracle's quality gate comes back with
``ok=False`` and a ``failure_reason``; its numbers must never be used as data.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol

from pydantic import BaseModel, ConfigDict

from alcove.science.geometry import HeadNeckPreset, RelativeKinematics
from alcove.science.series import ForceSeries, Trajectory

CancelCheck = Callable[[], bool]

#: Diagnostics every oracle reports (None where it has no such thing), shown by ``alcove
#: oracle run --json`` and the UI: deepest penetration [m], energy dissipated by the contact
#: [J], total Newton iterations.
SUMMARY_DIAGNOSTICS = ("max_penetration_m", "dissipated_energy_j", "newton_iterations")


class OracleInputError(ValueError):
    """Bad input to an oracle (trajectory or parameters); ``field`` names what is wrong."""

    def __init__(self, field: str, reason: str):
        self.field = field
        self.reason = reason
        super().__init__(f"{field}: {reason}")


class OracleCancelled(RuntimeError):
    """The run was cancelled cooperatively through the cancel check."""


class OracleParams(BaseModel):
    """Base class of the validated parameter model of an oracle type.

    Unknown fields are refused, and so are infinite and NaN numbers (they pass bounds such
    as ``gt=0``).
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


@dataclass
class OracleResult:
    ok: bool
    forces: ForceSeries | None
    kinematics: RelativeKinematics | None
    diagnostics: dict[str, Any] = field(default_factory=dict)
    wall_time: float = 0.0
    failure_reason: str | None = None

    def summary(self) -> dict[str, Any]:
        """JSON-ready summary (status, wall time, peak force and the diagnostics)."""
        return {
            "status": "ok" if self.ok else "failed",
            "failure_reason": self.failure_reason,
            "wall_time_s": self.wall_time,
            "peak_force_n": None if self.forces is None else self.forces.peak_force,
            **self.diagnostics,
        }


class Oracle(Protocol):
    """What every oracle type provides (its parameters may be any :class:`OracleParams` subclass)."""

    type_name: ClassVar[str]

    @property
    def params(self) -> OracleParams: ...

    @property
    def preset(self) -> HeadNeckPreset: ...

    def run(self, trajectory: Trajectory, cancel: CancelCheck | None = None) -> OracleResult: ...
