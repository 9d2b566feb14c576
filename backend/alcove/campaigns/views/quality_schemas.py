"""What the API says about how far a campaign's models can be trusted: the trust assessment of
an OCP solution found with a surrogate, and the held-out validation suite's generalisation
error (re-exported by :mod:`alcove.campaigns.schemas`)."""

from __future__ import annotations

from pydantic import BaseModel, Field

from alcove.science.surrogate.metrics import DESCRIPTIONS


class TrustRead(BaseModel):
    """Where the surrogate's OCP solution of the iteration can be trusted (alcove.science.surrogate.trust),
    evaluated at the interval midpoints where the OCP evaluates the contact model."""

    trusted: bool = Field(description="false: the solution relies on force outside the data (see reasons)")
    reasons: list[str] = Field(description="why it is not trusted: ghost force, ensemble disagreement in contact")
    ensemble_size: int = Field(description="members K of the model (K = 1 has no std)")
    contact_fraction: float = Field(description="fraction of the solution with gap <= gap_tolerance (contact phase)")
    max_std_contact: float | None = Field(
        description="largest ensemble force std sqrt(sigma_fx^2 + sigma_fy^2 + sigma_fz^2) in the contact phase [N]"
    )
    integral_std_contact: float = Field(description="time integral of that std over the contact phase [N s]")
    max_std: float = Field(description="largest ensemble force std over the whole solution [N]")
    open_gap_max_force: float = Field(
        description="largest predicted |F| (ensemble mean) where the geometric gap is open by more than "
        "gap_tolerance [N] (the ghost force; 0: never clearly open)"
    )
    open_gap_at_gap: float | None = Field(description="the gap where that force is predicted [m]")
    open_gap_at_time: float | None = Field(description="the time where that force is predicted [s]")
    min_gap: float = Field(description="smallest signed gap head profile - undeformed headrest along its normal [m]")
    max_pool_distance: float | None = Field(
        description="largest distance to the nearest pool sample in the surrogate's scaled feature space"
    )
    median_pool_distance: float | None = Field(description="median of that distance over the solution")
    thresholds: dict[str, float] = Field(
        description="gap_tolerance [m], open_gap_force_tolerance [N], contact_std_threshold [N]"
    )
    trust_region_max_std: float | None = Field(
        None, description="the trust region the OCP was solved with: force std bound [N] (null: none)"
    )


class ValidationSuiteRead(BaseModel):
    """The held-out validation suite a campaign's model versions are evaluated on (shared per
    oracle version and suite spec)."""

    id: int
    status: str = Field(description="replaying | complete | failed")
    n_motions: int
    motions_done: int = Field(description="motions replayed and stored")
    replay_wall_time_s: float | None = Field(None, description="first motion queued to last motion stored [s]")
    shared_by: int = Field(description="campaigns evaluated on this suite")
    error: str | None = None
    n_stress_motions: int = Field(
        0, description="of the n_motions, those of the stress part (beyond the task's reach; scored apart)"
    )
    ranges: dict[str, list[float]] = Field(
        default_factory=dict,
        description="the core motions' ranges: start and depth [rad], speed [rad/s], dwell [s], release and reload "
        "[-] (release and reload absent: simple presses)",
    )
    stress_ranges: dict[str, list[float]] | None = Field(None, description="the stress motions' ranges (null: none)")
    n_reference_motions: int = Field(
        0, description="of the n_motions, the best-possible line's training replays (never scored; 0: no line)"
    )
    best_possible_computed: bool = Field(
        False, description="the suite's best-possible line is computed (GET .../validation: best_possible)"
    )


class ValidationReference(BaseModel):
    """An error on (a part of) the held-out validation suite: a reference model's (a line beside
    the campaign's models) or a model version's on the suite's stress part."""

    force_rmse: float = Field(description="sqrt(mean_i |F_pred,i - F_true,i|^2) over all samples of all motions [N]")
    moment_rmse: float = Field(description="the same for the moment vector [N m]")
    components: dict[str, float | None] = Field(description="the " + DESCRIPTIONS["rmse_components"])
    calibration: float | None = Field(None, description=DESCRIPTIONS["calibration"] + "; null: not computed")


class ValidationPoint(BaseModel):
    """Model version k's generalisation error on the held-out validation suite."""

    iteration_index: int = Field(description="k: the iteration whose train step made the model version")
    model_version_id: int
    force_rmse: float = Field(description="sqrt(mean_i |F_pred,i - F_true,i|^2) over all samples of all motions [N]")
    moment_rmse: float = Field(description="the same for the moment vector [N m]")
    components: dict[str, float | None] = Field(description="the " + DESCRIPTIONS["rmse_components"])
    calibration: float | None = Field(
        None,
        description=DESCRIPTIONS["calibration"] + "; over all samples of all motions; null also when not recorded",
    )
    calibration_recorded: bool = Field(
        True,
        description="false: evaluated before migration 0019, which did not compute the calibration (its null does "
        "not mean K = 1)",
    )
    per_motion: list[dict[str, float | str | None]] = Field(
        description="force_rmse, moment_rmse, calibration (evaluations since migration 0019), n_samples of each "
        "motion; part 'stress' on the stress part's motions"
    )
    stress: ValidationReference | None = Field(
        None,
        description="the error on the suite's stress part, over all its samples (the other figures cover the core "
        "motions); null: the suite has no stress part",
    )


class BestPossiblePoint(ValidationReference):
    """The best-possible line at one oracle budget."""

    budget: int = Field(description="oracle calls: the reference replays the model was trained on")


class BestPossibleLine(BaseModel):
    """A suite's best-possible line (alcove.surrogates.reference_line): per oracle budget B, the suite
    error of the default surrogate configuration trained from scratch on the first B replays of
    motions spread over the suite's range (FE data only), computed once per suite."""

    points: list[BestPossiblePoint] = Field(description="by budget")
    replays: int = Field(description="reference replays the oracle stored (a failed one shortens the line)")


class ValidationSeries(BaseModel):
    suite: ValidationSuiteRead | None = Field(description="the campaign's held-out validation suite (null: none)")
    points: list[ValidationPoint] = Field(description="one per own model version evaluated so far, by k")
    aux_law: ValidationReference | None = Field(
        None,
        description="the auxiliary penalty law's own error on the suite (the law the preliminary data come from, "
        "with its default parameters): what a model of the preliminary data alone approaches; null until the "
        "suite is complete",
    )
    best_possible: BestPossibleLine | None = Field(
        None,
        description="the suite's best-possible line at oracle budgets 4, 8, 16, ...; null until computed, or when "
        "the suite has no reference motions",
    )
