"""Step executors: what a Celery job does for one step of one iteration.

Every job runs :func:`run_step`, the same protocol for all steps:

1. **claim** (one transaction): ``UPDATE iteration_steps SET status='running', attempts=n,
   claim_token=..., lease_until=... WHERE id=... AND status='queued' AND attempts=n-1``. A
   duplicate or stale message matches no row and the job returns ``duplicate``. A
   campaign that is pausing or cancelling does not start the step.
2. **compute** outside any transaction (inputs read in a short read transaction), while a
   :class:`LeaseKeeper` thread extends the lease and reads the cancel flag, which the
   computation checks cooperatively (between epochs, Newton steps, ...).
3. **complete** (one transaction, conditional on still holding the claim token): write the
   results, mark the step, let the state machine decide, create the next step row; the
   next message is sent only after this commit.

Failures: an exception is retried (step back to ``queued``, attempt n+1) until
``max_attempts``; bad input (a ``ValueError`` with a ``field``) is not retried. Then the
step's policy applies: a failed OCP or oracle marks the iteration failed and the campaign
continues with ``append`` (or stops, if configured); other steps fail the campaign. A
result failing the oracle's quality gate is quarantined with its reason, never appended.

Everything is reproducible from the database: seeds derive from the campaign seed and k,
the OCP's initial guess is the previous iteration's stored solution (primal and dual), so
a step re-run by another worker after a crash gives the same rows.
"""

from __future__ import annotations

import json
import logging
import math
import threading
import time
import uuid
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove.campaigns import repository as repo
from alcove.campaigns import service
from alcove.campaigns.schemas import CampaignConfig, StepJob
from alcove.campaigns.state_machine import IterationRecord, Outcome, StepRef, stop_reason
from alcove.db import session_scope, transaction
from alcove.db.arrays import get_arrays, put_arrays
from alcove.models import (
    Campaign,
    CampaignConfigVersion,
    CampaignStatus,
    Iteration,
    IterationMetrics,
    IterationStep,
    ModelVersion,
    OcpSolution,
    OracleRun,
    OracleVersion,
    QuarantinedResult,
    StepName,
    StepStatus,
    SurrogateConfigVersion,
    TaskVersion,
    utcnow,
)
from alcove.pool import service as pool_service
from alcove.science.json_values import json_safe

log = logging.getLogger(__name__)


class StepCancelled(RuntimeError):
    """The campaign's cancel flag was seen during the step."""


class IterationFailure(RuntimeError):
    """The step ran but its result cannot be used (OCP not converged, quarantined oracle
    result): not retried; the on-failure policy decides. ``write`` records what happened."""

    def __init__(self, reason: str, write: Callable[[Session, Campaign, Iteration], dict[str, Any]] | None = None):
        super().__init__(reason)
        self.reason = reason
        self.write = write


@dataclass
class StepContext:
    campaign_id: int
    ref: StepRef
    attempt: int
    step_id: int
    token: str
    worker: str
    config: CampaignConfig
    cancel_flag: Callable[[], bool] = lambda: False

    def cancelled(self) -> bool:
        return self.cancel_flag()

    def check_cancel(self) -> None:
        if self.cancel_flag():
            raise StepCancelled(f"step {self.ref} cancelled")

    @property
    def fault(self) -> dict[str, Any]:
        f = self.config.settings.fault_injection.get(self.ref.step.value) or {}
        its = f.get("iterations")
        return f if its is None or self.ref.iteration in its else {}


WriteFn = Callable[[Session, Campaign, Iteration], tuple[dict[str, Any], str | None]]


@dataclass
class StepOutput:
    write: WriteFn
    compute_s: float = 0.0
    extra: dict[str, Any] = field(default_factory=dict)


# ----------------------------------------------------------------------------- lease keeper


class LeaseKeeper(threading.Thread):
    """Extends the step's lease every ``interval`` s and caches the campaign's cancel flag."""

    def __init__(self, step_id: int, token: str, lease_seconds: float, interval: float):
        super().__init__(name=f"alcove-lease-{step_id}", daemon=True)
        self.step_id, self.token, self.lease_seconds, self.interval = step_id, token, lease_seconds, interval
        self.cancel_requested = False
        self.lost = False
        self._stop_event = threading.Event()

    def run(self) -> None:
        while not self._stop_event.wait(self.interval):
            try:
                ours, cancel = transaction(lambda s: repo.extend_lease(s, self.step_id, self.token, self.lease_seconds))
                self.cancel_requested = self.cancel_requested or cancel
                if not ours:
                    self.lost = True
                    self.cancel_requested = True  # someone else owns the step now: stop working on it
                    return
            except Exception:
                log.exception("lease heartbeat of step %s failed", self.step_id)

    def stop(self) -> None:
        self._stop_event.set()


def lease_seconds() -> float:
    from alcove.settings import get_settings

    return float(get_settings().job_lease_seconds)


# ----------------------------------------------------------------------------- the protocol


def run_step(
    campaign_id: int,
    iteration: int,
    step: str,
    attempt: int,
    *,
    worker_name: str = "local",
    send: Callable[[list[StepJob]], Any] | None = None,
) -> dict[str, Any]:
    """Run one step message. Returns a small status dict (for logs and tests)."""
    from alcove.jobs.campaign import enqueue

    send = send or enqueue
    t_job = time.perf_counter()
    ref = StepRef(iteration, StepName(step))
    token = uuid.uuid4().hex
    lease = lease_seconds()

    claimed = transaction(lambda s: _claim(s, campaign_id, ref, attempt, token, worker_name, lease))
    status, step_id, config, jobs = claimed
    if status != "claimed":
        if jobs:
            send(jobs)
        return {"status": status, "step": str(ref), "attempt": attempt}
    assert step_id is not None and config is not None
    t_claimed = time.perf_counter()
    keeper = LeaseKeeper(step_id, token, lease, interval=max(0.5, lease / 4))
    keeper.start()
    ctx = StepContext(
        campaign_id, ref, attempt, step_id, token, worker_name, config, cancel_flag=lambda: keeper.cancel_requested
    )
    output: StepOutput | None = None
    failure: tuple[Outcome | None, str, Any] | None = None
    try:
        t0 = time.perf_counter()
        output = EXECUTORS[ref.step](ctx)
        output.compute_s = output.compute_s or (time.perf_counter() - t0)
    except StepCancelled as err:
        failure = (Outcome.cancelled, str(err), None)
    except IterationFailure as err:
        failure = (_policy_outcome(config, ref), err.reason, err.write)
    except Exception as err:
        if _is_cancel(err):
            failure = (Outcome.cancelled, str(err), None)
        else:
            log.exception("step %s of campaign %s failed (attempt %d)", ref, campaign_id, attempt)
            failure = (None, f"{type(err).__name__}: {err}", _bad_input(err))
    finally:
        keeper.stop()
    if keeper.lost:
        return {"status": "lost", "step": str(ref), "attempt": attempt}

    t_done = time.perf_counter()
    timing = {"claim_s": t_claimed - t_job, "compute_s": output.compute_s if output else t_done - t_claimed}

    def complete(s: Session) -> list[StepJob] | None:
        row = repo.owned_running_step(s, step_id, token)
        if row is None:
            return None  # the reconciler gave the step to another job
        c = repo.get_campaign(s, campaign_id, lock=True)
        it = s.get(Iteration, row.iteration_id)
        assert it is not None
        wall = time.perf_counter() - t_job
        base = {**timing, "worker": worker_name, "queue_latency_s": _latency(row)}
        if output is not None:
            result, reason = output.write(s, c, it)
            base["write_s"] = time.perf_counter() - t_done
            return service.complete_step(
                s,
                c,
                ref,
                row,
                Outcome.succeeded,
                result={**base, **output.extra, **result},
                stop_reason=reason,
                wall_time_s=wall,
            )
        outcome, message, extra = failure  # type: ignore[misc]
        if outcome is None:  # an exception: retry while attempts remain (unless bad input)
            bad_input = extra
            if ref.step is StepName.oracle:  # every oracle attempt leaves a run row
                s.add(
                    OracleRun(
                        campaign_id=c.id,
                        iteration_id=it.id,
                        oracle_version_id=c.oracle_version_id,
                        attempt=row.attempts,
                        status="failed",
                        worker_name=worker_name,
                        started_at=row.started_at,
                        finished_at=utcnow(),
                        failure_reason=message,
                    )
                )
            if row.attempts < row.max_attempts and not bad_input:
                return _requeue(s, c, ref, row, message)
            outcome = _policy_outcome(config, ref)
        elif callable(extra):
            extra(s, c, it)
        return service.complete_step(s, c, ref, row, outcome, result=base, error=message, wall_time_s=wall)

    jobs = transaction(complete)
    if jobs is None:
        return {"status": "lost", "step": str(ref), "attempt": attempt}
    send(jobs)
    return {
        "status": "done" if failure is None else ("cancelled" if failure[0] is Outcome.cancelled else "failed"),
        "step": str(ref),
        "attempt": attempt,
        "next": [f"{j.iteration}/{j.step.value}#{j.attempt}" for j in jobs],
        **timing,
        "total_s": time.perf_counter() - t_job,
    }


def _claim(s: Session, campaign_id: int, ref: StepRef, attempt: int, token: str, worker: str, lease: float):
    row = repo.get_step(s, campaign_id, ref.iteration, ref.step.value)
    if row is None:
        return "missing", None, None, []
    if row.status != StepStatus.queued.value or row.attempts != attempt - 1:
        return "duplicate", None, None, []
    c = repo.get_campaign(s, campaign_id, lock=True)
    if c.is_terminal:
        row.status, row.finished_at = StepStatus.cancelled.value, utcnow()
        return "cancelled", None, None, []
    if c.cancel_requested:
        return (
            "cancelled",
            None,
            None,
            service.complete_step(s, c, ref, row, Outcome.cancelled, error="cancelled before it started"),
        )
    if c.pause_requested or c.status in (CampaignStatus.pausing.value, CampaignStatus.paused.value):
        row.status = StepStatus.pending.value
        service.apply_decision(s, c, service.Decision(CampaignStatus.paused), note="paused before the next step")
        return "paused", None, None, []
    if not repo.claim_step(s, row.id, attempt, token, worker, lease):
        return "duplicate", None, None, []
    if c.status == CampaignStatus.queued.value:
        service.apply_decision(s, c, service.Decision(CampaignStatus.running), note="first step claimed")
    it = s.get(Iteration, row.iteration_id)
    cv = s.get(CampaignConfigVersion, row.config_version_id or it.config_version_id)
    config = service.config_from_version(cv) if cv is not None else service.current_config(s, c)
    repo.add_event(
        s, campaign_id, "step_started", worker, iteration=ref.iteration, step=ref.step.value, data={"attempt": attempt}
    )
    return "claimed", row.id, config, []


def _requeue(s: Session, c: Campaign, ref: StepRef, row: IterationStep, message: str) -> list[StepJob]:
    row.status = StepStatus.queued.value
    row.error = message
    row.claim_token = None
    row.lease_until = None
    row.queued_at = utcnow()
    repo.add_event(
        s, c.id, "step_retry", message, iteration=ref.iteration, step=ref.step.value, data={"attempt": row.attempts}
    )
    return [StepJob(campaign_id=c.id, iteration=ref.iteration, step=ref.step, attempt=row.attempts + 1)]


def _latency(row: IterationStep) -> float | None:
    if row.queued_at and row.started_at:
        return max((row.started_at - row.queued_at).total_seconds(), 0.0)
    return None


def _policy_outcome(config: CampaignConfig, ref: StepRef) -> Outcome:
    p = config.policies
    if ref.step is StepName.ocp:
        return Outcome.iteration_failed if p.ocp_on_failure == "continue" else Outcome.failed
    if ref.step is StepName.oracle:
        return Outcome.iteration_failed if p.oracle_on_failure == "continue" else Outcome.failed
    return Outcome.failed


def _is_cancel(err: BaseException) -> bool:
    return type(err).__name__ in ("OracleCancelled", "TrainingCancelled", "StepCancelled")


def _bad_input(err: BaseException) -> bool:
    """Errors that name a field (the science modules' input errors) will not go away on retry."""
    return isinstance(err, ValueError) and hasattr(err, "field")


# ----------------------------------------------------------------------------- shared loaders

_task_cache: dict[tuple[int, int | None], Any] = {}
_oracle_cache: OrderedDict[tuple[str, str, str], Any] = OrderedDict()


def derive_seed(campaign_seed: int, iteration: int, salt: int = 0) -> int:
    """A reproducible per-iteration seed (independent streams for different k)."""
    return int(
        np.random.SeedSequence([int(campaign_seed), int(iteration), salt]).generate_state(1, np.uint64)[0]
        >> np.uint64(2)
    )


def load_task(s: Session, c: Campaign, config: CampaignConfig):
    from alcove.science.ocp.task_spec import parse_task

    key = (c.task_version_id, config.settings.ocp_intervals)
    task = _task_cache.get(key)
    if task is None:
        tv = s.get(TaskVersion, c.task_version_id)
        task = parse_task(tv.spec)
        if config.settings.ocp_intervals:
            task = task.with_intervals(config.settings.ocp_intervals)
        _task_cache[key] = task
    return task


def load_oracle(s: Session, c: Campaign, preset: Any):
    """The campaign's oracle, built once per worker process (an FE oracle builds its mesh once)."""
    from alcove.science.oracles.registry import build_oracle

    ov = s.get(OracleVersion, c.oracle_version_id)
    key = (ov.oracle_type, ov.spec_hash, json.dumps(preset.to_dict(), sort_keys=True))
    oracle = _oracle_cache.get(key)
    if oracle is None:
        catalogue = None
        if ov.oracle_type not in ("fe-headrest-2d", "aux-penalty"):
            catalogue = _command_catalogue(s)
        oracle = build_oracle(ov.oracle_type, ov.spec, preset, catalogue=catalogue)
        _oracle_cache[key] = oracle
        while len(_oracle_cache) > 4:
            _oracle_cache.popitem(last=False)
    return oracle


def _command_catalogue(s: Session):
    """Command oracles: the settings' YAML catalogue plus the admins' enabled entries."""
    from alcove.oracles.service import command_catalogue

    return command_catalogue(s)


def software_versions() -> dict[str, Any]:
    """Code and library versions recorded with every iteration (and every model version)."""
    from alcove.surrogates.service import code_version, library_versions

    return {"code_version": code_version(), "library_versions": library_versions()}


def _fault(ctx: StepContext) -> dict[str, Any]:
    f = ctx.fault
    if f.get("sleep_s"):
        end = time.monotonic() + float(f["sleep_s"])
        while time.monotonic() < end:
            ctx.check_cancel()
            time.sleep(0.05)
    if f.get("raise_attempts") and ctx.attempt <= int(f["raise_attempts"]):
        raise RuntimeError(f"fault injection: {ctx.ref.step.value} raises on attempt {ctx.attempt}")
    return f


def _read(fn: Callable[[Session], Any]) -> Any:
    with session_scope() as s:
        return fn(s)


# ----------------------------------------------------------------------------- preliminary (iteration 0)


def execute_preliminary(ctx: StepContext) -> StepOutput:
    _fault(ctx)
    pre = ctx.config.preliminary

    def inputs(s: Session) -> tuple[Any, int, list[int] | None]:
        c = repo.get_campaign(s, ctx.campaign_id)
        return load_task(s, c, ctx.config).preset(), c.seed, pre.dataset_ids

    preset, seed, dataset_ids = _read(inputs)
    pool = None
    if not dataset_ids:
        from alcove.science.surrogate.preliminary import preliminary_pool

        pool = preliminary_pool(
            preset,
            samples=pre.samples,
            velocity_bound=pre.velocity_bound,
            seed=seed if pre.seed is None else pre.seed,
            chunks=pre.chunks,
        )

    def write(s: Session, c: Campaign, it: Iteration) -> tuple[dict[str, Any], str | None]:
        if pool is not None:
            new = [
                pool_service.store_dataset(
                    s,
                    t=d.t,
                    q=d.q,
                    qd=d.qd,
                    f=np.hstack([d.force, d.moment]),
                    origin="preliminary",
                    name=d.name,
                    campaign_id=c.id,
                    iteration_id=it.id,
                    meta={"lhs": pre.model_dump(mode="json")},
                )
                for d in pool
            ]
        else:
            from alcove.pool.repository import datasets

            new = datasets(s, list(dataset_ids or []))
        pv = pool_service.create_version(
            s, campaign_id=c.id, iteration_id=it.id, version=0, parent=None, new_datasets=new
        )
        return {"pool_version_id": pv.id, "n_datasets": pv.n_datasets, "n_samples": pv.n_samples}, None

    return StepOutput(write)


# ----------------------------------------------------------------------------- train


def execute_train(ctx: StepContext) -> StepOutput:
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import TrainingCancelled, train_surrogate
    from alcove.surrogates.service import load_model, store_model

    _fault(ctx)
    k = ctx.ref.iteration

    def inputs(s: Session) -> dict[str, Any]:
        c = repo.get_campaign(s, ctx.campaign_id)
        it = repo.get_iteration(s, c.id, k)
        cv = s.get(CampaignConfigVersion, it.config_version_id)
        scv = s.get(SurrogateConfigVersion, cv.surrogate_config_version_id)
        pv = repo.pool_version(s, c, k - 1)
        if pv is None:
            raise RuntimeError(f"pool version {k - 1} does not exist")
        parent = repo.model_version(s, c, k - 1)
        config = SurrogateConfig.parse(scv.spec)
        return {
            "preset": load_task(s, c, ctx.config).preset(),
            "pool": pool_service.load_training_pool(s, pv),
            "pool_version_id": pv.id,
            "config": config,
            "scv_id": scv.id,
            "seed": derive_seed(c.seed, k),
            "parent_id": parent.id if parent else None,
            "warm": load_model(s, parent) if parent is not None and config.warm_start else None,
        }

    d = _read(inputs)
    t0 = time.perf_counter()
    try:
        result = train_surrogate(
            d["pool"], d["config"], d["seed"], warm_start=d["warm"], cancel=ctx.cancelled, preset=d["preset"]
        )
    except TrainingCancelled as err:
        raise StepCancelled(str(err)) from None
    compute = time.perf_counter() - t0

    def write(s: Session, c: Campaign, it: Iteration) -> tuple[dict[str, Any], str | None]:
        mv = store_model(
            s,
            result,
            campaign_id=c.id,
            iteration_id=it.id,
            version=k,
            pool_version_id=d["pool_version_id"],
            parent_model_id=d["parent_id"],
            surrogate_config_version_id=d["scv_id"],
            seed=d["seed"],
            lineage={"config_version_id": it.config_version_id},
        )
        return {
            "model_version_id": mv.id,
            "pool_version_id": d["pool_version_id"],
            "test_force_rmse": mv.test_force_rmse,
            "test_moment_rmse": mv.test_moment_rmse,
            "epochs": result.metrics.epochs,
        }, None

    return StepOutput(write, compute_s=compute)


# ----------------------------------------------------------------------------- ocp


def _stored_solution(s: Session, sol_row: OcpSolution | None, task: Any) -> Any:
    """The previous iteration's converged solution rebuilt from the database (initial guess)."""
    from alcove.science.ocp.solve import OcpSolution as Solution

    if sol_row is None or not sol_row.success or sol_row.trajectory_sha256 is None:
        return None
    a = get_arrays(s, sol_row.trajectory_sha256)
    if "x" not in a:
        return None
    return Solution(
        t=a["t"],
        q=a["q"],
        qd=a["qd"],
        controls=a["controls"],
        status=sol_row.solver_status,
        converged=True,
        iterations=sol_row.n_iterations or 0,
        cost=sol_row.cost or 0.0,
        constraint_violation=0.0,
        wall_time=0.0,
        chain=task.chain(),
        task_name=task.name,
        x=a["x"],
        lam_x=a["lam_x"],
        lam_g=a["lam_g"],
    )


def _previous_converged_solution(s: Session, c: Campaign, k: int) -> OcpSolution | None:
    """The latest converged OCP solution of an iteration before k (this campaign or its source)."""
    for j in range(k - 1, 0, -1):
        cid, jj = repo.resolve_source(s, c, j)  # type: ignore[misc]
        row = s.scalar(
            sa.select(OcpSolution)
            .join(Iteration, Iteration.id == OcpSolution.iteration_id)
            .where(Iteration.campaign_id == cid, Iteration.index == jj, OcpSolution.success.is_(True))
            .order_by(OcpSolution.attempt.desc())
            .limit(1)
        )
        if row is not None:
            return row
        if k - j > 20:
            break
    return None


def execute_ocp(ctx: StepContext) -> StepOutput:
    from alcove.science.ocp.solve import solve_task
    from alcove.science.surrogate.export import surrogate_contact
    from alcove.surrogates.service import load_model

    fault = _fault(ctx)
    k = ctx.ref.iteration

    def inputs(s: Session) -> dict[str, Any]:
        c = repo.get_campaign(s, ctx.campaign_id)
        task = load_task(s, c, ctx.config)
        mv = repo.model_version(s, c, k)
        if mv is None:
            raise RuntimeError(f"model version {k} does not exist")
        return {
            "task": task,
            "model": load_model(s, mv),
            "model_version_id": mv.id,
            "previous": _stored_solution(s, _previous_converged_solution(s, c, k), task),
        }

    d = _read(inputs)
    ctx.check_cancel()
    task = d["task"]
    t0 = time.perf_counter()
    # weights as NLP parameters: the NLP and IPOPT solver of this architecture are reused across iterations
    contact, contact_params = surrogate_contact(d["model"], task.preset())
    ipopt = {"ipopt.max_iter": int(fault["ipopt_max_iter"])} if fault.get("ipopt_max_iter") else None
    sol = solve_task(
        task,
        contact,
        initial_guess=d["previous"],
        contact_params=contact_params,
        max_attempts=ctx.config.policies.ocp_initial_guesses,
        ipopt_options=ipopt,
        on_attempt=lambda _attempt: ctx.check_cancel(),
    )  # cancel between IPOPT runs
    compute = time.perf_counter() - t0
    arrays = {"t": sol.t, "q": sol.q, "qd": sol.qd, "tau": sol.tau, "controls": sol.controls}
    if sol.converged and sol.x is not None:
        arrays.update(
            x=np.asarray(sol.x, float).ravel(),
            lam_x=np.asarray(sol.lam_x, float).ravel(),
            lam_g=np.asarray(sol.lam_g, float).ravel(),
        )

    def record(s: Session, c: Campaign, it: Iteration) -> dict[str, Any]:
        sha = put_arrays(s, arrays)
        row = OcpSolution(
            campaign_id=c.id,
            iteration_id=it.id,
            model_version_id=d["model_version_id"],
            attempt=ctx.attempt,
            initial_guess=sol.attempts[-1]["guess"] if sol.attempts else "default",
            success=bool(sol.converged),
            solver_status=sol.status,
            n_iterations=int(sol.iterations),
            cost=float(sol.cost) if math.isfinite(sol.cost) else None,
            wall_time_s=float(sol.wall_time),
            message="" if sol.converged else f"no converged solution after {len(sol.attempts)} initial guess(es)",
            stats=json_safe(sol.summary()),
            trajectory_sha256=sha,
        )
        s.add(row)
        s.flush()
        return {
            "ocp_solution_id": row.id,
            "converged": bool(sol.converged),
            "status": sol.status,
            "iterations": int(sol.iterations),
            "cost": json_safe(sol.cost),
        }

    if not sol.converged:
        raise IterationFailure(
            f"OCP did not converge ({sol.status}) after {len(sol.attempts)} initial guess(es)", write=record
        )
    return StepOutput(lambda s, c, it: (record(s, c, it), None), compute_s=compute)


# ----------------------------------------------------------------------------- oracle


def replay_trajectory(arrays: dict[str, np.ndarray], task: Any, phases: int, dt: float | None) -> Any:
    """The first ``phases`` phases of the OCP solution; resampled at ``dt`` with cubic
    Hermite interpolation (q and its derivative qd), torque linear."""
    from scipy.interpolate import CubicHermiteSpline

    from alcove.science.series import Trajectory

    t, q, qd, tau = arrays["t"], arrays["q"], arrays["qd"], arrays["tau"]
    t_end = t[0] + sum(ph.duration for ph in task.phases[:phases])
    if dt is None:
        m = t <= t_end + 1e-9
        return Trajectory(t[m], q[m], qd[m], tau[m])
    # a grid of step dt from t0 to t_end (t_end included)
    n = math.floor((t_end - t[0]) / dt + 1e-9) + 1
    grid = np.minimum(t[0] + dt * np.arange(n), t_end)
    spline = CubicHermiteSpline(t, q, qd, axis=0)
    tau_g = np.stack([np.interp(grid, t, tau[:, j]) for j in range(q.shape[1])], -1)
    q_g = spline(grid)
    preset = task.preset()
    if q.shape[1] == 1 and hasattr(preset, "theta_min"):
        # the cubic may overshoot the joint range between nodes that sit on a bound
        q_g = np.clip(q_g, preset.theta_min, preset.theta_max)
    return Trajectory(grid, q_g, spline.derivative()(grid), tau_g)


def execute_oracle(ctx: StepContext) -> StepOutput:
    fault = _fault(ctx)
    k = ctx.ref.iteration

    def inputs(s: Session) -> dict[str, Any]:
        c = repo.get_campaign(s, ctx.campaign_id)
        it = repo.get_iteration(s, c.id, k)
        sol = repo.latest_ocp_solution(s, it.id)
        if sol is None or not sol.success:
            raise RuntimeError(f"iteration {k} has no converged OCP solution")
        task = load_task(s, c, ctx.config)
        return {
            "task": task,
            "oracle": load_oracle(s, c, task.preset()),
            "arrays": get_arrays(s, sol.trajectory_sha256),
            "ocp_solution_id": sol.id,
            "oracle_version_id": c.oracle_version_id,
        }

    d = _read(inputs)
    traj = replay_trajectory(d["arrays"], d["task"], ctx.config.settings.replay_phases, ctx.config.settings.replay_dt)
    started = utcnow()
    t0 = time.perf_counter()
    res = d["oracle"].run(traj, cancel=ctx.cancelled)
    compute = time.perf_counter() - t0
    ok = bool(res.ok) and not fault.get("gate_fail")
    reason = (
        res.failure_reason
        if not res.ok
        else ("fault injection: quality gate failed" if fault.get("gate_fail") else None)
    )
    diagnostics = json_safe(res.diagnostics)

    def record(s: Session, c: Campaign, it: Iteration) -> dict[str, Any]:
        in_sha = put_arrays(s, {"t": traj.t, "q": traj.q, "qd": traj.qd, "tau": traj.tau})
        out_sha = (
            put_arrays(s, {"t": res.forces.t, "f": np.hstack([res.forces.force, res.forces.moment])})
            if res.forces is not None
            else None
        )
        run = OracleRun(
            campaign_id=c.id,
            iteration_id=it.id,
            oracle_version_id=d["oracle_version_id"],
            ocp_solution_id=d["ocp_solution_id"],
            attempt=ctx.attempt,
            status="ok" if ok else "quarantined",
            worker_name=ctx.worker,
            started_at=started,
            finished_at=utcnow(),
            wall_time_s=float(res.wall_time),
            failure_reason=reason,
            diagnostics=diagnostics,
            input_sha256=in_sha,
            output_sha256=out_sha,
        )
        s.add(run)
        s.flush()
        c.oracle_wall_time_s = (c.oracle_wall_time_s or 0.0) + float(res.wall_time)
        out: dict[str, Any] = {"oracle_run_id": run.id, "ok": ok, "wall_time_s": float(res.wall_time)}
        if ok:
            f = res.forces
            on_grid = (
                traj.resample(f.t)
                if (len(f.t) != len(traj.t) or not np.allclose(f.t, traj.t, rtol=0, atol=1e-12))
                else traj
            )
            ds = pool_service.store_dataset(
                s,
                t=f.t,
                q=on_grid.q,
                qd=on_grid.qd,
                f=np.hstack([f.force, f.moment]),
                origin="oracle",
                name=f"iteration-{k:04d}",
                campaign_id=c.id,
                iteration_id=it.id,
                oracle_run_id=run.id,
                meta={"oracle_version_id": d["oracle_version_id"]},
            )
            out["dataset_id"] = ds.id
        else:
            s.add(
                QuarantinedResult(
                    oracle_run_id=run.id,
                    campaign_id=c.id,
                    iteration_id=it.id,
                    reason=reason or "quality gate failed",
                    gate=diagnostics,
                    output_sha256=out_sha,
                )
            )
            out["quarantined"] = reason
        return out

    if not ok:
        raise IterationFailure(f"oracle result quarantined: {reason}", write=record)
    return StepOutput(lambda s, c, it: (record(s, c, it), None), compute_s=compute)


# ----------------------------------------------------------------------------- evaluate


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


def execute_evaluate(ctx: StepContext) -> StepOutput:
    from alcove.science.surrogate.training import predict
    from alcove.surrogates.service import load_model

    _fault(ctx)
    k = ctx.ref.iteration

    def inputs(s: Session) -> dict[str, Any]:
        c = repo.get_campaign(s, ctx.campaign_id)
        it = repo.get_iteration(s, c.id, k)
        ds = repo.iteration_dataset(s, it.id)
        if ds is None:
            raise RuntimeError(f"iteration {k} has no oracle dataset")
        mv = repo.model_version(s, c, k)
        return {"arrays": pool_service.dataset_arrays(s, ds), "dataset_id": ds.id, "model": load_model(s, mv), "mv": mv}

    d = _read(inputs)
    a = d["arrays"]
    pred = predict(d["model"], a["t"], a["q"], a["qd"])
    f_pred = np.hstack([pred.force, pred.moment])
    f_true = a["f"]
    err = f_pred - f_true
    metrics = {
        "force_rmse": rmse(f_pred[:, :3], f_true[:, :3]),
        "moment_rmse": rmse(f_pred[:, 3:], f_true[:, 3:]),
        "force_max_error": float(np.linalg.norm(err[:, :3], axis=1).max()),
        "moment_max_error": float(np.linalg.norm(err[:, 3:], axis=1).max()),
    }
    per_component = {c: rmse(f_pred[:, j], f_true[:, j]) for j, c in enumerate(pool_service.FORCE_COLUMNS)}

    def write(s: Session, c: Campaign, it: Iteration) -> tuple[dict[str, Any], str | None]:
        sol = repo.latest_ocp_solution(s, it.id)
        runs = [r for r in repo.oracle_runs(s, it.id) if r.status == "ok"]
        pv_prev = repo.pool_version(s, c, k - 1)
        timings = {st.step: st.wall_time_s for st in it.steps if st.wall_time_s is not None}
        curves = put_arrays(s, {"t": a["t"], "q": a["q"], "qd": a["qd"], "f_true": f_true, "f_pred": f_pred})
        mv: ModelVersion = d["mv"]
        m = IterationMetrics(
            campaign_id=c.id,
            iteration_id=it.id,
            iteration_index=k,
            model_version_id=mv.id,
            dataset_id=d["dataset_id"],
            **metrics,
            ocp_success=sol.success if sol else None,
            ocp_status=sol.solver_status if sol else None,
            ocp_iterations=sol.n_iterations if sol else None,
            ocp_cost=sol.cost if sol else None,
            ocp_wall_time_s=sol.wall_time_s if sol else None,
            oracle_wall_time_s=runs[-1].wall_time_s if runs else None,
            train_wall_time_s=mv.train_wall_time_s,
            n_pool_samples=pv_prev.n_samples if pv_prev else None,
            extra={
                **software_versions(),
                "model_seed": mv.seed,
                "rmse_components": per_component,
                "step_wall_time_s": timings,
                "n_samples": len(a["t"]),
                "model_test_rmse": {"force": mv.test_force_rmse, "moment": mv.test_moment_rmse},
                "config_version_id": it.config_version_id,
            },
            curves_sha256=curves,
        )
        s.add(m)
        s.flush()
        return {"metrics_id": m.id, **metrics}, None

    return StepOutput(write)


# ----------------------------------------------------------------------------- append


def execute_append(ctx: StepContext) -> StepOutput:
    _fault(ctx)
    k = ctx.ref.iteration

    def write(s: Session, c: Campaign, it: Iteration) -> tuple[dict[str, Any], str | None]:
        parent = repo.pool_version(s, c, k - 1)
        if parent is None:
            raise RuntimeError(f"pool version {k - 1} does not exist")
        ds = repo.iteration_dataset(s, it.id)
        pv = pool_service.create_version(
            s,
            campaign_id=c.id,
            iteration_id=it.id,
            version=k,
            parent=parent,
            new_datasets=[ds] if ds is not None else [],
        )
        history = [IterationRecord(*row) for row in repo.rmse_history(s, c.id)]
        rules = service.current_config(s, c).stopping  # stopping rules edited during the run apply at once
        reason = stop_reason(rules, k, history, c.oracle_wall_time_s or 0.0)
        return {
            "pool_version_id": pv.id,
            "n_datasets": pv.n_datasets,
            "n_samples": pv.n_samples,
            "appended": ds.id if ds else None,
            "stop_reason": reason,
            **software_versions(),
        }, reason

    return StepOutput(write)


EXECUTORS: dict[StepName, Callable[[StepContext], StepOutput]] = {
    StepName.preliminary: execute_preliminary,
    StepName.train: execute_train,
    StepName.ocp: execute_ocp,
    StepName.oracle: execute_oracle,
    StepName.evaluate: execute_evaluate,
    StepName.append: execute_append,
}


# ----------------------------------------------------------------------------- in-process driver (tests, benchmarks)


def drive_inline(campaign_id: int, jobs: list[StepJob], *, max_steps: int = 100_000) -> int:
    """Run step jobs in this process until none is left (no Celery): same protocol, same
    rows; used by service tests and the orchestration-overhead benchmark."""
    queue = list(jobs)
    n = 0
    while queue and n < max_steps:
        j = queue.pop(0)
        run_step(j.campaign_id, j.iteration, j.step.value, j.attempt, worker_name="inline", send=queue.extend)
        n += 1
    return n
