"""The held-out validation suite in the job protocol (in this process, each backend): created
once per (oracle version, spec) and shared, never in a pool, every model version evaluated."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from alcove.surrogates.validation import generalisation_error

pytestmark = pytest.mark.integration


def test_generalisation_error_is_the_vector_norm_rmse_with_structural_zeros() -> None:
    # two samples; the force error vectors are (3, 0, 4) and (0, 0, 0): |e| = 5 and 0
    true = np.zeros((2, 6))
    pred = np.zeros((2, 6))
    pred[0, :3] = (3.0, 0.0, 4.0)
    pred[1, 4] = 2.0  # moment error (0, 2, 0) in the second sample only
    e = generalisation_error(pred, true)
    assert e["force_rmse"] == pytest.approx(np.sqrt(25 / 2), rel=1e-12)  # not sqrt(25 / 6): fy does not dilute it
    assert e["moment_rmse"] == pytest.approx(np.sqrt(4 / 2), rel=1e-12)
    assert e["components"]["fx"] == pytest.approx(np.sqrt(9 / 2), rel=1e-12)
    assert e["components"]["fy"] == 0.0
    # the vector RMSE is the root of the sum of the components' squares
    assert e["force_rmse"] ** 2 == pytest.approx(sum(e["components"][c] ** 2 for c in ("fx", "fy", "fz")), rel=1e-12)
    with pytest.raises(ValueError, match="shape"):
        generalisation_error(np.zeros((2, 5)), np.zeros((2, 5)))


def _hand_calibration_case() -> tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray | None]]:
    """Two motions, K > 1. Informative components: fx and my (fy, fz, mx, mz are 0 in every sample).
    Motion 0 (2 samples): fx errors 1, 3 with std 1 (|e| <= 2 s: in, out); my errors 0.5, 0.5 with
    std 0.25 (in: 0.5 <= 0.5, on the band's edge). Motion 1 (1 sample): fx error 2 with std 0.5
    (out), my error 0 with std 0 (in). Per (sample, informative component): 4 of 6 inside."""
    true0 = np.zeros((2, 6))
    true0[:, 0] = (10.0, 20.0)
    true0[:, 4] = (1.0, 2.0)
    pred0 = true0.copy()
    pred0[:, 0] += (1.0, -3.0)
    pred0[:, 4] += (0.5, -0.5)
    std0 = np.zeros((2, 6))
    std0[:, 0], std0[:, 4] = 1.0, 0.25
    std0[:, 1] = 5.0  # a structurally zero component's spread does not count
    true1 = np.zeros((1, 6))
    true1[0, 0], true1[0, 4] = 5.0, 3.0
    pred1 = true1.copy()
    pred1[0, 0] += 2.0
    std1 = np.zeros((1, 6))
    std1[0, 0] = 0.5
    return [pred0, pred1], [true0, true1], [std0, std1]


def test_validation_calibration_is_the_share_inside_two_std_and_null_without_spread() -> None:
    from alcove.surrogates.validation import metrics_from_predictions

    preds, trues, stds = _hand_calibration_case()
    m = metrics_from_predictions(preds, trues, stds)
    assert m["calibration"] == pytest.approx(4 / 6, abs=1e-15)
    assert [p["calibration"] for p in m["per_motion"]] == pytest.approx([3 / 4, 1 / 2], abs=1e-15)
    assert m["calibration_recorded"] is True
    # K = 1: no std, so null (not 0, which would claim every value outside the band)
    single = metrics_from_predictions(preds, trues, [None, None])
    assert single["calibration"] is None and [p["calibration"] for p in single["per_motion"]] == [None, None]
    assert single["force_rmse"] == m["force_rmse"]


def _suite_rows(url: str, suite_id: int) -> Any:
    from tests.procs import db_rows

    return db_rows(
        url, 'SELECT status, dataset_id FROM validation_motions WHERE suite_id = :s ORDER BY "index"', s=suite_id
    )


def test_suite_is_shared_replayed_once_never_pooled_and_evaluates_every_model(
    campaign_db: str, make_campaign: Any
) -> None:
    from alcove.campaigns.run import protocol
    from alcove.models import Campaign
    from alcove.oracles.validation import run_motion
    from alcove.surrogates.validation import evaluate_suite
    from tests.procs import db_rows

    settings = {"ocp_intervals": 20, "replay_dt": 0.01, "validation_motions": 3}
    a, jobs = make_campaign(seed=1, settings=settings, stopping={"max_iterations": 2})
    protocol.drive_inline(a, jobs)
    ((suite_id,),) = db_rows(campaign_db, "SELECT validation_suite_id FROM campaigns WHERE id = :c", c=a)
    assert suite_id is not None
    assert [r[0] for r in _suite_rows(campaign_db, suite_id)] == ["queued"] * 3
    # not complete yet: the in-loop metrics exist, the generalisation error does not
    assert db_rows(campaign_db, "SELECT count(*) FROM validation_metrics WHERE suite_id = :s", s=suite_id) == [(0,)]

    motions = [r[0] for r in db_rows(campaign_db, "SELECT id FROM validation_motions WHERE suite_id = :s", s=suite_id)]
    assert [run_motion(m, "w") for m in motions] == ["succeeded"] * 3
    assert [run_motion(m, "w") for m in motions] == ["duplicate"] * 3  # a duplicate delivery does nothing
    assert db_rows(campaign_db, "SELECT status FROM validation_suites WHERE id = :s", s=suite_id) == [("complete",)]
    # model version 1 of a: a hand-computed ensemble evaluation (calibration 4/6) through the storage path
    from alcove.db import run_transaction
    from alcove.surrogates.validation import metrics_from_predictions, store_for_model

    ((mv1,),) = db_rows(campaign_db, "SELECT id FROM model_versions WHERE campaign_id = :c AND version = 1", c=a)
    hand = metrics_from_predictions(*_hand_calibration_case())
    assert run_transaction(lambda s: store_for_model(s, mv1, suite_id, hand)) is True
    assert evaluate_suite(suite_id) == 1  # model version 2 (the campaign's own K = 2 ensemble)
    assert evaluate_suite(suite_id) == 0  # idempotent
    cal = "SELECT mv.version, v.calibration, v.calibration_recorded FROM validation_metrics v "
    cal += "JOIN model_versions mv ON mv.id = v.model_version_id WHERE mv.campaign_id = :c ORDER BY mv.version"
    (v1, v2) = db_rows(campaign_db, cal, c=a)
    assert v1 == (1, pytest.approx(4 / 6, abs=1e-15), True)
    assert v2[0] == 2 and 0.0 <= v2[1] <= 1.0 and v2[2]
    from alcove.campaigns.views.detail import metrics_series
    from alcove.campaigns.views.validation import validation_series
    from alcove.db import open_transaction

    with open_transaction() as s:
        served = [(m.validation_calibration, m.validation_calibration_recorded) for m in metrics_series(s, a)]
        series_a = validation_series(s, s.get(Campaign, a))
        points = series_a.points
    # the auxiliary law's own error on the suite: this campaign's oracle is the auxiliary law itself
    # (aux-penalty, the same parameters), so the reference line lies at zero (to float rounding)
    assert series_a.aux_law is not None
    assert series_a.aux_law.force_rmse <= 1e-9 and series_a.aux_law.moment_rmse <= 1e-9
    assert set(series_a.aux_law.components) >= {"fx", "fz", "my", "fx_contact"}
    assert served == [(pytest.approx(4 / 6, abs=1e-15), True), (v2[1], True)]
    assert [p.calibration for p in points] == [pytest.approx(4 / 6, abs=1e-15), v2[1]]
    assert points[0].per_motion[0]["calibration"] == pytest.approx(3 / 4, abs=1e-15)

    # a second campaign with the same oracle version and suite spec shares the suite (not replayed again);
    # its models are evaluated in their evaluate step, the suite being complete. A single model
    # (K = 1): no spread, so its validation calibration is stored as null (recorded), not 0
    b, jobs = make_campaign(seed=2, settings=settings, stopping={"max_iterations": 2}, surrogate={"ensemble_size": 1})
    protocol.drive_inline(b, jobs)
    assert db_rows(campaign_db, cal, c=b) == [(1, None, True), (2, None, True)]
    assert db_rows(campaign_db, "SELECT validation_suite_id FROM campaigns WHERE id = :c", c=b) == [(suite_id,)]
    # (the database is shared with other tests: every query is restricted to this test's objects)
    assert db_rows(campaign_db, "SELECT count(*) FROM validation_suites WHERE id > :s", s=suite_id) == [(0,)]
    assert db_rows(
        campaign_db,
        "SELECT count(*) FROM datasets d JOIN validation_motions m ON m.dataset_id = d.id "
        "WHERE m.suite_id = :s AND d.origin = 'validation'",
        s=suite_id,
    ) == [(3,)]
    assert db_rows(
        campaign_db, "SELECT count(*) FROM validation_motions WHERE attempts = 1 AND suite_id = :s", s=suite_id
    ) == [(3,)]
    # never in a pool
    assert db_rows(
        campaign_db,
        "SELECT count(*) FROM pool_version_members m JOIN datasets d ON d.id = m.dataset_id "
        "WHERE d.origin = 'validation'",
    ) == [(0,)]
    # every model version of both campaigns has its generalisation error, positive and finite
    got = db_rows(
        campaign_db,
        "SELECT mv.campaign_id, mv.version, v.force_rmse, v.moment_rmse, v.n_samples FROM model_versions mv "
        "LEFT JOIN validation_metrics v ON v.model_version_id = mv.id WHERE mv.campaign_id IN (:a, :b) "
        "ORDER BY mv.campaign_id, mv.version",
        a=a,
        b=b,
    )
    assert [(c, k) for c, k, *_ in got] == [(a, 1), (a, 2), (b, 1), (b, 2)]
    assert all(f is not None and 0 < f < 1e4 and 0 < m < 1e3 and n > 0 for *_, f, m, n in got)

    # served next to the in-loop RMSE
    from alcove.campaigns.views.detail import get_detail, metrics_series
    from alcove.db import open_transaction

    with open_transaction() as s:
        series = metrics_series(s, b)
        detail = get_detail(s, b)
    assert [m.validation_force_rmse is not None and m.force_rmse is not None for m in series] == [True, True]
    assert detail.validation is not None and detail.validation.status == "complete"
    assert detail.validation.motions_done == 3 and detail.validation.shared_by == 2

    # exported with the campaign: the suite, each model's error, the motions' oracle values
    import csv
    import io
    import json
    import zipfile

    from alcove.campaigns.views.export import export_zip

    with open_transaction() as s:
        z = zipfile.ZipFile(io.BytesIO(export_zip(s, b, models=False)))
    names = z.namelist()
    assert [n for n in names if "/validation/" in n] == [
        f"campaign-{b}/validation/suite.json",
        *(f"campaign-{b}/validation/motion-{i:02d}.csv" for i in range(3)),
    ]
    doc = json.loads(z.read(f"campaign-{b}/validation/suite.json"))
    assert [m["version"] for m in doc["model_versions"]] == [1, 2] and len(doc["model_versions"][0]["per_motion"]) == 3
    assert [(m["calibration"], m["calibration_recorded"]) for m in doc["model_versions"]] == [(None, True)] * 2
    metrics = list(csv.DictReader(io.StringIO(z.read(f"campaign-{b}/metrics.csv").decode())))
    assert all(float(r["validation_force_rmse"]) > 0 for r in metrics)
    assert [(r["validation_calibration"], r["validation_calibration_recorded"]) for r in metrics] == [("", "True")] * 2
    motion = list(csv.DictReader(io.StringIO(z.read(f"campaign-{b}/validation/motion-00.csv").decode())))
    assert {"t", "q0", "qd0", "fx", "mz"} <= set(motion[0]) and max(abs(float(r["fx"])) for r in motion) > 0


def test_no_suite_when_the_campaign_asks_for_none(campaign_db: str, make_campaign: Any) -> None:
    from alcove.campaigns.run import protocol
    from tests.procs import db_rows

    c, jobs = make_campaign(seed=3, settings={"ocp_intervals": 20, "replay_dt": 0.01, "validation_motions": 0})
    protocol.drive_inline(c, jobs)
    assert db_rows(campaign_db, "SELECT validation_suite_id, status FROM campaigns WHERE id = :c", c=c) == [
        (None, "completed")
    ]


def test_reconciler_resends_lost_motions_and_fails_a_suite_whose_last_attempt_died(
    campaign_db: str, make_campaign: Any
) -> None:
    from datetime import timedelta

    import sqlalchemy as sa

    from alcove.campaigns.run import protocol
    from alcove.db import run_transaction
    from alcove.models import ValidationMotion, ValidationSuite, utcnow
    from alcove.oracles.validation import reconcile_motions

    c, jobs = make_campaign(
        seed=4,
        settings={"ocp_intervals": 20, "replay_dt": 0.01, "validation_motions": 2, "validation_seed": 9},
        stopping={"max_iterations": 1},
    )
    protocol.drive_inline(c, jobs)

    def age(s: Any) -> list[int]:
        motions = s.scalars(
            sa.select(ValidationMotion).join(ValidationSuite).where(ValidationSuite.spec["seed"].as_integer() == 9)
        ).all()
        past = utcnow() - timedelta(hours=1)
        motions[0].queued_at = past  # its message was lost
        motions[1].status, motions[1].attempts, motions[1].lease_until = "running", 3, past  # its last worker died
        return [m.id for m in motions]

    lost, dead = run_transaction(age)

    def resent() -> list[int]:  # (other tests' suites share the database: only this suite's motions count)
        return [m for m in run_transaction(lambda s: reconcile_motions(s, timedelta(seconds=60))) if m in (lost, dead)]

    assert resent() == [lost]
    assert resent() == []  # re-sent once, not again at once

    def states(s: Any) -> tuple[str, str, str]:
        d, suite = s.get(ValidationMotion, dead), s.get(ValidationMotion, lost)
        return d.status, s.get(ValidationSuite, d.suite_id).status, suite.status

    assert run_transaction(states) == ("failed", "replaying", "queued")  # the lost one may still succeed


def test_the_stress_part_is_scored_apart_and_the_suite_figures_cover_the_core_motions(
    campaign_db: str, make_campaign: Any
) -> None:
    """Two core motions (presses with unloads and re-loads from the task's box) and two stress
    motions: the row's figures are the error over the core motions' samples alone, ``stress`` the
    error over the stress motions', each recomputed here from the stored replays."""
    from alcove.campaigns.run import protocol
    from alcove.campaigns.views.validation import validation_series
    from alcove.db import open_transaction
    from alcove.models import Campaign, ModelVersion, ValidationSuite
    from alcove.oracles.validation import run_motion
    from alcove.science.surrogate.training import predict_ensemble
    from alcove.surrogates.service import load_model
    from alcove.surrogates.validation import _suite_arrays, evaluate_suite
    from tests.procs import db_rows

    settings = {
        "ocp_intervals": 20,
        "replay_dt": 0.01,
        "validation_motions": 2,
        "validation_seed": 7,
        "validation_stress_motions": 2,
        "validation_ranges": {"dwell": [0.0, 0.05]},
    }
    a, jobs = make_campaign(seed=3, settings=settings, stopping={"max_iterations": 1})
    protocol.drive_inline(a, jobs)
    ((suite_id,),) = db_rows(campaign_db, "SELECT validation_suite_id FROM campaigns WHERE id = :c", c=a)
    rows = db_rows(campaign_db, 'SELECT id FROM validation_motions WHERE suite_id = :s ORDER BY "index"', s=suite_id)
    assert [run_motion(m, "w") for (m,) in rows] == ["succeeded"] * 4
    evaluate_suite(suite_id)
    with open_transaction() as s:
        suite = s.get(ValidationSuite, suite_id)
        assert suite is not None and suite.spec["ranges"]["dwell"] == [0.0, 0.05]  # the user's range
        assert suite.spec["ranges"]["release"] == [0.3, 1.0]  # derived from the task: with histories
        series = validation_series(s, s.get(Campaign, a))
        mv = s.query(ModelVersion).filter_by(campaign_id=a, version=1).one()
        model, arrays = load_model(s, mv), _suite_arrays(s, suite_id)
    assert series.suite is not None and series.suite.n_motions == 4 and series.suite.n_stress_motions == 2
    assert [x["part"] for x in arrays] == ["core", "core", "stress", "stress"]
    (point,) = series.points
    assert [m.get("part") for m in point.per_motion] == [None, None, "stress", "stress"]

    def force_rmse(part: str) -> float:
        err = []
        for x in arrays:
            if x["part"] == part:
                err.append(predict_ensemble(model, x["q"], x["qd"]).force - x["f"][:, :3])
        e = np.vstack(err)
        return float(np.sqrt(np.mean(np.sum(e**2, axis=1))))

    assert point.force_rmse == pytest.approx(force_rmse("core"), rel=1e-12)
    assert point.stress is not None and point.stress.force_rmse == pytest.approx(force_rmse("stress"), rel=1e-12)
    assert point.stress.force_rmse != pytest.approx(point.force_rmse, rel=1e-6)


def test_a_suite_range_the_task_cannot_reach_is_refused_naming_it(campaign_db: str, make_campaign: Any) -> None:
    from alcove.errors import InvalidInput

    with pytest.raises(InvalidInput) as err:
        make_campaign(settings={"validation_ranges": {"depth": [0.34, 0.6]}}, start=False)
    (problem,) = err.value.detail()
    assert problem["loc"] == ["body", "settings", "validation_ranges", "depth"]
    assert "leaves the joint range" in problem["msg"]
    with pytest.raises(InvalidInput) as err:
        make_campaign(settings={"validation_stress_motions": 1, "validation_stress_ranges": {"speed": [0.0, 1.0]}})
    assert err.value.detail()[0]["loc"] == ["body", "settings", "validation_stress_ranges", "speed"]


def test_the_best_possible_line_learns_from_its_reference_replays_alone_and_is_computed_once(
    campaign_db: str, make_campaign: Any
) -> None:
    """A suite with 8 reference motions: they are the first 8 of its box's space-filling sequence,
    replayed with the suite but never scored; the line's models (trained on the first 4 and 8
    replays alone) predict the suite's core motions far better than a model that predicts no
    force (the oracle here is the auxiliary law itself: learnable from its replays)."""
    from alcove.campaigns.run import protocol
    from alcove.campaigns.views.validation import validation_series
    from alcove.db import open_transaction
    from alcove.models import Campaign, ValidationSuite
    from alcove.oracles.validation import run_motion
    from alcove.science.press_family import sequence_motion
    from alcove.science.validation_suite import SuiteSpec, suite_model_from_dict
    from alcove.surrogates.reference_line import compute_reference_line
    from alcove.surrogates.validation import _suite_arrays, evaluate_suite
    from tests.procs import db_rows

    settings = {"validation_motions": 2, "validation_seed": 11, "validation_reference_motions": 8}
    a, jobs = make_campaign(seed=4, settings=settings, stopping={"max_iterations": 1})
    protocol.drive_inline(a, jobs)
    ((suite_id,),) = db_rows(campaign_db, "SELECT validation_suite_id FROM campaigns WHERE id = :c", c=a)
    rows = db_rows(
        campaign_db, 'SELECT id, params FROM validation_motions WHERE suite_id = :s ORDER BY "index"', s=suite_id
    )
    assert len(rows) == 10 and [run_motion(m, "w") for m, _ in rows] == ["succeeded"] * 10
    evaluate_suite(suite_id)  # the evaluation job: the model versions, then the line, once
    assert compute_reference_line(suite_id) is True
    assert compute_reference_line(suite_id) is False
    with open_transaction() as s:
        suite = s.get(ValidationSuite, suite_id)
        assert suite is not None and suite.status == "complete"
        spec, model = SuiteSpec.from_dict(suite.spec), suite_model_from_dict(suite.preset)
        arrays = _suite_arrays(s, suite_id)
        series = validation_series(s, s.get(Campaign, a))
    import json

    params = [json.loads(p) if isinstance(p, str) else p for _, p in rows]
    theta = (model.theta_min, model.theta_max)
    for i, p in enumerate(params[2:]):
        assert p.pop("part") == "reference"
        assert p == pytest.approx(vars(sequence_motion(spec.ranges, 11, i, theta)), abs=0)
    (point,) = series.points
    assert len(point.per_motion) == 2  # the reference motions are not scored
    line = series.best_possible
    assert line is not None and line.replays == 8 and [p.budget for p in line.points] == [4, 8]
    core = [x for x in arrays if x["part"] == "core"]
    f = np.vstack([x["f"][:, :3] for x in core])
    zero_force = float(np.sqrt(np.mean(np.sum(f**2, axis=1))))  # the error of predicting no force
    assert zero_force > 1.0
    for p in line.points:
        assert np.isfinite(p.force_rmse) and p.force_rmse < 0.5 * zero_force, (p.budget, p.force_rmse, zero_force)
        assert set(p.components) >= {"fx", "fz", "my", "fx_contact"}
