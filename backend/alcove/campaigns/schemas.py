"""Pydantic schemas of the campaign domain: settings (validated JSON stored on the
campaign and its config versions), requests, and what the service returns to the API."""

from __future__ import annotations

from datetime import datetime
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from alcove.models.base import CampaignStatus, IterationStatus, StepName, StepStatus
from alcove.pool.schemas import PoolVersionRead
from alcove.surrogates.schemas import ModelVersionRead


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


# ----------------------------------------------------------------------------- settings


class PreliminaryConfig(_Strict):
    """Where pool version 0 comes from: Latin-hypercube samples evaluated with the auxiliary
    penalty model (the paper), or uploaded datasets (``dataset_ids``)."""

    samples: int = Field(4000, ge=2, le=1_000_000, description="LHS sample count K")
    velocity_bound: float = Field(2.0, gt=0, le=100, description="|qd| bound of the samples [rad/s]")
    chunks: int = Field(
        10, ge=1, le=1000, description="datasets the samples are dealt into (for the split by simulation)"
    )
    seed: int | None = Field(None, ge=0, description="LHS seed (default: the campaign seed)")
    dataset_ids: list[int] | None = Field(None, description="uploaded datasets to use instead of LHS samples")


class StoppingRules(_Strict):
    """Any combination; the first that fires after an iteration stops the campaign."""

    max_iterations: int | None = Field(
        200, ge=1, le=100_000, description="stop after iteration k = max_iterations (paper: 200)"
    )
    target_force_rmse: float | None = Field(
        None, gt=0, description="stop when the iteration's force RMSE [N] is at most this"
    )
    target_moment_rmse: float | None = Field(
        None, gt=0, description="stop when the iteration's moment RMSE [N m] is at most this"
    )
    plateau_window: int | None = Field(
        None,
        ge=1,
        le=10_000,
        description="stop when the best force RMSE of the last W iterations is no better than before",
    )
    plateau_tolerance: float = Field(0.01, ge=0, lt=1, description="relative improvement that still counts as progress")
    oracle_budget_s: float | None = Field(
        None, gt=0, description="stop when the oracle's total wall time reaches this [s]"
    )

    @model_validator(mode="after")
    def _some_rule(self) -> StoppingRules:
        if (
            self.max_iterations is None
            and self.target_force_rmse is None
            and self.target_moment_rmse is None
            and self.plateau_window is None
            and self.oracle_budget_s is None
        ):
            raise ValueError("at least one stopping rule is needed (e.g. max_iterations)")
        return self


OnFailure = Literal["continue", "stop"]


class Policies(_Strict):
    """What happens when a step fails."""

    train_max_attempts: int = Field(2, ge=1, le=20, description="attempts of a train job that raised")
    ocp_initial_guesses: int = Field(
        3,
        ge=1,
        le=4,
        description="IPOPT runs with different initial guesses (previous solution, passive, ramp, static)",
    )
    ocp_max_attempts: int = Field(2, ge=1, le=20, description="attempts of an ocp job that raised")
    ocp_on_failure: OnFailure = Field(
        "continue", description="no converged solution: mark the iteration failed and continue, or stop the campaign"
    )
    oracle_max_attempts: int = Field(3, ge=1, le=20, description="attempts of an oracle job that raised or timed out")
    oracle_on_failure: OnFailure = Field(
        "continue", description="oracle failed (attempts exhausted) or its result was quarantined by the quality gate"
    )
    evaluate_max_attempts: int = Field(3, ge=1, le=20)
    append_max_attempts: int = Field(3, ge=1, le=20)


class RunSettings(_Strict):
    """Other settings that change results."""

    replay_phases: int = Field(
        1, ge=1, le=100, description="the oracle replays the first N phases of the OCP trajectory (paper: 1)"
    )
    replay_dt: float | None = Field(
        0.0025,
        gt=0,
        le=0.1,
        description="the replayed trajectory is resampled (cubic Hermite) at this step [s]; None: the OCP grid",
    )
    ocp_intervals: int | None = Field(
        None, ge=2, le=20000, description="override the task's intervals per phase (None: as the task says)"
    )
    fault_injection: dict[str, Any] = Field(
        default_factory=dict,
        description="tests only, per step name: raise_attempts (raise on attempts <= n), sleep_s (+ iterations: [k...]), ipopt_max_iter (ocp), gate_fail (oracle)",
    )


class CampaignConfig(_Strict):
    """The editable part of a campaign; a snapshot of it is a campaign config version."""

    preliminary: PreliminaryConfig = Field(default_factory=PreliminaryConfig)
    stopping: StoppingRules = Field(default_factory=StoppingRules)
    policies: Policies = Field(default_factory=Policies)
    settings: RunSettings = Field(default_factory=RunSettings)


# ----------------------------------------------------------------------------- requests


class CampaignCreate(CampaignConfig):
    name: str = Field(min_length=1, max_length=200)
    description: str = ""
    task_version_id: int
    oracle_version_id: int
    surrogate_config_version_id: int
    seed: int = Field(0, ge=0, lt=2**62)


class CampaignConfigUpdate(_Strict):
    """Edit of a campaign's settings: each given part replaces the current one and a new
    config version is recorded; iterations created afterwards use it."""

    surrogate_config_version_id: int | None = None
    stopping: StoppingRules | None = None
    policies: Policies | None = None
    settings: RunSettings | None = None
    note: str = ""


class ForkRequest(_Strict):
    """A new campaign continuing from ``iteration`` of the source (its pool version and
    model at that iteration), with changed settings."""

    iteration: int = Field(ge=0)
    name: str | None = None
    surrogate_config_version_id: int | None = None
    oracle_version_id: int | None = None
    task_version_id: int | None = None
    seed: int | None = Field(None, ge=0, lt=2**62)
    stopping: StoppingRules | None = None
    policies: Policies | None = None
    settings: RunSettings | None = None
    start: bool = False


# ----------------------------------------------------------------------------- reads


class _Read(BaseModel):
    model_config = ConfigDict(from_attributes=True)


class StepJob(BaseModel):
    """A Celery message to send after commit: run ``step`` of ``iteration`` (attempt n)."""

    model_config = ConfigDict(frozen=True)

    campaign_id: int
    iteration: int
    step: StepName
    attempt: int


class CampaignRead(_Read):
    id: int
    owner_id: int
    name: str
    description: str
    status: CampaignStatus
    stop_reason: str | None
    error: str | None
    task_version_id: int
    oracle_version_id: int
    surrogate_config_version_id: int
    seed: int
    config_version: int
    source_campaign_id: int | None
    source_iteration: int | None
    current_iteration: int
    current_step: str | None
    pause_requested: bool
    cancel_requested: bool
    oracle_wall_time_s: float
    created_at: datetime
    started_at: datetime | None
    finished_at: datetime | None


class StepRead(_Read):
    id: int
    step: StepName
    status: StepStatus
    queue: str
    attempts: int
    max_attempts: int
    worker_name: str | None
    queued_at: datetime | None
    started_at: datetime | None
    finished_at: datetime | None
    lease_until: datetime | None
    heartbeat_at: datetime | None
    wall_time_s: float | None
    error: str | None
    result: dict[str, Any]


class IterationRead(_Read):
    id: int
    index: int
    status: IterationStatus
    current_step: str | None
    config_version_id: int
    error: str | None
    started_at: datetime | None
    finished_at: datetime | None
    steps: list[StepRead] | None = Field(
        None, description="the iteration's steps (null in the compact list: ask with ?steps=true)"
    )


class MetricsRead(_Read):
    campaign_id: int = Field(description="the campaign the iteration ran in (a fork's source for inherited rows)")
    inherited: bool = Field(False, description="an iteration of a fork's source, up to the fork point")
    iteration_index: int
    force_rmse: float | None
    moment_rmse: float | None
    force_max_error: float | None
    moment_max_error: float | None
    ocp_success: bool | None
    ocp_status: str | None
    ocp_iterations: int | None
    ocp_cost: float | None
    ocp_wall_time_s: float | None
    oracle_wall_time_s: float | None
    train_wall_time_s: float | None
    n_pool_samples: int | None
    model_version_id: int | None
    dataset_id: int | None
    extra: dict[str, Any] | None = Field(
        None, description="software versions, per-component RMSE, step timings (only with ?extra=true on the series)"
    )


class CampaignDetail(BaseModel):
    campaign: CampaignRead
    config: CampaignConfig
    current: IterationRead | None
    latest_metrics: MetricsRead | None
    iterations_finished: int
    iterations_failed: int
    mean_iteration_s: float | None
    eta_s: float | None = Field(None, description="remaining iterations (max_iterations rule) x mean iteration time")


class IterationCurves(BaseModel):
    """Model k's prediction and the oracle's truth along iteration k's trajectory."""

    iteration_index: int
    t: list[float]
    q: list[list[float]]
    qd: list[list[float]]
    tau: list[list[float]] | None = Field(
        None,
        description="(n, ndof) joint torque of the replayed motion [N m] on the same grid; null without an oracle run (iteration 0)",
    )
    f_true: list[list[float]] = Field(description="(n, 6): fx fy fz mx my mz")
    f_pred: list[list[float]]


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
    replay_phases: int = Field(description="the oracle replays the first N phases (the iteration's setting)")
    replay_t_end: float = Field(description="end of the replayed part [s]")
    replay_dt: float | None = Field(None, description="the replay's resampling step [s]; null: the OCP grid")
    solver: OcpSolverSummary


class EventRead(_Read):
    id: int
    campaign_id: int
    iteration_index: int | None
    step: str | None
    kind: str
    message: str
    data: dict[str, Any]
    created_at: datetime


__all__ = [
    "CampaignConfig",
    "CampaignConfigUpdate",
    "CampaignCreate",
    "CampaignDetail",
    "CampaignRead",
    "EventRead",
    "ForkRequest",
    "IterationCurves",
    "IterationRead",
    "MetricsRead",
    "ModelVersionRead",
    "OnFailure",
    "Policies",
    "PoolVersionRead",
    "PreliminaryConfig",
    "RunSettings",
    "StepJob",
    "StepRead",
    "StoppingRules",
]
