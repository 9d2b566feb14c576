"""What a campaign shows of its acquisition: an iteration's candidates ranked, with
why each was or was not picked (:func:`alcove.science.ocp.acquisition.explain_selection` on the
stored scores and features with the iteration's settings), each pick's curves, and the costs
(oracle calls, wall time) the metrics series is plotted against. Reads only."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime

import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove.campaigns import candidate_queries
from alcove.campaigns import repository as repo
from alcove.campaigns.config import config_from_version
from alcove.campaigns.machine.slots import OPEN, ocp_slots
from alcove.campaigns.views.pick_schemas import CandidateDetail, CandidateWhy, IterationCandidates, PickRmse
from alcove.campaigns.views.schemas import IterationCurves, MetricsRead
from alcove.db.arrays import get_arrays
from alcove.errors import NotFound
from alcove.lineage import resolve_iteration
from alcove.models import (
    Campaign,
    CampaignConfigVersion,
    Iteration,
    IterationCandidate,
    IterationMetrics,
    OracleRun,
)
from alcove.science.ocp.acquisition import explain_selection


def _iteration(s: Session, campaign_id: int, k: int) -> Iteration:
    repo.get_campaign(s, campaign_id)
    cid, kk = resolve_iteration(s, campaign_id, k)
    it = repo.get_iteration(s, cid, kk)
    if it is None:
        raise NotFound("iteration", message=f"campaign {campaign_id} has no iteration {k}")
    return it


def _why(
    cands: Sequence[IterationCandidate],
    strategy: str,
    q: int,
    min_distance: float,
    threshold: float | None,
    solved: bool,
) -> list[tuple[int | None, CandidateWhy]]:
    """(rank, why) per candidate row."""
    if strategy != "ensemble-disagreement":  # random-scenarios: every converged draw is replayed
        return [
            (None, CandidateWhy(code="replayed", text=c.pick_reason or "replayed"))
            if c.converged
            else (None, CandidateWhy(code="not-converged", text="its OCP did not converge: not replayed"))
            for c in cands
        ]
    scores = [c.score if c.converged else None for c in cands]
    if not solved:
        return [
            (None, CandidateWhy(code="pending", text="waiting for the other candidates' solves"))
            if sc is not None
            else (None, CandidateWhy(code="not-converged", text="its OCP did not converge: not scored, never picked"))
            for sc in scores
        ]
    width = max((len(c.features or []) for c in cands), default=0)
    features = [list(c.features or [0.0] * width) for c in cands]
    out = []
    for c, v in zip(cands, explain_selection(scores, features, q, min_distance, threshold), strict=True):
        why = CandidateWhy(code=v.code, text=v.reason, nearest_pick=v.nearest_pick, distance=v.distance)
        if v.pick != c.pick:  # the stored selection is what happened (e.g. settings stored before a change)
            why = (
                CandidateWhy(code="picked-top" if c.pick == 0 else "picked-far", text=c.pick_reason or "picked")
                if c.pick is not None
                else CandidateWhy(code="pending", text="not picked by the stored selection")
            )
        out.append((v.rank, why))
    return out


def iteration_candidates(s: Session, campaign_id: int, k: int) -> IterationCandidates:
    """Iteration k's candidates by slot: score, rank, pick and why, the OCP solution and whether
    the pick's curves are stored. Empty for an iteration of strategy ``paper``."""
    it = _iteration(s, campaign_id, k)
    cv = s.get(CampaignConfigVersion, it.config_version_id)
    assert cv is not None
    cfg = config_from_version(cv)
    st = cfg.settings
    cands = candidate_queries.candidates(s, it.id)
    ocp_rows = repo.slot_steps(s, it.id, ["ocp"])
    solved = len(cands) >= ocp_slots(st) and not any(r.status in OPEN for r in ocp_rows)
    solved = solved or any(c.pick is not None for c in cands)
    whys = _why(cands, st.strategy, st.batch, st.min_distance, cfg.stopping.min_disagreement, solved)
    scores = [c.score for c in cands if c.score is not None]
    # the first pick's curves are the metrics row's too (iterations stored before every pick's were kept)
    evaluated = (
        s.scalar(sa.select(IterationMetrics.curves_sha256).where(IterationMetrics.iteration_id == it.id)) is not None
    )
    rows = []
    for c, (rank, why) in zip(cands, whys, strict=True):
        base = {f: getattr(c, f) for f in CandidateDetail.model_fields if hasattr(c, f)}
        rows.append(
            CandidateDetail.model_validate(
                {
                    **base,
                    "rank": rank,
                    "why": why,
                    "has_curves": c.curves_sha256 is not None or (c.pick == 0 and evaluated),
                }
            )
        )
    return IterationCandidates(
        iteration_index=k,
        strategy=st.strategy,
        batch=st.batch,
        n_candidates=ocp_slots(st),
        min_distance=st.min_distance if st.strategy == "ensemble-disagreement" else None,
        min_disagreement=cfg.stopping.min_disagreement,
        top_score=max(scores) if scores else None,
        candidates=rows,
    )


def pick_curves(s: Session, campaign_id: int, k: int, pick: int) -> IterationCurves:
    """Model k's prediction (ensemble mean and std) and the oracle's truth along pick ``pick``
    of iteration k. The first pick's are the metrics row's curves (also for iterations stored
    before every pick's were kept)."""
    it = _iteration(s, campaign_id, k)
    cand = candidate_queries.picked_candidate(s, it.id, pick)
    sha = cand.curves_sha256 if cand is not None else None
    if sha is None and pick == 0:
        m = s.scalar(sa.select(IterationMetrics).where(IterationMetrics.iteration_id == it.id))
        sha = m.curves_sha256 if m is not None else None
    if sha is None:
        raise NotFound("pick", message=f"campaign {campaign_id} has no stored curves of pick {pick} in iteration {k}")
    a = get_arrays(s, sha)
    return IterationCurves(
        iteration_index=k,
        t=a["t"].tolist(),
        q=a["q"].tolist(),
        qd=a["qd"].tolist(),
        f_true=a["f_true"].tolist(),
        f_pred=a["f_pred"].tolist(),
        f_std=a["f_std"].tolist() if "f_std" in a else None,
        history=a["history"].tolist() if "history" in a else None,
        pick=pick,
        slot=cand.slot if cand is not None else 0,
    )


@dataclass(frozen=True)
class Cost:
    index: int
    calls: int
    started: datetime | None
    finished: datetime | None
    evaluated: datetime | None  # the metrics row's creation


def _seconds(a: datetime | None, b: datetime | None) -> float:
    return max((b - a).total_seconds(), 0.0) if a is not None and b is not None else 0.0


def _costs(s: Session, c: Campaign) -> list[Cost]:
    """Iterations 0.. of the campaign's lineage: its sources' up to the fork point, then its own
    (iteration 0's oracle calls are pool version 0's press-family replays, if any)."""
    out: list[Cost] = []
    first = 0
    if c.source_campaign_id is not None and c.source_iteration is not None:
        src = s.get(Campaign, c.source_campaign_id)
        if src is not None:
            out = [r for r in _costs(s, src) if r.index <= c.source_iteration]
        first = c.source_iteration + 1
    calls = (
        sa.select(sa.func.count()).where(OracleRun.iteration_id == Iteration.id).correlate(Iteration).scalar_subquery()
    )
    q = (
        sa.select(Iteration.index, calls, Iteration.started_at, Iteration.finished_at, IterationMetrics.created_at)
        .outerjoin(IterationMetrics, IterationMetrics.iteration_id == Iteration.id)
        .where(Iteration.campaign_id == c.id, Iteration.index >= first)
        .order_by(Iteration.index)
    )
    return out + [Cost(*row) for row in s.execute(q)]


def cumulative_costs(costs: list[Cost]) -> dict[int, tuple[int, int, float]]:
    """Per iteration index: (its oracle calls, the oracle calls of it and every iteration before,
    the wall time of every iteration before from start to end plus its own from its start until
    its evaluation, or its end if it has no metrics row) over ``costs`` in lineage order. Iteration
    0 (the preliminary data) counts its oracle calls (press-family replays), not its wall time."""
    at: dict[int, tuple[int, int, float]] = {}
    calls = 0
    wall = 0.0
    for r in costs:
        own_wall = _seconds(r.started, r.evaluated or r.finished) if r.index > 0 else 0.0
        at[r.index] = (r.calls, calls + r.calls, wall + own_wall)
        calls += r.calls
        wall += _seconds(r.started, r.finished) if r.index > 0 else 0.0
    return at


def with_costs(s: Session, c: Campaign, rows: list[MetricsRead], iteration_ids: dict[int, int]) -> list[MetricsRead]:
    """The series' rows with iteration k's oracle calls, the cumulative oracle calls and wall
    time of iterations 1..k (until model k was evaluated), and each pick's RMSE.
    ``iteration_ids``: iteration index -> iteration id of the rows."""
    at = cumulative_costs(_costs(s, c))
    picks: dict[int, list[PickRmse]] = {}
    if iteration_ids:
        q = (
            sa.select(IterationCandidate)
            .where(
                IterationCandidate.iteration_id.in_(list(iteration_ids.values())), IterationCandidate.pick.is_not(None)
            )
            .order_by(IterationCandidate.iteration_id, IterationCandidate.pick)
        )
        for cand in s.scalars(q):
            assert cand.pick is not None
            picks.setdefault(cand.iteration_id, []).append(
                PickRmse(pick=cand.pick, slot=cand.slot, force_rmse=cand.force_rmse, moment_rmse=cand.moment_rmse)
            )
    out = []
    for m in rows:
        n, cum_calls, cum_wall = at.get(m.iteration_index, (None, None, None))
        own = picks.get(iteration_ids.get(m.iteration_index, -1), [])
        out.append(
            m.model_copy(
                update={
                    "oracle_calls": n,
                    "cumulative_oracle_calls": cum_calls,
                    "cumulative_wall_time_s": cum_wall,
                    "picks": own if len(own) > 1 else [],
                }
            )
        )
    return out


__all__ = ["Cost", "cumulative_costs", "iteration_candidates", "pick_curves", "with_costs"]
