"""The held-out validation suite's oracle side: create a suite once per (oracle version, spec)
and replay its motions as oracle jobs.

* :func:`attach_suite` (in the transaction of a campaign step) finds or creates the suite a
  campaign asks for, names it on the campaign and, for a new suite, sends one
  ``alcove.oracle.validation_motion`` job per motion after the commit;
* :func:`run_motion` is such a job: claim the motion row with a conditional update (a
  duplicate delivery does nothing), replay the motion in the oracle outside any transaction,
  store the replay as a dataset of origin ``validation`` (never in a pool version). The job
  that stores the suite's last motion marks the suite complete and sends
  ``alcove.default.validation_evaluate``, which evaluates every model version waiting for it;
* :func:`reconcile_motions` re-sends motions whose message was lost or whose worker died.
"""

from __future__ import annotations

import logging
import time
import uuid
from dataclasses import asdict
from datetime import timedelta
from typing import Any

import sqlalchemy as sa
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from alcove.jobs.after_commit import send_after_commit
from alcove.models import Campaign, MotionStatus, SuiteStatus, ValidationMotion, ValidationSuite, utcnow
from alcove.pool.service import store_dataset

log = logging.getLogger(__name__)

MOTION_JOB = "alcove.oracle.validation_motion"
EVALUATE_JOB = "alcove.default.validation_evaluate"


def attach_suite(
    s: Session, campaign: Campaign, spec: Any, preset: Any, params: list[Any] | None = None
) -> ValidationSuite | None:
    """The campaign's suite for ``spec`` (an ``alcove.science.validation_suite.SuiteSpec``) and
    its model ``preset``: the existing one of the same oracle version and spec, or a new one
    whose motions are sent to the oracle queue after the commit. ``spec.motions == 0``: none.
    ``params``: the motions (``motion_parameters(spec, preset)``), computed before the
    transaction by the caller (a tenth of a second: not while holding the campaign's lock)."""
    from alcove.science.validation_suite import motion_parameters

    if spec.motions == 0:
        return None
    digest = spec.digest(preset)
    suite = _find(s, campaign.oracle_version_id, digest)
    if suite is None:
        params = params if params is not None else motion_parameters(spec, preset)
        try:
            with s.begin_nested():
                suite = ValidationSuite(
                    oracle_version_id=campaign.oracle_version_id,
                    spec_hash=digest,
                    spec=spec.to_dict(),
                    preset=preset.to_dict(),
                    n_motions=len(params),
                )
                s.add(suite)
                s.flush()
                now = utcnow()
                rows = [
                    ValidationMotion(suite_id=suite.id, index=i, params=motion_row_params(spec, i, p), queued_at=now)
                    for i, p in enumerate(params)
                ]
                s.add_all(rows)
                s.flush()
        except IntegrityError:  # another campaign created it at the same time
            suite = _find(s, campaign.oracle_version_id, digest)
            assert suite is not None
        else:
            for row in rows:
                send_after_commit(s, MOTION_JOB, row.id)
    campaign.validation_suite_id = suite.id
    return suite


def motions_for(spec: Any, preset: Any) -> list[Any] | None:
    """The suite's motion parameters (None when the spec asks for no suite)."""
    from alcove.science.validation_suite import motion_parameters

    return motion_parameters(spec, preset) if spec.motions > 0 else None


def motion_row_params(spec: Any, index: int, motion: Any) -> dict[str, Any]:
    """What a motion row stores: the motion's parameters and, for the stress part, ``part``."""
    params = asdict(motion)
    if spec.part(index) != "core":
        params["part"] = spec.part(index)
    return params


def _find(s: Session, oracle_version_id: int, digest: str) -> ValidationSuite | None:
    return s.scalar(
        sa.select(ValidationSuite).where(
            ValidationSuite.oracle_version_id == oracle_version_id, ValidationSuite.spec_hash == digest
        )
    )


def _lease() -> timedelta:
    from alcove.settings import get_settings

    return timedelta(seconds=get_settings().job_lease_seconds)


def claim(s: Session, motion_id: int, token: str, worker_name: str) -> int | None:
    """Take a queued motion (or a running one whose lease expired); returns the attempt or None."""
    now = utcnow()
    m = ValidationMotion
    res = s.execute(
        sa.update(m)
        .where(
            m.id == motion_id,
            m.attempts < m.max_attempts,
            sa.or_(
                m.status == MotionStatus.queued.value,
                sa.and_(m.status == MotionStatus.running.value, m.lease_until < now),
            ),
        )
        .values(
            status=MotionStatus.running.value,
            attempts=m.attempts + 1,
            claim_token=token,
            lease_until=now + _lease(),
            worker_name=worker_name,
            started_at=now,
        )
        .returning(m.attempts)
    ).first()
    return None if res is None else int(res[0])


def run_motion(motion_id: int, worker_name: str = "local") -> str:
    """The job of one motion: claim, replay, record. Returns the motion's status (or ``duplicate``)."""
    from alcove.db import open_transaction, run_transaction
    from alcove.oracles.steps import load_oracle
    from alcove.science.ocp.task_spec import ModelSpec
    from alcove.science.validation_suite import (
        ChainSuiteModel,
        SuiteSpec,
        chain_press_trajectory,
        suite_model_from_dict,
        suite_motion,
    )

    token = uuid.uuid4().hex
    attempt = run_transaction(lambda s: claim(s, motion_id, token, worker_name))
    if attempt is None:
        return "duplicate"
    res, traj, error = None, None, None
    t0 = time.perf_counter()
    try:
        with open_transaction() as s:
            row = s.get(ValidationMotion, motion_id)
            assert row is not None
            suite = s.get(ValidationSuite, row.suite_id)
            assert suite is not None
            suite_model = suite_model_from_dict(suite.preset)
            spec = SuiteSpec.from_dict(suite.spec)
            if isinstance(suite_model, ChainSuiteModel):
                preset = ModelSpec.model_validate(suite_model.model).oracle_preset()
            else:
                preset = suite_model
            oracle = load_oracle(s, suite.oracle_version_id, preset)
            params = dict(row.params)
        if isinstance(suite_model, ChainSuiteModel):  # a chain's motion along its joint line
            pose = ModelSpec.model_validate(suite_model.model).pose_function()
            traj = chain_press_trajectory(suite_motion(params), spec.dt, suite_model, pose)
        else:
            traj = suite_motion(params).trajectory(spec.dt)
        res = oracle.run(traj)
    except Exception as err:
        log.exception("validation motion %d failed (attempt %d)", motion_id, attempt)
        error = f"{type(err).__name__}: {err}"
    wall = time.perf_counter() - t0
    return str(run_transaction(lambda s: _record(s, motion_id, token, traj, res, error, wall)))


def _record(s: Session, motion_id: int, token: str, traj: Any, res: Any, error: str | None, wall: float) -> str:
    import numpy as np

    row = s.get(ValidationMotion, motion_id)
    if row is None or row.claim_token != token or row.status != MotionStatus.running.value:
        return "lost"  # the lease expired and another job took the motion
    suite = s.get(ValidationSuite, row.suite_id, with_for_update=True)  # serialises the suite's completions
    assert suite is not None
    row.finished_at, row.claim_token, row.lease_until = utcnow(), None, None
    if error is not None:
        row.error = error
        if row.attempts < row.max_attempts:
            row.status, row.queued_at = MotionStatus.queued.value, utcnow()
            send_after_commit(s, MOTION_JOB, row.id)
            return row.status
        row.status = MotionStatus.failed.value
    elif not res.ok or res.forces is None:  # the quality gate refused it: deterministic, not retried
        row.status, row.error = MotionStatus.failed.value, f"quarantined: {res.failure_reason}"
    else:
        f = res.forces
        on_grid = traj if len(f.t) == len(traj.t) and np.allclose(f.t, traj.t, atol=1e-12) else traj.resample(f.t)
        ds = store_dataset(
            s,
            t=f.t,
            q=on_grid.q,
            qd=on_grid.qd,
            f=f.wrench,
            origin="validation",
            name=f"validation-{suite.id}-{row.index}",
            meta={
                "suite_id": suite.id,
                "motion": row.index,
                "params": row.params,
                "oracle_version_id": suite.oracle_version_id,
            },
        )
        row.status, row.dataset_id, row.wall_time_s, row.error = (
            MotionStatus.succeeded.value,
            ds.id,
            float(res.wall_time),
            None,
        )
    s.flush()
    _settle(s, suite)
    return row.status


def _settle(s: Session, suite: ValidationSuite) -> None:
    """Mark the suite complete (and send its evaluation) or failed once no motion is pending: complete
    when every scored motion (core and stress) succeeded; a failed reference motion (the best-possible
    line's training data) only shortens the line, and the suite's error says so."""
    motions = list(s.scalars(sa.select(ValidationMotion).where(ValidationMotion.suite_id == suite.id)))
    if any(m.status in (MotionStatus.queued.value, MotionStatus.running.value) for m in motions):
        return
    now = utcnow()
    suite.completed_at = now
    suite.replay_wall_time_s = max((now - suite.created_at).total_seconds(), 0.0)
    scored = [m.status for m in motions if (m.params or {}).get("part") != "reference"]
    lost = sum(m.status != MotionStatus.succeeded.value for m in motions if (m.params or {}).get("part") == "reference")
    if all(st == MotionStatus.succeeded.value for st in scored):
        suite.status = SuiteStatus.complete.value
        suite.error = f"{lost} reference motion(s) failed: the best-possible line is shorter" if lost else None
        send_after_commit(s, EVALUATE_JOB, suite.id)
    else:
        suite.status = SuiteStatus.failed.value
        suite.error = f"{scored.count(MotionStatus.failed.value)} of {len(scored)} motions failed"


def reconcile_motions(s: Session, older_than: timedelta) -> list[int]:
    """Motions to re-send: queued for longer than ``older_than`` (a lost message) or running
    past their lease (a dead worker). Records their jobs in the outbox (sent after the commit)
    and returns their ids."""
    now = utcnow()
    m = ValidationMotion
    rows = s.scalars(
        sa.select(m).where(
            m.attempts < m.max_attempts,
            sa.or_(
                sa.and_(m.status == MotionStatus.queued.value, m.queued_at < now - older_than),
                sa.and_(m.status == MotionStatus.running.value, m.lease_until < now),
            ),
        )
    ).all()
    for r in rows:
        r.queued_at = now
        send_after_commit(s, MOTION_JOB, r.id)
    # a motion whose last attempt's worker died: out of attempts, it fails (and so does its suite)
    dead = s.scalars(
        sa.select(m).where(m.attempts >= m.max_attempts, m.status == MotionStatus.running.value, m.lease_until < now)
    ).all()
    for r in dead:
        r.status, r.finished_at, r.claim_token = MotionStatus.failed.value, now, None
        r.error = f"its last attempt (worker {r.worker_name}) did not finish within its lease"
        suite = s.get(ValidationSuite, r.suite_id, with_for_update=True)
        assert suite is not None
        s.flush()
        _settle(s, suite)
    return [r.id for r in rows]
