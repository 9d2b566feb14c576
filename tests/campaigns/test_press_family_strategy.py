"""Strategy ``press-family`` in the job protocol (in this process, each backend): no OCP; the
oracle replays the next motions of the task's press family, a prefix of its space-filling
sequence, whole; each becomes a pool dataset like an OCP's replay."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

pytestmark = pytest.mark.integration


def test_the_oracle_replays_the_family_sequence_in_order_whatever_the_batch(
    campaign_db: str, make_campaign: Any
) -> None:
    from alcove.campaigns.config import RunSettings
    from alcove.campaigns.run import protocol
    from alcove.campaigns.suite import family_box, suite_model
    from alcove.db import open_transaction, run_transaction
    from alcove.models import Campaign, Iteration, IterationCandidate, OcpSolution
    from alcove.pool.repository import oracle_datasets
    from alcove.pool.service import dataset_arrays
    from alcove.science.ocp.task_spec import task_preset
    from alcove.science.press_family import sequence_motion

    settings = {"strategy": "press-family", "batch": 2, "validation_motions": 0, "family_ranges": {"dwell": [0, 0.05]}}
    cid, jobs = make_campaign(seed=5, settings=settings, stopping={"max_iterations": 2})
    protocol.drive_inline(cid, jobs)
    task = task_preset("head-headrest-2phase")
    model = suite_model(task)
    box = family_box(RunSettings.model_validate(settings), task, model)
    assert box.dwell == (0, 0.05) and box.release[0] < 1  # the user's dwell, the task's histories
    with open_transaction() as s:
        c = s.get(Campaign, cid)
        assert c is not None and c.status == "completed", c.status
        iterations = s.query(Iteration).filter_by(campaign_id=cid).filter(Iteration.index > 0).order_by(Iteration.index)
        replayed, indices, statuses = [], [], []
        for it in iterations:
            cands = s.query(IterationCandidate).filter_by(iteration_id=it.id).order_by(IterationCandidate.slot).all()
            indices += [cand.scenario["motion_index"] for cand in cands]
            assert [cand.pick for cand in cands] == [0, 1]
            statuses += [sol.solver_status for sol in s.query(OcpSolution).filter_by(iteration_id=it.id)]
            replayed += [dataset_arrays(s, ds) for ds in oracle_datasets(s, it.id)]
    assert indices == [0, 1, 2, 3] and statuses == ["prescribed"] * 4
    # each replay is the whole motion of its index (not cut at the task's first phase, 1 s), on the
    # replay grid (steps of 0.01 s; the motion's own samples add its end, less than a step later)
    durations = []
    for i, got in enumerate(replayed):
        want = sequence_motion(box, 5, i, (model.theta_min, model.theta_max)).trajectory(0.01)
        n = len(got["t"])
        assert want.t[-1] - 0.01 < got["t"][-1] <= want.t[-1] and n >= len(want.t) - 1
        assert np.allclose(got["t"], want.t[:n], rtol=0, atol=1e-12)
        assert np.allclose(got["q"], want.q[:n], rtol=0, atol=1e-9)
        assert np.allclose(got["qd"], want.qd[:n], rtol=0, atol=1e-9)
        durations.append(want.t[-1])
        assert np.abs(got["f"][:, 0]).max() > 0  # it presses the headrest
    assert max(durations) > 1.0  # at least one motion outlasts the task's first phase
    # an edit of the batch size mid-campaign continues the sequence after the last motion used
    from alcove.campaigns.candidate_queries import family_motion_indices

    assert run_transaction(lambda s: family_motion_indices(s, cid, 3)) == [0, 1, 2, 3]
    assert run_transaction(lambda s: family_motion_indices(s, cid, 2)) == [0, 1]


def test_a_family_range_the_task_cannot_reach_is_refused_naming_it(campaign_db: str, make_campaign: Any) -> None:
    from alcove.errors import InvalidInput

    with pytest.raises(InvalidInput) as err:
        make_campaign(
            settings={"strategy": "press-family", "validation_motions": 0, "family_ranges": {"depth": [0.2, 0.6]}},
            start=False,
        )
    (problem,) = err.value.detail()
    assert problem["loc"] == ["body", "settings", "family_ranges", "depth"]
    assert "leaves the joint range" in problem["msg"]


def test_left_open_the_family_start_is_decided_at_creation_by_the_oracle(campaign_db: str, make_campaign: Any) -> None:
    """family_motions null (the default) is decided when the campaign is created, and stored:
    DEFAULT_FAMILY_MOTIONS replays for an FE oracle, none for the auxiliary law itself (its replays
    teach nothing its samples do not); a number given is kept, also 0."""
    from alcove.campaigns.config import DEFAULT_FAMILY_MOTIONS, current_config
    from alcove.db import run_transaction
    from alcove.models import Campaign

    def stored(cid: int) -> Any:
        return run_transaction(lambda s: current_config(s, s.get(Campaign, cid)).preliminary.family_motions)

    open_fe, _ = make_campaign(oracle="fe-headrest-2d", preliminary={"family_motions": None}, start=False)
    open_aux, _ = make_campaign(oracle="aux-penalty", preliminary={"family_motions": None}, start=False)
    none_fe, _ = make_campaign(oracle="fe-headrest-2d", preliminary={"family_motions": 0}, start=False)
    two_aux, _ = make_campaign(oracle="aux-penalty", preliminary={"family_motions": 2}, start=False)
    assert DEFAULT_FAMILY_MOTIONS == 4
    assert [stored(c) for c in (open_fe, open_aux, none_fe, two_aux)] == [4, 0, 0, 2]


def test_pool_version_0_can_start_from_oracle_replays_of_the_family_counted_as_oracle_calls(
    campaign_db: str, make_campaign: Any
) -> None:
    """preliminary.family_motions 3: pool version 0 holds the auxiliary law's samples and the
    oracle's replays of the family's first 3 motions (origin oracle, 3 oracle runs of iteration 0);
    a press-family campaign's iterations then continue the sequence after them; model 1's members
    drop the auxiliary law's contact samples (their training splits hold oracle data)."""
    from alcove.campaigns.candidate_queries import family_motion_indices
    from alcove.campaigns.run import protocol
    from alcove.db import open_transaction, run_transaction
    from alcove.models import Dataset, Iteration, ModelVersion, OracleRun, PoolVersion
    from tests.procs import db_rows

    cid, jobs = make_campaign(
        seed=6,
        preliminary={"family_motions": 3},
        settings={"strategy": "press-family", "batch": 1, "validation_motions": 0},
        stopping={"max_iterations": 1},
    )
    protocol.drive_inline(cid, jobs)
    with open_transaction() as s:
        it0 = s.query(Iteration).filter_by(campaign_id=cid, index=0).one()
        runs = s.query(OracleRun).filter_by(iteration_id=it0.id).order_by(OracleRun.slot).all()
        assert [(r.slot, r.status, r.ocp_solution_id) for r in runs] == [
            (0, "ok", None),
            (1, "ok", None),
            (2, "ok", None),
        ]
        pv0 = s.query(PoolVersion).filter_by(campaign_id=cid, version=0).one()
        origins = [d.origin for d in s.query(Dataset).filter(Dataset.iteration_id == it0.id)]
        assert origins.count("oracle") == 3 and origins.count("preliminary") == 4  # the quick config's 4 chunks
        assert pv0.n_datasets == 7
        from alcove.surrogates.service import load_model

        lineage = load_model(s, s.query(ModelVersion).filter_by(campaign_id=cid, version=1).one()).lineage
    assert run_transaction(lambda s: family_motion_indices(s, cid, 2)) == [3]  # iteration 1 replayed motion 3
    assert db_rows(campaign_db, "SELECT count(*) FROM oracle_runs WHERE campaign_id = :c", c=cid) == [(4,)]
    from alcove.campaigns.views.detail import metrics_series

    with open_transaction() as s:
        (row,) = metrics_series(s, cid)
    assert (row.oracle_calls, row.cumulative_oracle_calls) == (1, 4)  # iteration 0's 3 replays count
    assert "drop" in str(lineage.get("preliminary_in_contact"))


def test_a_press_family_campaign_trains_and_scores_a_surrogate_with_history_states(
    campaign_db: str, make_campaign: Any
) -> None:
    """The surrogate config's feature set 'history': every model version takes the 19 features
    and the 3 history states; the in-loop error and the validation suite are predicted along each
    replayed motion (its times), with the same figures as the science's own prediction."""
    from alcove.campaigns.run import protocol
    from alcove.campaigns.views.detail import iteration_curves
    from alcove.db import open_transaction
    from alcove.models import Campaign, Iteration, IterationMetrics, ModelVersion, ValidationSuite
    from alcove.oracles.validation import run_motion
    from alcove.pool.repository import oracle_datasets
    from alcove.pool.service import dataset_arrays
    from alcove.science.surrogate.history import HISTORY_NAMES
    from alcove.science.surrogate.metrics import wrench_metrics
    from alcove.science.surrogate.training import history_along, predict_ensemble
    from alcove.surrogates.service import load_model
    from alcove.surrogates.validation import _suite_arrays, compute_for_model

    history = {"features": "history"}
    settings = {"strategy": "press-family", "batch": 1, "validation_motions": 2, "validation_reference_motions": 0}
    cid, jobs = make_campaign(seed=8, surrogate=history, settings=settings, stopping={"max_iterations": 2})
    protocol.drive_inline(cid, jobs)
    with open_transaction() as s:
        versions = s.query(ModelVersion).filter_by(campaign_id=cid).order_by(ModelVersion.version).all()
        assert len(versions) == 2
        model = load_model(s, versions[1])
        assert model.config.features == "history"
        assert model.members[0].input_norm.mean.shape == (19 + len(HISTORY_NAMES),)
        it = s.query(Iteration).filter_by(campaign_id=cid, index=2).one()
        (ds,) = oracle_datasets(s, it.id)
        a = dataset_arrays(s, ds)
        metric_rmse = s.query(IterationMetrics).filter_by(iteration_id=it.id).one().force_rmse
        suite = s.get(ValidationSuite, s.get(Campaign, cid).validation_suite_id)
        suite_id, motion_ids = suite.id, [m.id for m in suite.motions]
        mv_id = versions[1].id
        curves = iteration_curves(s, cid, 2)  # the iteration view's arrays: the states the model saw
        assert versions[1].architecture["features"] == "history"
    assert curves.history is not None
    np.testing.assert_allclose(np.array(curves.history), history_along(model, a["q"], a["qd"], a["t"]), rtol=1e-12)
    assert np.array(curves.history)[:, 0].max() > 0  # the motion pressed into the headrest
    p = predict_ensemble(model, a["q"], a["qd"], t=a["t"])
    assert metric_rmse == pytest.approx(wrench_metrics(np.hstack([p.force, p.moment]), a["f"])["force_rmse"], rel=1e-9)
    # the suite: replayed by the oracle, then model 2 scored along each motion
    assert [run_motion(i) for i in motion_ids] == ["succeeded", "succeeded"]
    got = compute_for_model(mv_id, suite_id)
    assert got is not None
    with open_transaction() as s:
        motions = [a for a in _suite_arrays(s, suite_id) if a.get("part") != "reference"]
    preds = [predict_ensemble(model, m["q"], m["qd"], t=m["t"]) for m in motions]
    want = wrench_metrics(
        np.vstack([np.hstack([q.force, q.moment]) for q in preds]), np.vstack([m["f"] for m in motions])
    )
    assert got["force_rmse"] == pytest.approx(want["force_rmse"], rel=1e-9)


def test_the_paper_loop_solves_its_ocps_with_a_surrogate_with_history_states(
    campaign_db: str, make_campaign: Any
) -> None:
    """The paper's loop with the feature set 'history': each iteration's OCP carries the model's
    history states (converged, trusted or not by the same diagnostics along its midpoints)."""
    from alcove.campaigns.run import protocol
    from alcove.db import open_transaction
    from alcove.models import Campaign, OcpSolution

    cid, jobs = make_campaign(
        seed=9, surrogate={"features": "history"}, settings={"validation_motions": 0}, stopping={"max_iterations": 2}
    )
    protocol.drive_inline(cid, jobs)
    with open_transaction() as s:
        assert s.get(Campaign, cid).status == "completed"
        sols = s.query(OcpSolution).filter_by(campaign_id=cid).all()
        assert len(sols) == 2 and all(sol.success for sol in sols), [sol.solver_status for sol in sols]
        assert all(sol.stats["trust"]["max_pool_distance"] is not None for sol in sols)
