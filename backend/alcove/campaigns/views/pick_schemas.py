"""Schemas of an iteration's candidates and picks (what the user sees): each
candidate with its rank and why it was or was not picked, and the per-pick RMSE of the
metrics series."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field


class _Read(BaseModel):
    model_config = ConfigDict(from_attributes=True)


class CandidateRead(_Read):
    """A scenario the iteration's OCP solved (ocp slot ``slot``) and, if picked, its replay."""

    slot: int = Field(description="the ocp slot (job) that solved it")
    scenario: dict[str, Any] | None = Field(description="seed, iteration, slot, values; null: the task as written")
    converged: bool | None = Field(description="whether its OCP converged")
    score: float | None = Field(None, description="ensemble disagreement over its contact phase [N] (if scored)")
    pick: int | None = Field(description="the oracle slot that replayed it; null: not picked")
    pick_reason: str | None = Field(None, description="why it was picked")
    oracle_run_id: int | None = None
    dataset_id: int | None = None
    force_rmse: float | None = Field(None, description="in-loop force RMSE of model k on its oracle data [N]")
    moment_rmse: float | None = Field(None, description="in-loop moment RMSE [N m]")
    ocp_solution_id: int | None = Field(
        None, description="its OCP solution (the trajectory: .../candidates/{slot}/trajectory)"
    )


WhyCode = Literal[
    "picked-top",
    "picked-far",
    "replayed",
    "not-converged",
    "below-threshold",
    "too-close",
    "batch-full",
    "no-contact",
    "pending",
]


class CandidateWhy(BaseModel):
    """Why a candidate was or was not picked, derived from the acquisition rule
    (:func:`alcove.science.ocp.acquisition.explain_selection`) with the iteration's settings."""

    code: WhyCode = Field(
        description=(
            "picked-top: the highest score; picked-far: the next highest score at least min_distance from every "
            "earlier pick; replayed: random-scenarios replays every converged draw; not-converged: its OCP did not "
            "converge (never picked); below-threshold: the iteration's highest score is below "
            "stopping.min_disagreement, nothing was picked; too-close: closer than min_distance to an earlier pick "
            "(nearest_pick); batch-full: q picks were made before its turn (not in the top q); no-contact: score 0, "
            "its OCP solution never touches the headrest (never picked); pending: the "
            "iteration's candidates are not all solved yet"
        )
    )
    text: str = Field(description="the same for a person, with the figures")
    nearest_pick: int | None = Field(
        None, description="the pick (0 = first) nearest to it in feature space when it was considered"
    )
    distance: float | None = Field(None, description="its distance to that pick (features scaled to [0, 1])")


class CandidateDetail(CandidateRead):
    rank: int | None = Field(description="by descending score (ties: lower slot), 1 = highest; null: not scored")
    features: list[float] | None = Field(None, description="its point in the diversity rule's feature space")
    why: CandidateWhy
    has_curves: bool = Field(False, description="the pick's curves are stored (.../iterations/{k}/picks/{pick}/curves)")


class IterationCandidates(BaseModel):
    """All candidates of an iteration, ranked, with which were picked and why."""

    iteration_index: int
    strategy: str = Field(description="the iteration's acquisition strategy")
    batch: int = Field(description="q: at most this many picks")
    n_candidates: int = Field(description="C: candidate scenarios solved (ensemble-disagreement), else q")
    min_distance: float | None = Field(None, description="ensemble-disagreement: the diversity rule's distance")
    min_disagreement: float | None = Field(None, description="the stopping threshold on the highest score [N]")
    top_score: float | None = Field(None, description="the highest candidate score [N]")
    candidates: list[CandidateDetail] = Field(description="by slot; empty for strategy paper")


class PickRmse(BaseModel):
    pick: int = Field(description="pick order (oracle slot)")
    slot: int = Field(description="the candidate's ocp slot")
    force_rmse: float | None = Field(None, description="model k's force RMSE on this pick's oracle data [N]")
    moment_rmse: float | None = Field(None, description="[N m]")


__all__ = ["CandidateDetail", "CandidateRead", "CandidateWhy", "IterationCandidates", "PickRmse", "WhyCode"]
