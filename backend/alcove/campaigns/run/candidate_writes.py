"""A batch iteration's candidate rows (``iteration_candidates``): what an ocp slot
records about the scenario it solved, and what an oracle slot records about its replay, each in
the transaction that completes the step."""

from __future__ import annotations

from collections.abc import Callable
from datetime import datetime
from typing import Any

from sqlalchemy.orm import Session

from alcove.campaigns import candidate_queries
from alcove.jobs.step_contract import IterationRef
from alcove.models import Campaign, Iteration, OcpSolution, utcnow

#: why a non-selecting strategy's slot is replayed
REPLAYED = {
    "random-scenarios": "random-scenarios: every drawn scenario is replayed",
    "press-family": "press-family: every motion of the family's sequence is replayed",
}


def storing_scenario(
    write: Callable[[Session, IterationRef], dict[str, Any]] | None,
    stored: dict[str, Any] | None,
    features: list[float] | None,
    strategy: str,
) -> Callable[[Session, IterationRef], dict[str, Any]]:
    """The solve's rows, the scenario on the iteration (slot 0's) and, in a batch (``features``
    given), the slot's candidate row: picked at once by random-scenarios (pick = slot); scored by
    ensemble-disagreement (the ensemble's largest force std over the contact phase, from the
    solution's trust diagnostics; 0 without contact) and picked at the fan-in."""

    def with_scenario(s: Session, at: IterationRef) -> dict[str, Any]:
        result = write(s, at) if write is not None else {}
        it = s.get(Iteration, at.iteration_id)
        assert it is not None
        if at.slot == 0:
            it.scenario = stored
        if features is not None:
            converged = bool(result.get("converged"))
            score = None
            if strategy == "ensemble-disagreement" and converged:
                sol = s.get(OcpSolution, result["ocp_solution_id"])
                assert sol is not None
                score = float((sol.stats or {}).get("trust", {}).get("max_std_contact") or 0.0)
            replayed = strategy in ("random-scenarios", "press-family") and converged
            candidate_queries.put_candidate(
                s,
                it.id,
                at.slot,
                scenario=stored,
                ocp_solution_id=result.get("ocp_solution_id"),
                converged=converged,
                score=score,
                features=features,
                pick=at.slot if replayed else None,
                pick_reason=REPLAYED.get(strategy) if replayed else None,
            )
            if score is not None:
                result = {**result, "score": score}
        return {**result, "scenario": stored} if stored is not None else result

    return with_scenario


def recording_replay(
    write: Callable[[Session, IterationRef], dict[str, Any]] | None, raised_since: datetime | None = None
) -> Callable[[Session, IterationRef], dict[str, Any]]:
    """An oracle slot's write, which also adds the oracle's wall time to the campaign's
    (``oracle_budget_s``; an attempt that raised, ``raised_since`` when it started, spent oracle
    time too) and records the replay's run and dataset on the picked candidate's row."""

    def counted(s: Session, at: IterationRef) -> dict[str, Any]:
        result = write(s, at) if write is not None else {}
        c = s.get(Campaign, at.campaign_id)
        assert c is not None
        spent = result.get("wall_time_s", 0.0) if raised_since is None else (utcnow() - raised_since).total_seconds()
        c.oracle_wall_time_s = (c.oracle_wall_time_s or 0.0) + max(float(spent), 0.0)
        cand = candidate_queries.picked_candidate(s, at.iteration_id, at.slot)
        if cand is not None and raised_since is None:
            cand.oracle_run_id, cand.dataset_id = result.get("oracle_run_id"), result.get("dataset_id")
        return result

    return counted
