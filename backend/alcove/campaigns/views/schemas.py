"""Pydantic schemas of what the API returns about a campaign: the campaign and its detail, the
list's summaries, iterations and their steps, metrics, events, jobs, and what an iteration's plots
read (model k's curves along iteration k's trajectory and the whole OCP solution)."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from alcove.campaigns.config import CampaignConfig
from alcove.campaigns.views.pick_schemas import CandidateRead, PickRmse
from alcove.campaigns.views.quality_schemas import TrustRead, ValidationSuiteRead
from alcove.models.base import CampaignStatus, IterationStatus, StepName, StepStatus
from alcove.oracles.schemas import BatchJobRead
from alcove.science.surrogate.metrics import DESCRIPTIONS


class _Read(BaseModel):
    model_config = ConfigDict(from_attributes=True)


class CampaignRead(_Read):
    id: int
    owner_id: int
    name: str
    description: str
    status: CampaignStatus
    stop_reason: str | None
    error: str | None
    wait_reason: str | None = Field(
        None,
        description="why a queued campaign has not started yet: its owner runs as many campaigns as their "
        "max_running_campaigns limit allows; it starts when one of them ends (null: it does not wait)",
    )
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
    slot: int = Field(
        0, description="which of the iteration's parallel jobs of this step (ocp: candidate, oracle: pick)"
    )
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
    batch_jobs: list[BatchJobRead] = Field(
        default_factory=list,
        description="an oracle step's batch-scheduler jobs, oldest first (empty unless its oracle runs as batch jobs)",
    )


class IterationRead(_Read):
    id: int
    index: int
    status: IterationStatus
    current_step: str | None
    config_version_id: int
    error: str | None
    started_at: datetime | None
    finished_at: datetime | None
    scenario: dict[str, Any] | None = Field(
        None,
        description="the scenario the iteration's OCP solved (strategy random-scenarios): seed, iteration, slot "
        "and values (parameter path -> drawn value); null: the task as written (strategy paper)",
    )
    steps: list[StepRead] | None = Field(
        None, description="the iteration's steps (null in the compact list: ask with ?steps=true)"
    )
    oracle_calls: int = Field(0, description="oracle runs the iteration made (every attempt that reached the oracle)")
    candidates: list[CandidateRead] = Field(
        default_factory=list,
        description="a batch iteration's candidate scenarios (ocp slots) and which were picked; empty: one trajectory "
        "(the iteration's scenario)",
    )


class MetricsRead(_Read):
    campaign_id: int = Field(description="the campaign the iteration ran in (a fork's source for inherited rows)")
    inherited: bool = Field(False, description="an iteration of a fork's source, up to the fork point")
    iteration_index: int
    force_rmse: float | None = Field(description=DESCRIPTIONS["force_rmse"] + ", model k on iteration k's oracle data")
    moment_rmse: float | None = Field(
        description=DESCRIPTIONS["moment_rmse"] + ", model k on iteration k's oracle data"
    )
    force_rmse_contact: float | None = Field(None, description=DESCRIPTIONS["force_rmse_contact"])
    moment_rmse_contact: float | None = Field(None, description=DESCRIPTIONS["moment_rmse_contact"])
    calibration: float | None = Field(None, description=DESCRIPTIONS["calibration"])
    metrics_definition: str = Field(
        "vector",
        description="vector: the RMSEs above are of the error vector (docs/concepts.md); stored campaigns were "
        "converted by migration 0007",
    )
    components: dict[str, float | None] | None = Field(
        None,
        description="model k on iteration k's oracle data (a batch: the picks' mean), the "
        + DESCRIPTIONS["rmse_components"]
        + "; null for iterations stored before the components were recorded",
    )
    force_max_error: float | None = Field(description="largest |F_pred - F_true| over the samples [N]")
    moment_max_error: float | None = Field(description="largest |M_pred - M_true| over the samples [N m]")
    ocp_success: bool | None
    ocp_status: str | None
    ocp_iterations: int | None
    ocp_cost: float | None
    ocp_wall_time_s: float | None
    ocp_trusted: bool | None = Field(
        None,
        description="false: the OCP solution relies on force outside the data (a ghost force with the gap open, "
        "or ensemble disagreement in contact); null: not assessed (iterations stored before the assessment)",
    )
    ocp_trust: TrustRead | None = Field(None, description="the OCP solution's trust diagnostics")
    oracle_wall_time_s: float | None
    train_wall_time_s: float | None
    n_pool_samples: int | None
    model_version_id: int | None
    dataset_id: int | None
    validation_force_rmse: float | None = Field(
        None,
        description=(
            "generalisation error of model k on the held-out validation suite: "
            "sqrt(mean_i |F_pred,i - F_true,i|^2) over all samples of all motions [N]; null until evaluated"
        ),
    )
    validation_moment_rmse: float | None = Field(
        None, description="the same for the moment vector [N m]; null until evaluated"
    )
    validation_components: dict[str, float | None] | None = Field(
        None,
        description="on the held-out validation suite, the " + DESCRIPTIONS["rmse_components"] + "; null until "
        "evaluated (suites evaluated before the in-contact figures were recorded have fx .. mz only)",
    )
    validation_calibration: float | None = Field(
        None,
        description=DESCRIPTIONS["calibration"]
        + "; of model k on all samples of all motions of the held-out validation "
        "suite; null until evaluated or when not recorded (validation_calibration_recorded)",
    )
    validation_calibration_recorded: bool | None = Field(
        None,
        description="false: the validation suite evaluation predates migration 0019 and did not compute the "
        "calibration (its null does not mean K = 1); null until evaluated",
    )
    oracle_calls: int | None = Field(None, description="oracle runs iteration k made")
    cumulative_oracle_calls: int | None = Field(
        None,
        description="oracle runs of iterations 1..k (a fork: its sources' up to the fork point included; the "
        "preliminary data of iteration 0 not counted): an x axis on which strategies and batch sizes compare",
    )
    cumulative_wall_time_s: float | None = Field(
        None,
        description="wall time of iterations 1..k until model k was evaluated [s]: finished iterations from start "
        "to end, iteration k from its start to its metrics row (pauses between iterations not counted; a fork "
        "includes its sources' up to the fork point)",
    )
    picks: list[PickRmse] = Field(
        default_factory=list,
        description="a batch iteration's in-loop RMSE per picked trajectory (the row's RMSEs are their mean)",
    )
    extra: dict[str, Any] | None = Field(
        None, description="software versions, per-component RMSE, step timings (only with ?extra=true on the series)"
    )


class CampaignDetail(BaseModel):
    campaign: CampaignRead
    config: CampaignConfig
    current: IterationRead | None
    latest_metrics: MetricsRead | None
    validation: ValidationSuiteRead | None = Field(None, description="the held-out validation suite, if any")
    iterations_finished: int
    iterations_failed: int
    mean_iteration_s: float | None
    eta_s: float | None = Field(None, description="remaining iterations (max_iterations rule) x mean iteration time")


class EventRead(_Read):
    id: int
    campaign_id: int
    iteration_index: int | None
    step: str | None
    kind: str
    message: str
    data: dict[str, Any]
    created_at: datetime


class CampaignSummary(BaseModel):
    id: int
    name: str
    status: CampaignStatus
    wait_reason: str | None = Field(
        None, description="why a queued campaign has not started yet (null: it does not wait)"
    )
    owner_id: int
    owner: str
    task_id: int
    task: str
    task_version: int
    oracle_id: int
    oracle: str
    oracle_type: str
    oracle_version: int
    current_iteration: int
    current_step: str | None
    max_iterations: int | None
    latest_iteration: int | None = Field(None, description="index of the latest iteration with metrics")
    force_rmse: float | None = Field(description="latest iteration's " + DESCRIPTIONS["force_rmse"])
    moment_rmse: float | None = Field(description="latest iteration's " + DESCRIPTIONS["moment_rmse"])
    mean_iteration_s: float | None = Field(None, description="mean wall time of the last 20 finished iterations [s]")
    eta_s: float | None = Field(
        None,
        description=(
            "remaining iterations (max_iterations rule) x mean iteration time [s]; null when finished or unknown"
        ),
    )
    source_campaign_id: int | None
    source_iteration: int | None
    created_at: datetime
    started_at: datetime | None
    finished_at: datetime | None


class CampaignOut(CampaignDetail):
    id: int = Field(description="the campaign's id (= campaign.id)")
    owner: str
    can_edit: bool
    task_id: int
    task_version: int
    oracle_id: int
    oracle_version: int


class JobOut(StepRead):
    iteration: int


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
