"""The OCP step of a campaign iteration: the task solved with model version k as the
contact model, warm-started from the previous converged solution (primal and dual), so a
step re-run by another worker gives the same rows. Called by the campaign's job protocol;
see :mod:`alcove.jobs.step_contract`."""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING, Any

import numpy as np
from sqlalchemy.orm import Session

from alcove.db import open_transaction
from alcove.db.arrays import get_arrays, put_arrays
from alcove.jobs.step_contract import IterationRef, StepOutput, StepRun, UnusableResult
from alcove.models import ModelVersion, OcpSolution, PoolVersion
from alcove.pool.service import load_training_pool
from alcove.science.json_values import json_safe
from alcove.surrogates.service import load_model

#: the solver status of a prescribed motion's solution row (:func:`prescribe`)
PRESCRIBED = "prescribed"

if TYPE_CHECKING:
    from alcove.science.geometry import HeadNeckPreset
    from alcove.science.ocp.solve import OcpSolution as Solution
    from alcove.science.ocp.task_spec import TaskSpec


def stored_solution(s: Session, row: OcpSolution | None, task: TaskSpec) -> Solution | None:
    """A converged solution rebuilt from the database (an initial guess), or None."""
    from alcove.science.ocp.solve import OcpSolution as Solution

    if row is None or not row.success or row.trajectory_sha256 is None:
        return None
    a = get_arrays(s, row.trajectory_sha256)
    if "x" not in a:
        return None
    return Solution(
        t=a["t"],
        q=a["q"],
        qd=a["qd"],
        controls=a["controls"],
        status=row.solver_status,
        converged=True,
        iterations=row.n_iterations or 0,
        cost=row.cost or 0.0,
        constraint_violation=0.0,
        wall_time=0.0,
        chain=task.chain(),
        task_name=task.name,
        x=a["x"],
        lam_x=a["lam_x"],
        lam_g=a["lam_g"],
    )


def prescribe(run: StepRun, *, t: Any, q: Any, qd: Any, model_version_id: int, motion: dict[str, Any]) -> StepOutput:
    """The ocp slot of a strategy that solves no OCP: the prescribed motion (nodes ``t``, joint
    angles ``q`` and velocities ``qd``) stored as the slot's solution, status ``prescribed``,
    without a cost. Its torques are 0: the oracle replays the kinematics, and the torque that
    drives the motion against the oracle's contact is not known before the replay."""
    t0 = time.perf_counter()
    q2, qd2 = np.atleast_2d(np.asarray(q, float).T).T, np.atleast_2d(np.asarray(qd, float).T).T
    arrays = {
        "t": np.asarray(t, float),
        "q": q2,
        "qd": qd2,
        "tau": np.zeros_like(q2),
        "controls": np.zeros((len(q2) - 1, q2.shape[1])),
    }
    compute = time.perf_counter() - t0

    def write(s: Session, at: IterationRef) -> dict[str, Any]:
        row = OcpSolution(
            campaign_id=at.campaign_id,
            iteration_id=at.iteration_id,
            slot=at.slot,
            model_version_id=model_version_id,
            attempt=run.attempt,
            initial_guess="prescribed",
            success=True,
            solver_status=PRESCRIBED,
            n_iterations=0,
            cost=None,
            wall_time_s=compute,
            message="a prescribed motion: no OCP solved",
            stats=json_safe({"prescribed": motion}),
            trajectory_sha256=put_arrays(s, arrays),
        )
        s.add(row)
        s.flush()
        return {"ocp_solution_id": row.id, "converged": True, "status": PRESCRIBED, "iterations": 0, "cost": None}

    return StepOutput(write, compute_s=compute)


def solve(
    run: StepRun,
    *,
    task: TaskSpec,
    model_version_id: int,
    previous_solution_id: int | None,
    initial_guesses: int,
    trust_region_max_std: float | None = None,
    pool_preset: HeadNeckPreset | None = None,
) -> StepOutput:
    """Solve ``task`` with the model version's networks as the contact model (their weights
    are NLP parameters: one NLP per architecture and process, reused across versions).

    With ``trust_region_max_std`` [N] (and an ensemble) the ensemble's force std is bounded
    along the solution. The solution's trust diagnostics
    (:func:`alcove.science.surrogate.trust.assess_solution`, the nearest-sample distance to the
    pool the model was trained on, its samples relative to ``pool_preset``'s headrest, default the
    task's) are stored in the solution's ``stats["trust"]``."""
    from alcove.science.ocp.solve import solve_task
    from alcove.science.surrogate.casadi_contact import surrogate_contact, surrogate_contact_std, surrogate_history
    from alcove.science.surrogate.history import history_inputs
    from alcove.science.surrogate.training import moved_headrest, pool_features, pose_kinematics, preset_kinematics
    from alcove.science.surrogate.trust import assess_solution, force_variance_function

    with open_transaction() as s:
        mv = s.get(ModelVersion, model_version_id)
        if mv is None:
            raise RuntimeError(f"model version id {model_version_id} does not exist")
        model = load_model(s, mv)
        pv = s.get(PoolVersion, mv.pool_version_id)
        pool = load_training_pool(s, pv) if pv is not None else None
        previous = None
        if previous_solution_id is not None:
            previous = stored_solution(s, s.get(OcpSolution, previous_solution_id), task)
    run.check_cancel()
    t0 = time.perf_counter()
    # a chain's features come from its contact body's pose (its kinematics); the 1-DOF preset's as before
    chain = task.chain() if task.model.is_chain else None
    preset = task.model.oracle_preset()
    base = pool_preset if pool_preset is not None else preset  # the pool's own headrest (a scenario's may be moved)
    contact, contact_params = surrogate_contact(model, preset, chain)
    history = surrogate_history(model, preset, chain)  # a model with memory: the NLP carries its states
    path, exploration = None, None
    if model.ensemble_size > 1 and (trust_region_max_std is not None or task.exploration_weight > 0):
        std_fn, _ = surrogate_contact_std(model, preset, chain)
        variance = force_variance_function(std_fn)
        if trust_region_max_std is not None:
            path = (variance, float(trust_region_max_std) ** 2)
        if task.exploration_weight > 0:  # the task's exploration term: reward the members' disagreement
            exploration = (variance, float(task.exploration_weight))
    max_iter = run.fault.ipopt_max_iter if run.fault is not None else None
    sol = solve_task(
        task,
        contact,
        initial_guess=previous,
        contact_params=contact_params,
        max_attempts=initial_guesses,
        ipopt_options={"ipopt.max_iter": int(max_iter)} if max_iter is not None else None,
        on_attempt=lambda _attempt: run.check_cancel(),  # cancel between IPOPT runs
        path=path,
        exploration=exploration,
        history=history,
    )
    kinematics = None if chain is None else pose_kinematics(chain.head_pose)
    inputs = history_inputs(model.config.features, model.config.history, preset)
    if pool is None:
        pool_x = None
    elif kinematics is not None:
        pool_x = pool_features(pool, kinematics, inputs=inputs)
    else:
        pool_x = pool_features(pool, preset_kinematics(base), moved_headrest(base), inputs)
    trust = assess_solution(model, preset, sol.t, sol.q, pool_x, kinematics=kinematics).to_dict()
    trust["trust_region_max_std"] = trust_region_max_std if path is not None else None
    compute = time.perf_counter() - t0
    arrays = {"t": sol.t, "q": sol.q, "qd": sol.qd, "tau": sol.tau, "controls": sol.controls}
    if sol.converged and sol.x is not None:
        arrays.update(
            x=np.asarray(sol.x, float).ravel(),
            lam_x=np.asarray(sol.lam_x, float).ravel(),
            lam_g=np.asarray(sol.lam_g, float).ravel(),
        )

    def write(s: Session, at: IterationRef) -> dict[str, Any]:
        row = OcpSolution(
            campaign_id=at.campaign_id,
            iteration_id=at.iteration_id,
            slot=at.slot,
            model_version_id=model_version_id,
            attempt=run.attempt,
            initial_guess=sol.attempts[-1]["guess"] if sol.attempts else "default",
            success=bool(sol.converged),
            solver_status=sol.status,
            n_iterations=int(sol.iterations),
            cost=float(sol.cost) if math.isfinite(sol.cost) else None,
            wall_time_s=float(sol.wall_time),
            message="" if sol.converged else f"no converged solution after {len(sol.attempts)} initial guess(es)",
            stats=json_safe({**sol.summary(), "trust": trust}),
            trajectory_sha256=put_arrays(s, arrays),
        )
        s.add(row)
        s.flush()
        return {
            "ocp_solution_id": row.id,
            "converged": bool(sol.converged),
            "status": sol.status,
            "iterations": int(sol.iterations),
            "cost": json_safe(sol.cost),
            "trusted": bool(trust["trusted"]),
        }

    if not sol.converged:
        raise UnusableResult(
            f"OCP did not converge ({sol.status}) after {len(sol.attempts)} initial guess(es)", write=write
        )
    return StepOutput(write, compute_s=compute)
