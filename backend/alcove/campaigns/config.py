"""A campaign's settings: the validated JSON stored on the campaign and its config versions
(preliminary data, stopping rules, failure policies, run settings), and the settings a stored
config version holds."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, field_validator, model_validator

from alcove.campaigns import repository as repo

if TYPE_CHECKING:
    from sqlalchemy.orm import Session

    from alcove.models import Campaign, CampaignConfigVersion


class _Strict(BaseModel):
    # strict: "1" is not a number and 1 or "true" not a boolean, as the schema says (JSON numbers still fill floats)
    model_config = ConfigDict(extra="forbid", strict=True)


# ----------------------------------------------------------------------------- settings


#: press-family replays in pool version 0 when the request leaves ``family_motions`` null: with them
#: every strategy's normal force reaches the best-possible line's (docs/active-learning.md)
DEFAULT_FAMILY_MOTIONS = 4


class PreliminaryConfig(_Strict):
    """Where pool version 0 comes from: Latin-hypercube samples evaluated with the auxiliary
    penalty model (the paper), or uploaded datasets (``dataset_ids``)."""

    samples: int = Field(4000, ge=2, le=1_000_000, description="LHS sample count K")
    velocity_bound: float = Field(
        2.0, gt=0, le=100, description="|qd| bound of the samples [rad/s]; above 0, at most 100"
    )
    chunks: int = Field(
        10, ge=1, le=1000, description="datasets the samples are dealt into (for the split by simulation)"
    )
    seed: int | None = Field(None, ge=0, lt=2**62, description="LHS seed (default: the campaign seed)")
    dataset_ids: list[Annotated[int, Field(ge=1, le=2**31 - 1)]] | None = Field(
        None, description="uploaded datasets to use instead of LHS samples"
    )
    family_motions: int | None = Field(
        None,
        ge=0,
        le=256,
        description=(
            "oracle replays in pool version 0 beside the auxiliary law's samples: the first of the task's press "
            "family (the space-filling sequence strategy press-family draws from, seeded by the campaign seed; "
            "settings.family_ranges), counted as oracle calls; with them the first model learns contact from the "
            "oracle, not the auxiliary law (preliminary_in_contact), over the depths and histories the OCP optima "
            "do not reach. 0 to 256; 0: none; null (the default): "
            f"{DEFAULT_FAMILY_MOTIONS} where the oracle is not the auxiliary law itself, the task's press family can "
            "be drawn and pool version 0 is not uploaded datasets, else 0 (the campaign stores the number it runs "
            "with; docs/active-learning.md)"
        ),
    )

    @property
    def family_replays(self) -> int:
        """The press-family replays of pool version 0 (a stored campaign's number is always decided)."""
        return self.family_motions or 0


class StoppingRules(_Strict):
    """Any combination; the first that fires after an iteration stops the campaign."""

    max_iterations: int | None = Field(
        200, ge=1, le=100_000, description="stop after iteration k = max_iterations (paper: 200)"
    )
    target_force_rmse: float | None = Field(
        None,
        gt=0,
        le=1e5,
        description="stop when the iteration's force RMSE [N] is at most this; above 0, at most 1e5 N",
    )
    target_moment_rmse: float | None = Field(
        None,
        gt=0,
        le=1e4,
        description="stop when the iteration's moment RMSE [N m] is at most this; above 0, at most 1e4 N m",
    )
    plateau_window: int | None = Field(
        None,
        ge=1,
        le=10_000,
        description="stop when the best force RMSE of the last W iterations is no better than before",
    )
    plateau_tolerance: float = Field(
        0.01, ge=0, lt=1, description="relative improvement that still counts as progress [-]; 0 to below 1"
    )
    oracle_budget_s: float | None = Field(
        None,
        gt=0,
        le=1e7,
        description="stop when the oracle's total wall time reaches this [s]; above 0, at most 1e7 s (16 weeks)",
    )
    max_oracle_calls: int | None = Field(
        None,
        ge=1,
        le=1_000_000,
        description=(
            "stop when the campaign has made this many oracle calls: every oracle run, also a failed attempt and "
            "the calls of failed iterations (checked after each iteration: a batch may end up to q - 1 above it); "
            "1 to 1e6"
        ),
    )
    max_failed_streak: int | None = Field(
        10,
        ge=1,
        le=100_000,
        description=(
            "stop after this many consecutive failed iterations (the OCP did not converge, or the oracle failed or "
            "was quarantined: no new data, so the next iteration starts from the same pool); a safety net, not a "
            "rule that ends a campaign by itself; null: never; 1 to 1e5"
        ),
    )
    min_disagreement: float | None = Field(
        None,
        gt=0,
        le=1e4,
        description=(
            "strategy 'ensemble-disagreement': stop when the highest candidate score (ensemble force std over "
            "the contact phase) falls below this [N]; the iteration then asks the oracle nothing; above 0, at "
            "most 1e4 N"
        ),
    )

    @model_validator(mode="after")
    def _some_rule(self) -> StoppingRules:
        if (
            self.max_iterations is None
            and self.target_force_rmse is None
            and self.target_moment_rmse is None
            and self.plateau_window is None
            and self.oracle_budget_s is None
            and self.max_oracle_calls is None
            and self.min_disagreement is None
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


#: a range [low, high] of the validation suite's motions
SuiteRange = Annotated[
    list[Annotated[float, Field(ge=-10, le=100, allow_inf_nan=False)]],
    Field(min_length=2, max_length=2, description="[low, high], each -10 to 100 in the parameter's unit"),
]


class ValidationRanges(_Strict):
    """Ranges of the validation suite's motions, each [low, high] (equal ends: fixed); a range left
    out (null) is derived from the task (docs/active-learning.md, "The validation suite")."""

    start: SuiteRange | None = Field(None, description="start angle, at rest [rad]")
    depth: SuiteRange | None = Field(None, description="peak angle of the press [rad]")
    speed: SuiteRange | None = Field(None, description="largest angular velocity of each segment [rad/s], above 0")
    dwell: SuiteRange | None = Field(None, description="hold at every turning point [s], at least 0")
    release: SuiteRange | None = Field(
        None, description="share of the press a partial unload gives back [-], in [0, 1] (1: a simple press)"
    )
    reload: SuiteRange | None = Field(
        None, description="share of the way back to the peak a re-load goes [-], in [0, 1] (0: none)"
    )

    @model_validator(mode="after")
    def _low_below_high(self) -> ValidationRanges:
        for name, r in self:
            if r is not None and r[0] > r[1]:
                raise ValueError(f"{name}: the low end {r[0]} lies above the high end {r[1]}")
        return self

    def given(self) -> dict[str, tuple[float, float]]:
        """The ranges set, by parameter."""
        return {name: (float(r[0]), float(r[1])) for name, r in self if r is not None}


class RunSettings(_Strict):
    """Other settings that change results."""

    replay_phases: int = Field(
        1, ge=1, le=100, description="the oracle replays the first N phases of the OCP trajectory (paper: 1)"
    )
    replay_dt: float | None = Field(
        0.0025,
        gt=0,
        le=0.1,
        description="the replayed trajectory is resampled (cubic Hermite) at this step [s], above 0, at most 0.1; "
        "None: the OCP grid",
    )
    ocp_intervals: int | None = Field(
        None, ge=2, le=20000, description="override the task's intervals per phase (None: as the task says)"
    )
    trust_region_max_std: float | None = Field(
        None,
        gt=0,
        le=10000,
        description=(
            "trust region: bound the ensemble's force std sqrt(sigma_fx^2 + sigma_fy^2 + sigma_fz^2) [N] at every "
            "interval midpoint of the OCP solution (above 0 N, at most 10000 N; None: unbounded; "
            "needs ensemble_size > 1)"
        ),
    )
    validation_motions: int = Field(
        8,
        ge=0,
        le=64,
        description=(
            "held-out validation motions every model version is evaluated on (generalisation error); "
            "0: no validation suite. Shared by campaigns with the same oracle version, seed and count"
        ),
    )
    validation_seed: int = Field(0, ge=0, le=2**31 - 1, description="seed of the validation suite's motions")
    validation_ranges: ValidationRanges = Field(
        default_factory=ValidationRanges,
        description=(
            "the validation suite's motions: presses with partial unloads and re-loads, slow and fast; ranges left "
            "out are derived from the task (peak angles from first contact to the joint limit, start angles "
            "covering the task's initial angles, speeds up to the task's fastest initial speed)"
        ),
    )
    validation_stress_motions: int = Field(
        0,
        ge=0,
        le=64,
        description=(
            "more validation motions beyond the task's reach (faster than its scenarios, up to twice the top "
            "speed), reported apart from the suite's figures; 0: none"
        ),
    )
    validation_reference_motions: int = Field(
        32,
        ge=0,
        le=128,
        description=(
            "the best-possible line: the oracle replays this many more motions of the suite's box (a "
            "space-filling sequence), and models trained on the first 4, 8, 16, ... of them from scratch (FE data "
            "only) are scored on the suite, once per suite; the campaign's curves show it at those oracle budgets. "
            "0 to 128; 0: none"
        ),
    )
    validation_stress_ranges: ValidationRanges = Field(
        default_factory=ValidationRanges,
        description="ranges of the stress motions; ranges left out: the suite's, with speeds above its top speed",
    )
    strategy: Literal["paper", "random-scenarios", "ensemble-disagreement", "press-family"] = Field(
        "paper",
        description=(
            "acquisition strategy (docs/active-learning.md): 'paper' solves the task as written every iteration "
            "(the paper's loop); 'random-scenarios' solves q scenarios drawn from the task's ranges with the "
            "campaign seed, the iteration index and the slot; 'ensemble-disagreement' draws C candidate scenarios, "
            "solves each with the ensemble mean, scores each by the ensemble's disagreement over its contact phase "
            "and replays the q best that are far enough apart; 'press-family' solves no OCP: the oracle replays q "
            "prescribed motions of the task's press family (press, dwell, partial unload, re-load; the box "
            "family_ranges), the next ones of a space-filling sequence seeded by the campaign seed"
        ),
    )
    family_ranges: ValidationRanges = Field(
        default_factory=ValidationRanges,
        description=(
            "'press-family': the box its motions are drawn from, each [low, high]; ranges left out are derived "
            "from the task as the validation suite's are"
        ),
    )
    candidates: int = Field(
        8,
        ge=1,
        le=64,
        description="candidate scenarios C solved per iteration by 'ensemble-disagreement' (1 to 64, at least q)",
    )
    min_distance: float = Field(
        0.1,
        ge=0,
        le=10,
        description=(
            "'ensemble-disagreement': no two picks closer than this in the scenarios' feature space (each ranged "
            "parameter scaled to [0, 1]); 0 to 10"
        ),
    )
    batch: int = Field(
        1,
        ge=1,
        le=64,
        description=(
            "batch size q: trajectories the oracle replays per iteration, in parallel oracle jobs, appended as one "
            "pool version (1 to 64; strategy 'paper' takes 1 only)"
        ),
    )
    max_concurrent_oracle_jobs: int | None = Field(
        None,
        ge=1,
        le=64,
        description=(
            "at most this many of the campaign's oracle jobs queued or running at once (1 to 64; None: no cap); "
            "the rest wait and start as running ones finish"
        ),
    )

    @field_validator("batch")
    @classmethod
    def _batch_needs_a_batch_strategy(cls, batch: int, info: ValidationInfo) -> int:
        strategy, candidates = info.data.get("strategy"), info.data.get("candidates")
        if batch > 1 and strategy == "paper":
            raise ValueError(
                f"strategy 'paper' replays one trajectory per iteration (batch 1), got {batch}; "
                "use strategy 'random-scenarios' or 'ensemble-disagreement' for q > 1"
            )
        if strategy == "ensemble-disagreement" and candidates is not None and batch > candidates:
            raise ValueError(f"a batch of {batch} needs at least as many candidates, got candidates = {candidates}")
        return batch


def strategy_problem(settings: RunSettings, ensemble_size: int) -> str | None:
    """Why ``settings.strategy`` cannot run with a surrogate of ``ensemble_size`` members, or None.

    ``ensemble-disagreement`` scores a candidate by the members' spread (their force std): an
    ensemble of one has no disagreement, every score would be 0 and the picks arbitrary."""
    if settings.strategy == "ensemble-disagreement" and ensemble_size < 2:
        return (
            f"strategy 'ensemble-disagreement' needs a surrogate ensemble of at least 2 members, the surrogate "
            f"config has ensemble_size {ensemble_size}: an ensemble of one has no disagreement to score "
            "candidates by (use 'random-scenarios', or a surrogate config with ensemble_size >= 2)"
        )
    return None


class CampaignConfig(_Strict):
    """The editable part of a campaign; a snapshot of it is a campaign config version."""

    preliminary: PreliminaryConfig = Field(default_factory=PreliminaryConfig)
    stopping: StoppingRules = Field(default_factory=StoppingRules)
    policies: Policies = Field(default_factory=Policies)
    settings: RunSettings = Field(default_factory=RunSettings)


# ----------------------------------------------------------------------------- reads


def config_from_version(row: CampaignConfigVersion) -> CampaignConfig:
    """The campaign configuration a stored config version holds."""
    return CampaignConfig.model_validate(
        {
            "preliminary": row.preliminary_config,
            "stopping": row.stopping_rules,
            "policies": row.policies,
            "settings": row.settings,
        }
    )


def current_config(s: Session, campaign: Campaign) -> CampaignConfig:
    """The settings of the campaign's current config version."""
    return config_from_version(repo.config_version(s, campaign))
