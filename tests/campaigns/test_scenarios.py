"""The random-scenarios strategy in a campaign (issue 17, q = 1), through the real protocol.

Each iteration's OCP solves the scenario drawn from the campaign seed and its index: the stored
scenario is that draw, the solved trajectory starts at its initial angle and velocity (the OCP's
boundary condition, to IPOPT's tolerance 1e-8), and the oracle replays it against the scenario's
headrest (the dataset records that headrest; training features are relative to it). A step
re-run after its worker died draws the same scenario; a duplicate delivery changes nothing.
"""

from __future__ import annotations

from datetime import timedelta

import numpy as np
import sqlalchemy as sa

from alcove.campaigns import protocol, repository, results
from alcove.campaigns.reconciler import reconcile
from alcove.db import session_scope
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
    with session_scope() as s:
        step = repository.get_step(s, cid, 1, "ocp")
        assert repository.claim_step(s, step.id, 1, "dead-token", "dead@host", lease_seconds=60)
        s.execute(
            sa.update(IterationStep)
            .where(IterationStep.id == step.id)
            .values(lease_until=utcnow() - timedelta(seconds=1))
        )
    with session_scope() as s:
        (job,) = [j for j in reconcile(s, stale_queued_s=60) if j.campaign_id == cid]
    assert (job.iteration, job.step.value, job.attempt) == (1, "ocp", 2)
    protocol.drive_inline(cid, [job])

    task = task_preset(TASK)
    with session_scope() as s:
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
        assert {i.index: i.scenario for i in results.list_iterations(s, cid)}[2] == stored[2]
    # a duplicate delivery of the finished OCP step is a no-op: the stored scenario stays
    assert protocol.run_step(cid, 1, "ocp", 2)["status"] == "duplicate"
    with session_scope() as s:
        assert repository.get_iteration(s, cid, 1).scenario == stored[1]
