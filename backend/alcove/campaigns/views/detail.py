"""What a campaign shows: its detail (status, latest metrics, ETA), the metrics series,
iterations, events, an iteration's curves and whole OCP trajectory, the jobs. Reads only."""

from __future__ import annotations

from datetime import datetime
from typing import Any

import numpy as np
from sqlalchemy.orm import Session

from alcove.campaigns import candidate_queries
from alcove.campaigns import repository as repo
from alcove.campaigns.config import config_from_version, current_config
from alcove.campaigns.views.schemas import (
    CampaignDetail,
    CampaignOut,
    CampaignRead,
    EventRead,
    IterationCurves,
    IterationRead,
    IterationTrajectory,
    MetricsRead,
    OcpSolverSummary,
    StepRead,
    TrajectoryPhase,
)
from alcove.campaigns.views.validation import suite_read, with_validation
from alcove.db.arrays import get_arrays
from alcove.errors import NotFound
from alcove.lineage import resolve_iteration
from alcove.models import (
    Campaign,
    CampaignConfigVersion,
    IterationStatus,
    IterationStep,
    OracleVersion,
    StepStatus,
    TaskVersion,
    User,
)
from alcove.oracles import repository as oracles_repo
from alcove.oracles.batch_jobs import with_batch_jobs
from alcove.science.ocp.scenarios import apply_to_spec
from alcove.solving import repository as solving_repo
from alcove.users.access import can_edit


def _metrics_read(m: Any) -> MetricsRead:
    return MetricsRead.model_validate(m).model_copy(update={"components": metric_components(m.extra)})


def metric_components(extra: dict[str, Any] | None) -> dict[str, float | None] | None:
    """The per-component RMSEs an iteration's metrics row keeps in ``extra``: over all samples (fx .. mz)
    and in contact (fx_contact .. mz_contact, where recorded)."""
    overall = (extra or {}).get("rmse_components")
    if not isinstance(overall, dict):
        return None
    contact = (extra or {}).get("rmse_components_contact") or {}
    return {**overall, **{f"{c}_contact": v for c, v in contact.items()}}


def get_detail(s: Session, campaign_id: int) -> CampaignDetail:
    c = repo.get_campaign(s, campaign_id)
    cfg = current_config(s, c)
    it = repo.get_iteration_with_steps(s, c.id, c.current_iteration)
    latest = repo.latest_metrics(s, c.id)
    times = repo.finished_iteration_times(s, c.id)
    done = [
        (k, st, a, b)
        for k, st, a, b in times
        if st in (IterationStatus.succeeded.value, IterationStatus.failed.value) and a and b
    ]
    recent = [(b - a).total_seconds() for _, _, a, b in done[-20:]]
    mean = float(np.mean(recent)) if recent else None
    eta = None
    if mean is not None and cfg.stopping.max_iterations is not None and not c.is_terminal:
        last_done = done[-1][0] if done else (c.source_iteration or 0)
        eta = max(cfg.stopping.max_iterations - last_done, 0) * mean
    return CampaignDetail(
        campaign=CampaignRead.model_validate(c),
        config=cfg,
        current=IterationRead.model_validate(it) if it is not None else None,
        latest_metrics=with_validation(s, [_metrics_read(latest)])[0] if latest is not None else None,
        validation=suite_read(s, c),
        iterations_finished=sum(1 for d in done if d[1] == IterationStatus.succeeded.value),
        iterations_failed=sum(1 for d in done if d[1] == IterationStatus.failed.value),
        mean_iteration_s=mean,
        eta_s=eta,
    )


def get_campaign(s: Session, campaign_id: int) -> CampaignRead:
    return CampaignRead.model_validate(repo.get_campaign(s, campaign_id))


def list_campaigns(s: Session, owner_id: int | None = None) -> list[CampaignRead]:
    return [CampaignRead.model_validate(c) for c in repo.list_campaigns(s, owner_id)]


def metrics_series(
    s: Session, campaign_id: int, after: int | None = None, *, inherited: bool = False
) -> list[MetricsRead]:
    """Per-iteration metrics; ``after=k`` returns only iterations > k (cheap polling). With
    ``inherited``, a fork's series starts with its sources' iterations up to the fork point
    (flagged ``inherited``), as its pool and model lineage does."""
    from alcove.campaigns.views.picks import with_costs

    c = repo.get_campaign(s, campaign_id)
    orm = repo.metrics_series(s, campaign_id, after)
    ids = {m.iteration_index: m.iteration_id for m in orm}
    rows = with_validation(s, [_metrics_read(m) for m in orm])
    if not inherited:
        return with_costs(s, c, rows, ids)
    before: list[MetricsRead] = []
    source, through = c.source_campaign_id, c.source_iteration
    while source is not None and through is not None:
        src = repo.get_campaign(s, source)
        own = [m for m in repo.metrics_series(s, src.id, after) if m.iteration_index <= through]
        ids.update({m.iteration_index: m.iteration_id for m in own})
        before = [_metrics_read(m).model_copy(update={"inherited": True}) for m in own] + before
        source, through = src.source_campaign_id, min(through, src.source_iteration or 0)
    return with_costs(s, c, with_validation(s, before) + rows, ids)


def list_iterations(s: Session, campaign_id: int, after: int | None = None) -> list[IterationRead]:
    return [IterationRead.model_validate(i) for i in repo.list_iterations(s, campaign_id, after)]


def list_events(s: Session, campaign_id: int, after: int = 0) -> list[EventRead]:
    return [EventRead.model_validate(e) for e in repo.events(s, campaign_id, after)]


def iteration_curves(s: Session, campaign_id: int, iteration: int) -> IterationCurves:
    m = repo.metrics_of(s, campaign_id, iteration)
    if m is None or m.curves_sha256 is None:
        raise NotFound("iteration", message=f"campaign {campaign_id} has no evaluated iteration {iteration}")
    a = get_arrays(s, m.curves_sha256)
    tau = a["tau"] if "tau" in a else _replayed_tau(s, m.iteration_id, a["t"])
    return IterationCurves(
        iteration_index=iteration,
        t=a["t"].tolist(),
        q=a["q"].tolist(),
        qd=a["qd"].tolist(),
        tau=None if tau is None else tau.tolist(),
        f_true=a["f_true"].tolist(),
        f_pred=a["f_pred"].tolist(),
        f_std=a["f_std"].tolist() if "f_std" in a else None,
        history=a["history"].tolist() if "history" in a else None,
    )


def no_solution_message(campaign_id: int, iteration: int) -> str:
    return (
        f"campaign {campaign_id} has no OCP solution for iteration {iteration} "
        "(iteration 0 has none; a later one has none until its OCP step ran)"
    )


def iteration_trajectory(s: Session, campaign_id: int, iteration: int, slot: int | None = None) -> IterationTrajectory:
    """Iteration k's whole OCP solution (its latest attempt, converged or not) over every
    phase of the task, with the phase boundaries, the part the oracle replayed and the
    solver summary. An iteration up to a fork's source iteration reads the source's. With
    ``slot``: the solution of that candidate (ocp slot) of a batch iteration, and its scenario."""
    c = repo.get_campaign(s, campaign_id)
    cid, k = resolve_iteration(s, c.id, iteration)
    it = repo.get_iteration(s, cid, k)
    sol = solving_repo.latest_of_iteration(s, it.id, slot or 0) if it is not None else None
    if it is None or sol is None or sol.trajectory_sha256 is None:
        what = no_solution_message(campaign_id, iteration)
        raise NotFound("iteration", message=what if slot is None else f"{what[:-1]}; or has no candidate {slot})")
    scenario = it.scenario
    if slot is not None:
        cand = candidate_queries.candidate_of_slot(s, it.id, slot)
        scenario = cand.scenario if cand is not None else scenario
    owner = c if cid == c.id else s.get(Campaign, cid)
    assert owner is not None  # resolve_iteration() found campaign cid
    task_version = s.get(TaskVersion, owner.task_version_id)
    assert task_version is not None  # a campaign's task version cannot be deleted (foreign key, RESTRICT)
    spec = task_version.spec
    if scenario and scenario.get("values"):  # the phases of the scenario solved (durations may vary)
        spec = apply_to_spec(spec, scenario["values"])
    cv = s.get(CampaignConfigVersion, it.config_version_id) if it.config_version_id else None
    settings = (config_from_version(cv) if cv is not None else current_config(s, owner)).settings
    a = get_arrays(s, sol.trajectory_sha256)
    t = np.asarray(a["t"], float)
    q = np.asarray(a["q"], float).reshape(len(t), -1)
    start = float(t[0]) if len(t) else 0.0
    phases, t0 = [], start
    n_replayed = min(settings.replay_phases, len(spec["phases"]))
    for m, ph in enumerate(spec["phases"]):
        d = float(ph["duration"])
        phases.append(
            TrajectoryPhase(
                index=m, name=ph.get("name") or "", duration=d, t_start=t0, t_end=t0 + d, replayed=m < n_replayed
            )
        )
        t0 += d
    return IterationTrajectory(
        iteration_index=iteration,
        t=t.tolist(),
        q=q.tolist(),
        qd=np.asarray(a["qd"], float).reshape(q.shape).tolist(),
        tau=np.asarray(a["tau"], float).reshape(q.shape).tolist(),
        duration=t0 - start,
        phases=phases,
        replay_phases=n_replayed,
        scenario=scenario,
        slot=sol.slot,
        replay_t_end=phases[n_replayed - 1].t_end,
        replay_dt=settings.replay_dt,
        solver=OcpSolverSummary(
            status=sol.solver_status,
            converged=bool(sol.success),
            iterations=sol.n_iterations,
            cost=sol.cost,
            wall_time_s=sol.wall_time_s,
            attempt=sol.attempt,
            initial_guess=sol.initial_guess,
            message=sol.message or "",
        ),
    )


def _replayed_tau(s: Session, iteration_id: int, t: np.ndarray) -> np.ndarray | None:
    """The joint torque of the motion the oracle replayed in this iteration, on the grid
    ``t`` of the curves (linear, as the replay itself interpolates torque)."""
    sha = oracles_repo.replayed_input(s, iteration_id)
    if sha is None:
        return None
    r = get_arrays(s, sha)
    if r.get("tau") is None:
        return None
    tau = np.asarray(r["tau"], float).reshape(len(r["t"]), -1)
    return np.stack([np.interp(t, r["t"], tau[:, j]) for j in range(tau.shape[1])], -1)


def list_jobs(s: Session, campaign_id: int, statuses: list[str] | None = None) -> list[dict[str, Any]]:
    """Every step row (the unit of Celery work) with its iteration index."""
    repo.get_campaign(s, campaign_id)
    rows = repo.steps_of_campaign(s, campaign_id, statuses)
    with_batch_jobs(s, [r for _, r in rows])
    return [{"iteration": k, **StepRead.model_validate(r).model_dump()} for k, r in rows]


def running_since(row: IterationStep) -> datetime | None:
    return row.started_at if row.status == StepStatus.running.value else None


def campaign_out(s: Session, campaign: Campaign, user: User) -> CampaignOut:
    """The detail as the API shows it to ``user`` (with the definitions' ids and versions)."""
    detail = get_detail(s, campaign.id)
    tv = s.get(TaskVersion, campaign.task_version_id)
    ov = s.get(OracleVersion, campaign.oracle_version_id)
    owner = s.get(User, campaign.owner_id)
    assert tv is not None and ov is not None
    return CampaignOut(
        **detail.model_dump(),
        id=campaign.id,
        owner=owner.email if owner else "",
        can_edit=can_edit(s, campaign, user),
        task_id=tv.definition_id,
        task_version=tv.version,
        oracle_id=ov.definition_id,
        oracle_version=ov.version,
    )
