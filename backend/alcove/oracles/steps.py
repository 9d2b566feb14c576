"""The oracle step of a campaign iteration: replay the OCP solution's motion in the
campaign's oracle and store the result, or quarantine it when the oracle's quality gate
refuses it (never appended to the pool). Called by the campaign's job protocol; see
:mod:`alcove.jobs.step_contract`."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable
from datetime import datetime
from typing import TYPE_CHECKING, Any

import numpy as np
from cachetools import LRUCache, cached
from sqlalchemy.orm import Session

from alcove.db import open_transaction
from alcove.db.arrays import get_arrays, put_arrays
from alcove.jobs.step_contract import IterationRef, StepOutput, StepPaused, StepRun, UnusableResult, WriteRows
from alcove.models import OracleRun, OracleVersion, QuarantinedResult, utcnow
from alcove.models.data import HeadrestPlacement
from alcove.oracles.batch_jobs import StepBatchJobs
from alcove.oracles.service import builtin_launchers, command_catalogue
from alcove.pool.service import store_dataset
from alcove.science.json_values import json_safe
from alcove.science.oracles.base import OracleCancelled
from alcove.science.oracles.builtin import BUILTIN_TYPE_NAMES

if TYPE_CHECKING:
    from alcove.science.geometry import HeadNeckPreset
    from alcove.science.ocp.task_spec import TaskSpec
    from alcove.science.oracles.base import Oracle

BUILTIN = BUILTIN_TYPE_NAMES


@cached(
    LRUCache(maxsize=4),
    key=lambda s, ov, preset, launcher: (
        ov.oracle_type,
        ov.spec_hash,
        json.dumps(preset.to_dict(), sort_keys=True),
        repr(launcher),
    ),
    lock=threading.Lock(),
)
def _built_oracle(s: Session, ov: OracleVersion, preset: HeadNeckPreset, launcher: Any) -> Oracle:
    from alcove.science.oracles.registry import build_oracle

    catalogue = None if ov.oracle_type in BUILTIN else command_catalogue(s)
    oracle = build_oracle(ov.oracle_type, ov.spec, preset, catalogue=catalogue)
    if launcher is not None and hasattr(oracle, "launcher"):
        oracle.launcher = launcher  # a built-in type that runs a program, dispatched as batch jobs
    return oracle


def load_oracle(s: Session, oracle_version_id: int, preset: HeadNeckPreset) -> Oracle:
    """The oracle of a version for a model preset, built once per process (an FE oracle builds its
    mesh once), by type, spec, preset and launcher."""
    ov = s.get(OracleVersion, oracle_version_id)
    if ov is None:
        raise RuntimeError(f"oracle version id {oracle_version_id} does not exist")
    launcher = builtin_launchers().get(ov.oracle_type) if ov.oracle_type in BUILTIN else None
    return _built_oracle(s, ov, preset, launcher)


def replay(
    run: StepRun,
    *,
    task: TaskSpec,
    oracle_version_id: int,
    solution_id: int,
    trajectory_sha256: str,
    replay_phases: int | None,
    replay_dt: float | None,
    scenario: bool = False,
    record_tilt: bool = False,
    batch_jobs: StepBatchJobs | None = None,
) -> StepOutput:
    """Replay the first ``replay_phases`` phases of the solution in the oracle (None: all of it). A result
    that passes the quality gate becomes the iteration's dataset; one that does not is
    quarantined with its reason (:class:`UnusableResult`). ``scenario``: ``task`` is a scenario
    drawn from the campaign's task (its dataset records the scenario's headrest offset and, with
    ``record_tilt`` (the scenario drew ``model.tilt``), its headrest tilt). ``batch_jobs``: where
    a command oracle with a batch launcher keeps its job (a later attempt attaches to it)."""
    from alcove.science.ocp.replay import replay_trajectory

    with open_transaction() as s:
        oracle = load_oracle(s, oracle_version_id, task.model.oracle_preset())
        arrays = get_arrays(s, trajectory_sha256)
    traj = replay_trajectory(arrays, task, replay_phases, replay_dt)
    # a scenario's headrest: the features of these samples are relative to it (None: the task's own)
    headrest = HeadrestPlacement(
        offset=task.model.headrest_offset if scenario else None,
        tilt=task.model.tilt if scenario and record_tilt else None,
    )
    tau = traj.tau
    assert tau is not None  # replay_trajectory always carries the solution's torques
    started = utcnow()
    t0 = time.perf_counter()
    if batch_jobs is not None and getattr(oracle, "runs_as_batch_jobs", False):
        # a batch job is cancelled when the campaign pauses too (not left queued through the
        # pause): the step then waits, pending, and the resume submits the call again
        try:
            res = oracle.run(  # type: ignore[call-arg]
                traj, cancel=lambda: run.cancelled() or run.pausing(), batch_book=batch_jobs
            )
        except OracleCancelled:
            if run.cancelled() or not run.pausing():
                raise
            raise StepPaused("the campaign is pausing: its oracle call's batch job was cancelled") from None
    else:
        batch_jobs = None
        res = oracle.run(traj, cancel=run.cancelled)
    compute = time.perf_counter() - t0
    gate_fail = run.fault is not None and run.fault.gate_fail
    ok = bool(res.ok) and not gate_fail
    reason = res.failure_reason if not res.ok else ("fault injection: quality gate failed" if gate_fail else None)

    def write(s: Session, at: IterationRef) -> dict[str, Any]:
        row, ds = _record_replay(
            s,
            at,
            run,
            slot=at.slot,
            traj=traj,
            res=res,
            inputs={"t": traj.t, "q": traj.q, "qd": traj.qd, "tau": tau},
            started=started,
            finished=utcnow(),
            oracle_version_id=oracle_version_id,
            ocp_solution_id=solution_id,
            refused=None if ok else reason or "quality gate failed",
            name=f"iteration-{at.index:04d}" + (f"-pick-{at.slot}" if at.slot else ""),
            meta={"oracle_version_id": oracle_version_id, **headrest.as_meta()},
        )
        if batch_jobs is not None:
            batch_jobs.mark_collected(s)
        out: dict[str, Any] = {"oracle_run_id": row.id, "ok": ok, "wall_time_s": float(res.wall_time)}
        if ds is not None:
            out["dataset_id"] = ds.id
        else:
            out["quarantined"] = reason
        return out

    if not ok:
        raise UnusableResult(f"oracle result quarantined: {reason}", write=write)
    return StepOutput(write, compute_s=compute)


def _record_replay(
    s: Session,
    at: IterationRef,
    run: StepRun,
    *,
    slot: int,
    traj: Any,
    res: Any,
    inputs: dict[str, Any],
    started: datetime,
    finished: datetime,
    oracle_version_id: int,
    ocp_solution_id: int | None,
    refused: str | None,
    name: str,
    meta: dict[str, Any],
) -> tuple[OracleRun, Any]:
    """One replay's rows: its oracle run (inputs and outputs as arrays) and either its dataset of
    origin ``oracle`` (the trajectory on the oracle's time grid) or, ``refused`` naming why, its
    quarantined result. Returns the run row and the dataset (None when quarantined)."""
    f = res.forces
    diagnostics = json_safe(res.diagnostics)
    out_sha = put_arrays(s, {"t": f.t, "f": f.wrench}) if f is not None else None
    row = OracleRun(
        campaign_id=at.campaign_id,
        iteration_id=at.iteration_id,
        slot=slot,
        oracle_version_id=oracle_version_id,
        ocp_solution_id=ocp_solution_id,
        attempt=run.attempt,
        status="ok" if refused is None else "quarantined",
        worker_name=run.worker,
        started_at=started,
        finished_at=finished,
        wall_time_s=float(res.wall_time),
        failure_reason=refused,
        diagnostics=diagnostics,
        input_sha256=put_arrays(s, inputs),
        output_sha256=out_sha,
    )
    s.add(row)
    s.flush()
    if refused is not None:
        s.add(
            QuarantinedResult(
                oracle_run_id=row.id,
                campaign_id=at.campaign_id,
                iteration_id=at.iteration_id,
                reason=refused,
                gate=diagnostics,
                output_sha256=out_sha,
            )
        )
        return row, None
    assert f is not None  # an oracle's result that passed its quality gate carries the forces
    same_grid = len(f.t) == len(traj.t) and np.allclose(f.t, traj.t, rtol=0, atol=1e-12)
    on_grid = traj if same_grid else traj.resample(f.t)
    ds = store_dataset(
        s,
        t=f.t,
        q=on_grid.q,
        qd=on_grid.qd,
        f=f.wrench,
        origin="oracle",
        name=name,
        campaign_id=at.campaign_id,
        iteration_id=at.iteration_id,
        oracle_run_id=row.id,
        meta=meta,
    )
    return row, ds


def replay_motions(
    run: StepRun, *, oracle_version_id: int, preset: HeadNeckPreset, trajectories: list[Any], label: str
) -> Callable[[Session, IterationRef], list[Any]]:
    """Replay prescribed motions (no OCP) in the oracle, one after the other, outside any
    transaction; the write records one oracle run per motion in the iteration (slots 0, 1, ...;
    they count as the campaign's oracle calls) and returns the datasets (origin ``oracle``) of
    those that passed the quality gate; a refused one is quarantined with its reason."""
    with open_transaction() as s:
        oracle = load_oracle(s, oracle_version_id, preset)
    results = []
    for traj in trajectories:
        run.check_cancel()
        started = utcnow()
        results.append((traj, started, oracle.run(traj, cancel=run.cancelled), utcnow()))

    def write(s: Session, at: IterationRef) -> list[Any]:
        stored = []
        for i, (traj, started, res, finished) in enumerate(results):
            _, ds = _record_replay(
                s,
                at,
                run,
                slot=i,
                traj=traj,
                res=res,
                inputs={"t": traj.t, "q": traj.q, "qd": traj.qd},
                started=started,
                finished=finished,
                oracle_version_id=oracle_version_id,
                ocp_solution_id=None,
                refused=None if res.ok and res.forces is not None else res.failure_reason or "quality gate failed",
                name=f"{label}-{i:03d}",
                meta={"oracle_version_id": oracle_version_id},
            )
            if ds is not None:
                stored.append(ds)
        return stored

    return write


def failed_run(run: StepRun, oracle_version_id: int, started: datetime, message: str) -> WriteRows:
    """The run row an attempt leaves when the oracle (or reading its inputs) raised."""

    def write(s: Session, at: IterationRef) -> dict[str, Any]:
        s.add(
            OracleRun(
                campaign_id=at.campaign_id,
                iteration_id=at.iteration_id,
                slot=at.slot,
                oracle_version_id=oracle_version_id,
                attempt=run.attempt,
                status="failed",
                worker_name=run.worker,
                started_at=started,
                finished_at=utcnow(),
                failure_reason=message,
            )
        )
        return {}

    return write
