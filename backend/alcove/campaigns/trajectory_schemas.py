"""Pydantic schemas of what an iteration's plots read: model k's curves along iteration k's
trajectory and the whole OCP solution over the task (re-exported by
:mod:`alcove.campaigns.schemas`)."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, Field


class IterationCurves(BaseModel):
    """Model k's prediction and the oracle's truth along iteration k's trajectory."""

    iteration_index: int
    t: list[float]
    q: list[list[float]]
    qd: list[list[float]]
    tau: list[list[float]] | None = Field(
        None,
        description=(
            "(n, ndof) joint torque of the replayed motion [N m] on the same grid; "
            "null without an oracle run (iteration 0)"
        ),
    )
    f_true: list[list[float]] = Field(description="(n, 6): fx fy fz mx my mz")
    f_pred: list[list[float]] = Field(description="(n, 6): the model's prediction (ensemble mean)")
    f_std: list[list[float]] | None = Field(
        None, description="(n, 6): the ensemble's standard deviation per output; null for a single model (K = 1)"
    )
    history: list[list[float]] | None = Field(
        None,
        description="(n, 3): the model's history states along the motion, max_indentation [m], slip_velocity_y "
        "and slip_velocity_z [m/s] (docs/concepts.md); null for a model of the state alone (features 'paper')",
    )
    pick: int | None = Field(None, description="the picked trajectory these are of (batch iterations; 0: first)")
    slot: int | None = Field(None, description="that pick's candidate (ocp slot)")


class TrajectoryPhase(BaseModel):
    """One phase of the task on the OCP's time axis."""

    index: int
    name: str = Field(description="the task's phase name (may be empty)")
    duration: float = Field(description="[s]")
    t_start: float = Field(description="[s]")
    t_end: float = Field(description="[s]")
    replayed: bool = Field(description="the oracle replayed this phase")


class OcpSolverSummary(BaseModel):
    """The solve that produced the trajectory (the iteration's latest OCP attempt)."""

    status: str = Field(description="IPOPT return status")
    converged: bool
    iterations: int | None = Field(None, description="IPOPT iterations")
    cost: float | None = None
    wall_time_s: float | None = None
    attempt: int
    initial_guess: str
    message: str = ""


class IterationTrajectory(BaseModel):
    """Iteration k's whole OCP solution over the task (all phases, on the OCP grid)."""

    iteration_index: int
    t: list[float] = Field(description="the OCP grid's nodes [s]")
    q: list[list[float]] = Field(description="(n, ndof) joint angles [rad]")
    qd: list[list[float]] = Field(description="(n, ndof) joint velocities [rad/s]")
    tau: list[list[float]] = Field(
        description="(n, ndof) joint torque at the nodes [N m] (mean of the adjacent intervals')"
    )
    duration: float = Field(description="the task's duration: the sum of the phase durations [s]")
    phases: list[TrajectoryPhase]
    scenario: dict[str, Any] | None = Field(
        None,
        description="the scenario the OCP solved (strategy random-scenarios: seed, iteration, slot, values); "
        "null: the task as written",
    )
    replay_phases: int = Field(description="the oracle replays the first N phases (the iteration's setting)")
    replay_t_end: float = Field(description="end of the replayed part [s]")
    replay_dt: float | None = Field(None, description="the replay's resampling step [s]; null: the OCP grid")
    solver: OcpSolverSummary
    slot: int = Field(0, description="the ocp slot (candidate) solved")


__all__ = ["IterationCurves", "IterationTrajectory", "OcpSolverSummary", "TrajectoryPhase"]
