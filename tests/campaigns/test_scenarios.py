"""The random-scenarios strategy in a campaign (q = 1), through the real protocol.

Each iteration's OCP solves the scenario drawn from the campaign seed and its index: the stored
scenario is that draw, the solved trajectory starts at its initial angle and velocity (the OCP's
boundary condition, to IPOPT's tolerance 1e-8), and the oracle replays it against the scenario's
headrest (the dataset records that headrest; training features are relative to it). A step
re-run after its worker died draws the same scenario; a duplicate delivery changes nothing.
"""

from __future__ import annotations

from datetime import timedelta

import numpy as np
import pytest
import sqlalchemy as sa

from alcove.campaigns import repository
from alcove.campaigns.run import protocol
from alcove.campaigns.run.reconciler import reconcile
from alcove.campaigns.views import detail
from alcove.db import open_transaction
from alcove.db.arrays import get_arrays
from alcove.models import IterationStep, utcnow
from alcove.pool import repository as pool_repo
from alcove.pool import service as pool_service
from alcove.science.geometry import relative_kinematics
from alcove.science.oracles.aux_penalty import AuxPenaltyParams, aux_penalty_wrench
from alcove.solving import repository as solving_repo

TASK = "head-headrest-scenarios"


def test_random_scenarios_solve_one_seeded_draw_per_iteration_and_a_rerun_draws_the_same(
    sqlite_campaign_db: str, make_campaign
) -> None:
    from alcove.science.ocp import scenarios
    from alcove.science.ocp.task_spec import task_preset

    seed = 5
    cid, jobs = make_campaign(
        task=TASK, seed=seed, settings={"strategy": "random-scenarios"}, stopping={"max_iterations": 2}
    )
    queue: list = list(jobs)
    protocol.run_step(cid, 0, "preliminary", 1, send=queue.extend)
    protocol.run_step(cid, 1, "train", 1, send=queue.extend)
    # a worker claims iteration 1's OCP and dies: the reconciler sends attempt 2
    with open_transaction() as s:
        step = repository.get_step(s, cid, 1, "ocp")
        assert repository.claim_step(s, step.id, 1, "dead-token", "dead@host", lease_seconds=60)
        s.execute(
            sa.update(IterationStep)
            .where(IterationStep.id == step.id)
            .values(lease_until=utcnow() - timedelta(seconds=1))
        )
    with open_transaction() as s:
        (job,) = [j for j in reconcile(s, stale_queued_s=60) if j.campaign_id == cid]
    assert (job.iteration, job.step.value, job.attempt) == (1, "ocp", 2)
    protocol.drive_inline(cid, [job])

    task = task_preset(TASK)
    with open_transaction() as s:
        assert repository.get_campaign(s, cid).status == "completed"
        assert repository.get_step(s, cid, 1, "ocp").attempts == 2
        stored = {}
        for k in (1, 2):
            it = repository.get_iteration(s, cid, k)
            assert it.status == "succeeded"
            stored[k] = it.scenario
            # the stored scenario is the draw for (campaign seed, k), whatever the attempt
            assert it.scenario == scenarios.draw(task, seed, k).to_json()
            for r in task.ranges or []:
                assert r.low <= it.scenario["values"][r.parameter] <= r.high
            # the OCP solved it: its trajectory starts at the drawn initial state (IPOPT tolerance 1e-8)
            sol = solving_repo.latest_of_iteration(s, it.id)
            a = get_arrays(s, sol.trajectory_sha256)
            np.testing.assert_allclose(a["q"][0, 0], it.scenario["values"]["initial.q.0"], atol=1e-8)
            np.testing.assert_allclose(a["qd"][0, 0], it.scenario["values"]["initial.qd.0"], atol=1e-8)
            # the oracle (aux-penalty) replayed it against the scenario's headrest: its forces are the
            # penalty law's with the moved headrest (1e-9 N), and the dataset records the offset the
            # training features are relative to
            ds = pool_repo.oracle_dataset(s, it.id)
            data = get_arrays(s, ds.content_sha256)
            offset = it.scenario["values"]["model.headrest_offset"]
            assert ds.meta["headrest_offset"] == offset
            moved = scenarios.from_json(task, it.scenario).preset()
            kin = relative_kinematics(moved, data["q"][:, 0], data["qd"][:, 0])
            force, _ = aux_penalty_wrench(moved, AuxPenaltyParams(), kin)
            np.testing.assert_allclose(data["f"][:, :3], force, rtol=0, atol=1e-9)
            trained_on = pool_service.load_training_pool(s, pool_repo.version_of(s, cid, k))
            assert [d.headrest_offset for d in trained_on if d.origin == "oracle"][-1] == offset
            assert all(d.headrest_offset is None for d in trained_on if d.origin == "preliminary")
        # one scenario per iteration, another for each
        assert stored[1]["values"] != stored[2]["values"]
        # the API's iteration list shows it
        assert {i.index: i.scenario for i in detail.list_iterations(s, cid)}[2] == stored[2]
    # a duplicate delivery of the finished OCP step is a no-op: the stored scenario stays
    assert protocol.run_step(cid, 1, "ocp", 2)["status"] == "duplicate"
    with open_transaction() as s:
        assert repository.get_iteration(s, cid, 1).scenario == stored[1]


def test_a_tilted_headrest_scenario_is_simulated_recorded_trained_and_scored_against_its_tilt(
    sqlite_campaign_db: str, make_campaign
) -> None:
    """A task that ranges the headrest tilt (model.tilt, +-0.05 rad around 0.31): the oracle
    (aux-penalty) replays the drawn scenario against the tilted headrest (its forces are the
    penalty law's with that tilt, 1e-9 N, and not the untilted headrest's), the dataset records
    the tilt, the next model trains on it with the tilt, and the in-loop metrics score the model
    against the tilted headrest."""
    import copy

    from alcove.models import IterationMetrics
    from alcove.science.ocp import scenarios
    from alcove.science.ocp.task_spec import TASK_PRESETS, parse_task
    from alcove.science.surrogate.metrics import wrench_metrics
    from alcove.science.surrogate.training import predict_ensemble
    from alcove.surrogates.service import load_model

    spec = copy.deepcopy(TASK_PRESETS[TASK])
    # starting pressed into the cushion (first contact at 0.31 rad), so the replay is in contact
    spec["ranges"] = [
        {"parameter": "initial.q.0", "low": 0.37, "high": 0.40},
        {"parameter": "model.tilt", "low": 0.26, "high": 0.36},
    ]
    task = parse_task(spec)
    cid, jobs = make_campaign(
        task=TASK, task_spec=spec, seed=2, settings={"strategy": "random-scenarios"}, stopping={"max_iterations": 1}
    )
    protocol.drive_inline(cid, jobs)
    with open_transaction() as s:
        assert repository.get_campaign(s, cid).status == "completed"
        it = repository.get_iteration(s, cid, 1)
        tilt = it.scenario["values"]["model.tilt"]
        assert 0.26 <= tilt <= 0.36 and abs(tilt - 0.31) > 1e-3
        ds = pool_repo.oracle_dataset(s, it.id)
        assert ds.meta["headrest_tilt"] == tilt and ds.meta["headrest_offset"] == 0.0
        data = get_arrays(s, ds.content_sha256)
        tilted = scenarios.from_json(task, it.scenario).preset()
        assert tilted.tilt == tilt
        kin = relative_kinematics(tilted, data["q"][:, 0], data["qd"][:, 0])
        force, _ = aux_penalty_wrench(tilted, AuxPenaltyParams(), kin)
        np.testing.assert_allclose(data["f"][:, :3], force, rtol=0, atol=1e-9)
        untilted = task.preset()
        force0, _ = aux_penalty_wrench(
            untilted, AuxPenaltyParams(), relative_kinematics(untilted, data["q"][:, 0], data["qd"][:, 0])
        )
        assert np.max(np.abs(force0 - data["f"][:, :3])) > 1.0  # [N]: the other geometry is not what was simulated
        # the pool's training dataset carries the tilt (its features are the tilted headrest's)
        (trained,) = [
            d for d in pool_service.load_training_pool(s, pool_repo.version_of(s, cid, 1)) if d.origin == "oracle"
        ]
        assert (trained.headrest_offset, trained.headrest_tilt) == (0.0, tilt)
        # iteration 1's in-loop metrics: model 1 against the oracle data, features of the tilted headrest
        row = s.query(IterationMetrics).filter_by(campaign_id=cid, iteration_index=1).one()
        from alcove.models import ModelVersion

        model = load_model(s, s.get(ModelVersion, row.model_version_id))
    pred = predict_ensemble(model, data["q"], data["qd"], headrest_offset=0.0, headrest_tilt=tilt)
    expected = wrench_metrics(np.hstack([pred.force, pred.moment]), data["f"])["force_rmse"]
    assert row.force_rmse == pytest.approx(expected, rel=1e-12)
    pred0 = predict_ensemble(model, data["q"], data["qd"], headrest_offset=0.0)
    assert wrench_metrics(np.hstack([pred0.force, pred0.moment]), data["f"])["force_rmse"] != pytest.approx(
        expected, rel=1e-6
    )
