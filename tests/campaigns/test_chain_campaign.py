"""A campaign on a chain task (the paper's task on head-neck-2dof) runs end to end: its data,
truth, predictions and trust diagnostics all come from the chain's head pose."""

from __future__ import annotations

import numpy as np

from alcove.campaigns import repository
from alcove.campaigns.run import protocol
from alcove.db import open_transaction
from alcove.db.arrays import get_arrays
from alcove.models import ValidationSuite
from alcove.pool import repository as pool_repo
from alcove.solving import repository as solving_repo
from alcove.surrogates import repository as surrogates_repo


def test_a_campaign_on_the_2dof_preset_runs_from_the_heads_pose(sqlite_campaign_db: str, make_campaign) -> None:
    from alcove.oracles.validation import run_motion
    from alcove.science.geometry import kinematics_from_pose, profile_gap
    from alcove.science.ocp.task_spec import task_preset
    from alcove.science.oracles.aux_penalty import AuxPenaltyParams, aux_penalty_wrench
    from alcove.science.surrogate.training import pose_kinematics, predict
    from alcove.surrogates.service import load_model

    cid, jobs = make_campaign(task="head-headrest-2dof")
    protocol.drive_inline(cid, jobs)
    model_spec = task_preset("head-headrest-2dof").model
    pose_fn, head = model_spec.pose_function(), model_spec.oracle_preset()
    with open_transaction() as s:
        c = repository.get_campaign(s, cid)
        assert (c.status, c.stop_reason) == ("completed", "max_iterations")
        pools = pool_repo.own_versions(s, cid)
        models = surrogates_repo.own_versions(s, cid)
        metrics = repository.metrics_series(s, cid)
        assert [p.version for p in pools] == [0, 1, 2] and [m.iteration_index for m in metrics] == [1, 2]
        # preliminary data: both joints, the heads at most 10 mm into the cushion
        first = pool_repo.members(s, pools[0].id)
        pre = [get_arrays(s, d.content_sha256) for _, d in first]
        q = np.vstack([a["q"] for a in pre])
        assert q.shape == (400, 2)
        assert profile_gap(head.profile, pose_fn(q, np.vstack([a["qd"] for a in pre]))).min() >= -0.010
        for k in (1, 2):
            it = repository.get_iteration(s, cid, k)
            ds = pool_repo.oracle_dataset(s, it.id)
            data = get_arrays(s, ds.content_sha256)
            assert data["q"].shape[1] == 2
            # the aux-penalty oracle's truth is the wrench at the chain's head pose
            force, moment = aux_penalty_wrench(
                head, AuxPenaltyParams(), kinematics_from_pose(pose_fn(data["q"], data["qd"]))
            )
            curves = get_arrays(s, metrics[k - 1].curves_sha256)
            np.testing.assert_allclose(curves["f_true"], np.hstack([force, moment]), atol=1e-9)
            # model k's prediction from the chain's head pose
            pred = predict(load_model(s, models[k - 1]), data["t"], data["q"], data["qd"], pose_kinematics(pose_fn))
            np.testing.assert_allclose(curves["f_pred"], np.hstack([pred.force, pred.moment]), atol=1e-9)
            sol = solving_repo.latest_of_iteration(s, it.id)
            assert sol.success and sol.stats["trust"]["max_pool_distance"] is not None
        suite = s.get(ValidationSuite, c.validation_suite_id)
        assert "chain_suite" in suite.preset
        suite_id, motion_ids = suite.id, [m.id for m in suite.motions]
    assert len(motion_ids) == 2
    # the suite's motions are replayed along the chain's joint line (the jobs a worker runs)
    assert [run_motion(i) for i in motion_ids] == ["succeeded", "succeeded"]
    with open_transaction() as s:
        assert s.get(ValidationSuite, suite_id).status == "complete"
