"""Which domain computes each step of a campaign iteration, and with what.

The protocol (:mod:`alcove.campaigns.run.protocol`) calls ``STEPS[step](context)``. Each entry
resolves the campaign's references for iteration k (task version, pool version k-1, model
version k, the OCP solution to replay, ...; a fork's early versions are its source's) and
calls its domain's one entry point, which computes and returns the rows to write:

=============  =============================================  ===========================
step           computed by                                     writes
=============  =============================================  ===========================
preliminary    :func:`alcove.pool.steps.build_preliminary`     datasets, pool version 0
train          :func:`alcove.surrogates.steps.train`           model version k; the campaign's
                                                               validation suite (found or created:
                                                               :func:`alcove.oracles.validation.attach_suite`)
ocp            :func:`alcove.solving.steps.solve`              OCP solution
oracle         :func:`alcove.oracles.steps.replay`             oracle run, dataset (or quarantine)
evaluate       :func:`alcove.surrogates.steps.evaluate`        iteration metrics and curves; model k's
                                                               generalisation error when the suite is
                                                               complete (:mod:`alcove.surrogates.validation`)
append         :func:`alcove.pool.steps.append`                pool version k; stopping rules
=============  =============================================  ===========================

Seeds derive from the campaign seed and k, and the OCP starts from the previous converged
solution stored in the database, so a step re-run by another worker gives the same rows.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, TypedDict

import numpy as np
from sqlalchemy.orm import Session

from alcove.campaigns import candidate_queries
from alcove.campaigns import repository as repo
from alcove.campaigns.config import current_config
from alcove.campaigns.machine.state_machine import IterationRecord, stop_reason
from alcove.campaigns.run import candidate_writes
from alcove.campaigns.run.step_context import StepContext
from alcove.campaigns.suite import suite_model as validation_suite_model
from alcove.campaigns.suite import suite_spec
from alcove.db import open_transaction
from alcove.jobs.step_contract import (
    FailedAttempt,
    IterationRef,
    StepOutput,
    StepPaused,
    UnusableResult,
    is_cancellation,
)
from alcove.models import (
    Campaign,
    CampaignConfigVersion,
    Iteration,
    OcpSolution,
    StepName,
    SurrogateConfigVersion,
    utcnow,
)
from alcove.oracles import repository as oracles_repo
from alcove.oracles import steps as oracle_steps
from alcove.oracles import validation as oracle_validation
from alcove.oracles.batch_jobs import StepBatchJobs
from alcove.pool import repository as pool_repo
from alcove.pool import steps as pool_steps
from alcove.science.ocp import acquisition
from alcove.science.ocp.scenario_ranges import TILT_PARAMETER
from alcove.science.ocp.scenarios import from_json
from alcove.solving import repository as solving_repo
from alcove.solving import steps as solving_steps
from alcove.surrogates import repository as surrogates_repo
from alcove.surrogates import steps as surrogate_steps
from alcove.surrogates import validation as surrogate_validation
from alcove.surrogates.service import software_versions

if TYPE_CHECKING:
    from alcove.science.geometry import HeadNeckPreset
    from alcove.science.ocp.task_spec import TaskSpec


def _kinematics(task: TaskSpec) -> Any:
    """A chain task's kinematics for the surrogate's features (from its contact body's pose);
    None for the 1-DOF preset, whose features come from the preset as before."""
    if not task.model.is_chain:
        return None
    from alcove.science.surrogate.training import pose_kinematics

    return pose_kinematics(task.model.pose_function())


def derive_seed(campaign_seed: int, iteration: int, salt: int = 0) -> int:
    """A reproducible per-iteration seed (independent streams for different k)."""
    state = np.random.SeedSequence([int(campaign_seed), int(iteration), salt]).generate_state(1, np.uint64)[0]
    return int(state >> np.uint64(2))


def _iteration(s: Session, ctx: StepContext) -> tuple[Campaign, Iteration]:
    c = repo.get_campaign(s, ctx.campaign_id)
    it = repo.get_iteration(s, c.id, ctx.k)
    if it is None:
        raise RuntimeError(f"iteration {ctx.k} does not exist")
    return c, it


def preliminary(ctx: StepContext) -> StepOutput:
    ctx.before_compute()
    pre = ctx.config.preliminary
    with open_transaction() as s:
        c = repo.get_campaign(s, ctx.campaign_id)
        task, seed, oracle_version_id = ctx.task(s, c), c.seed, c.oracle_version_id
    model = task.model
    measured = None
    if pre.family_replays > 0:  # oracle replays of the task's press family beside the auxiliary law
        from alcove.campaigns.run.family_steps import preliminary_replays

        measured = preliminary_replays(ctx, task, seed, oracle_version_id)
    spec = pool_steps.PreliminarySpec(
        samples=pre.samples,
        velocity_bound=pre.velocity_bound,
        seed=seed if pre.seed is None else pre.seed,
        chunks=pre.chunks,
        dataset_ids=pre.dataset_ids,
        meta={"lhs": pre.model_dump(mode="json")},
    )
    if model.is_chain:  # samples over the chain's joint box, the wrench from its head's pose
        return pool_steps.build_preliminary(ctx.run, spec, model.oracle_preset(), model, measured)
    return pool_steps.build_preliminary(ctx.run, spec, model.to_preset(), measured=measured)


class _TrainInputs(TypedDict):
    """What the training step reads in its read transaction (the keywords of surrogates.steps.train)."""

    pool_version_id: int
    spec: dict[str, Any]
    config_version_id: int
    seed: int
    parent_model_id: int | None
    preset: HeadNeckPreset
    lineage: dict[str, Any]
    kinematics: Any


def train(ctx: StepContext) -> StepOutput:
    ctx.before_compute()
    with open_transaction() as s:
        c, it = _iteration(s, ctx)
        cv = s.get(CampaignConfigVersion, it.config_version_id)
        scv = s.get(SurrogateConfigVersion, cv.surrogate_config_version_id) if cv is not None else None
        pv = pool_repo.version_of(s, c.id, ctx.k - 1)
        if pv is None or scv is None:
            raise RuntimeError(f"pool version {ctx.k - 1} or the surrogate config of iteration {ctx.k} does not exist")
        parent = surrogates_repo.version_of(s, c.id, ctx.k - 1)
        task = ctx.task(s, c)
        needs_suite = c.validation_suite_id is None
        inputs: _TrainInputs = {
            "pool_version_id": pv.id,
            "spec": scv.spec,
            "config_version_id": scv.id,
            "seed": derive_seed(c.seed, ctx.k),
            "parent_model_id": parent.id if parent is not None else None,
            "preset": task.model.oracle_preset(),
            "lineage": {"config_version_id": it.config_version_id},
            "kinematics": _kinematics(task),
        }
    out = surrogate_steps.train(ctx.run, **inputs)
    wants_suite = needs_suite and ctx.config.settings.validation_motions > 0
    suite_model = validation_suite_model(task) if wants_suite else None
    spec = suite_spec(ctx.config.settings, task, suite_model) if wants_suite else None
    motions = oracle_validation.motions_for(spec, suite_model) if wants_suite else None

    def write(s: Session, at: IterationRef) -> dict[str, Any]:
        result = out.write(s, at)
        c = repo.get_campaign(s, at.campaign_id)
        if c.validation_suite_id is None:  # the first model of a campaign (or of a fork)
            suite = oracle_validation.attach_suite(s, c, spec, suite_model, motions) if spec is not None else None
            result["validation_suite_id"] = suite.id if suite is not None else None
        return result

    return StepOutput(write, out.compute_s)


def ocp(ctx: StepContext) -> StepOutput:
    if ctx.config.settings.strategy == "press-family":
        from alcove.campaigns.run.family_steps import family_motion

        return family_motion(ctx)
    ctx.before_compute()
    with open_transaction() as s:
        c = repo.get_campaign(s, ctx.campaign_id)
        mv = surrogates_repo.version_of(s, c.id, ctx.k)
        if mv is None:
            raise RuntimeError(f"model version {ctx.k} does not exist")
        previous = solving_repo.previous_converged(s, c.id, ctx.k)
        scenario = ctx.scenario(s, c)
        settings = ctx.config.settings
        batch = (
            settings.batch > 1
            or settings.strategy == "ensemble-disagreement"
            or candidate_queries.has_candidates(s, c.id, ctx.k)
        )
        features = acquisition.scenario_features(ctx.task(s, c), scenario.values) if batch else None
        nominal_preset = ctx.task(s, c).model.oracle_preset()
    # the paper's strategy solves the task as written: nothing to store (null)
    stored = scenario.to_json() if ctx.config.settings.strategy != "paper" else None
    try:
        out = solving_steps.solve(
            ctx.run,
            task=scenario.task,
            model_version_id=mv.id,
            previous_solution_id=previous.id if previous is not None else None,
            initial_guesses=ctx.config.policies.ocp_initial_guesses,
            trust_region_max_std=ctx.config.settings.trust_region_max_std,
            pool_preset=nominal_preset,
        )
    except UnusableResult as err:  # no converged solution: the iteration still shows its scenario
        raise UnusableResult(
            err.reason, candidate_writes.storing_scenario(err.write, stored, features, settings.strategy)
        ) from None
    return StepOutput(candidate_writes.storing_scenario(out.write, stored, features, settings.strategy), out.compute_s)


def oracle(ctx: StepContext) -> StepOutput:
    """The oracle replay; every attempt leaves an oracle run row, also one that raised.
    The oracle's wall time counts toward the campaign's oracle budget."""
    started = utcnow()
    oracle_version_id = None
    try:
        with open_transaction() as s:
            c, it = _iteration(s, ctx)
            oracle_version_id = c.oracle_version_id
            # oracle slot i replays the candidate picked as i (no candidate rows: the one solution)
            cand = candidate_queries.picked_candidate(s, it.id, ctx.ref.slot)
            if cand is not None:
                sol = s.get(OcpSolution, cand.ocp_solution_id) if cand.ocp_solution_id is not None else None
                stored = cand.scenario
            else:
                sol, stored = solving_repo.latest_of_iteration(s, it.id), it.scenario
            if sol is None or not sol.success or sol.trajectory_sha256 is None:
                raise RuntimeError(f"iteration {ctx.k} (oracle slot {ctx.ref.slot}) has no converged OCP solution")
            # the scenario the OCP solved (stored with the iteration): its headrest is the oracle's
            task, solution_id, sha = from_json(ctx.task(s, c), stored), sol.id, sol.trajectory_sha256
            # a prescribed motion is replayed whole (it does not follow the task's phases)
            phases = None if sol.solver_status == solving_steps.PRESCRIBED else ctx.config.settings.replay_phases
            scenario = stored is not None
            # a drawn headrest tilt is recorded with the dataset (its features are relative to it)
            record_tilt = scenario and TILT_PARAMETER in ((stored or {}).get("values") or {})
            step_row = repo.get_step(s, ctx.campaign_id, ctx.ref.iteration, ctx.ref.step.value, ctx.ref.slot)
            batch_jobs = (
                None
                if step_row is None
                else StepBatchJobs(step_row.id, ctx.campaign_id, ctx.run.attempt, ctx.run.worker)
            )
        ctx.before_compute()
        settings = ctx.config.settings
        out = oracle_steps.replay(
            ctx.run,
            task=task,
            oracle_version_id=oracle_version_id,
            solution_id=solution_id,
            trajectory_sha256=sha,
            replay_phases=phases,
            replay_dt=settings.replay_dt,
            scenario=scenario,
            record_tilt=record_tilt,
            batch_jobs=batch_jobs,
        )
    except UnusableResult as err:
        raise UnusableResult(err.reason, candidate_writes.recording_replay(err.write)) from None
    except Exception as err:
        if is_cancellation(err) or isinstance(err, StepPaused) or oracle_version_id is None:
            raise
        message = f"{type(err).__name__}: {err}"
        failed = oracle_steps.failed_run(ctx.run, oracle_version_id, started, message)
        raise FailedAttempt(err, candidate_writes.recording_replay(failed, started)) from err
    return StepOutput(candidate_writes.recording_replay(out.write), out.compute_s)


def evaluate(ctx: StepContext) -> StepOutput:
    ctx.before_compute()
    with open_transaction() as s:
        c, it = _iteration(s, ctx)
        datasets = pool_repo.oracle_datasets(s, it.id)
        if not datasets:
            raise RuntimeError(f"iteration {ctx.k} has no oracle dataset")
        mv = surrogates_repo.version_of(s, c.id, ctx.k)
        if mv is None:
            raise RuntimeError(f"model version {ctx.k} does not exist")
        sol = solving_repo.latest_of_iteration(s, it.id)
        ok_runs = {r.slot: r for r in oracles_repo.runs_of_iteration(s, it.id) if r.status == "ok"}  # latest per slot
        runs = list(ok_runs.values())
        pv_prev = pool_repo.version_of(s, c.id, ctx.k - 1)
        record = {
            "ocp_success": sol.success if sol else None,
            "ocp_status": sol.solver_status if sol else None,
            "ocp_iterations": sol.n_iterations if sol else None,
            "ocp_cost": sol.cost if sol else None,
            "ocp_wall_time_s": sol.wall_time_s if sol else None,
            "ocp_trusted": (sol.stats or {}).get("trust", {}).get("trusted") if sol else None,
            "ocp_trust": (sol.stats or {}).get("trust") if sol else None,
            # the oracle's wall time of the iteration: of its one replay, or the sum over a batch's picks
            "oracle_wall_time_s": (
                runs[-1].wall_time_s if len(runs) == 1 else sum(r.wall_time_s or 0.0 for r in runs) if runs else None
            ),
            "n_pool_samples": pv_prev.n_samples if pv_prev else None,
            "extra": {
                "step_wall_time_s": {
                    (f"{st.step}[{st.slot}]" if st.slot else st.step): st.wall_time_s
                    for st in it.steps
                    if st.wall_time_s is not None
                },
                "config_version_id": it.config_version_id,
            },
        }
        model_version_id, dataset_ids, suite_id = mv.id, [d.id for d in datasets], c.validation_suite_id
        kinematics = _kinematics(ctx.task(s, c))
    evaluated = surrogate_steps.evaluate(
        ctx.run, model_version_id=model_version_id, dataset_ids=dataset_ids, record=record, kinematics=kinematics
    )

    def per_pick(s: Session, at: IterationRef) -> dict[str, Any]:
        result = evaluated.write(s, at)
        for p in result.get("picks", []):  # a batch: the in-loop RMSE and curves of each picked trajectory
            candidate_queries.set_candidate_rmse(
                s, at.iteration_id, p["dataset_id"], p["force_rmse"], p["moment_rmse"], p.get("curves_sha256")
            )
        return result

    out = StepOutput(per_pick, evaluated.compute_s)
    if suite_id is None:
        return out
    # the generalisation error now if the suite is complete; else the suite's completion evaluates it
    validation = surrogate_validation.compute_for_model(model_version_id, suite_id)
    if validation is None:
        return out

    def write(s: Session, at: IterationRef) -> dict[str, Any]:
        result = out.write(s, at)
        surrogate_validation.store_for_model(s, model_version_id, suite_id, validation)
        return {**result, "validation_force_rmse": validation["force_rmse"]}

    return StepOutput(write, out.compute_s)


def append(ctx: StepContext) -> StepOutput:
    """Pool version k, then the stopping rules (as edited now: an edit during the run
    applies at once)."""
    ctx.before_compute()
    out = pool_steps.append(parent_version=ctx.k - 1)

    def write(s: Session, at: IterationRef) -> dict[str, Any]:
        result = out.write(s, at)
        c = repo.get_campaign(s, at.campaign_id)
        history = [IterationRecord(*row) for row in repo.rmse_history(s, c.id)]
        rules = current_config(s, c).stopping
        scores = [cand.score for cand in candidate_queries.candidates(s, at.iteration_id) if cand.score is not None]
        top = max(scores) if scores else None
        calls = repo.oracle_calls(s, c.id)
        streak = repo.failed_streak(s, c.id, ctx.k)
        reason = stop_reason(
            rules, ctx.k, history, c.oracle_wall_time_s or 0.0, top_score=top, oracle_calls=calls, failed_streak=streak
        )
        return {**result, "stop_reason": reason, **software_versions()}

    return StepOutput(write)


STEPS: dict[StepName, Callable[[StepContext], StepOutput]] = {
    StepName.preliminary: preliminary,
    StepName.train: train,
    StepName.ocp: ocp,
    StepName.oracle: oracle,
    StepName.evaluate: evaluate,
    StepName.append: append,
}
