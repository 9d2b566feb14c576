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


def _suite_rows(url: str, suite_id: int) -> Any:
    from tests.integration.procs import db_rows

    return db_rows(
        url, 'SELECT status, dataset_id FROM validation_motions WHERE suite_id = :s ORDER BY "index"', s=suite_id
    )


def test_suite_is_shared_replayed_once_never_pooled_and_evaluates_every_model(
    campaign_db: str, make_campaign: Any
) -> None:
    from alcove.campaigns import protocol
    from alcove.oracles.validation import run_motion
    from alcove.surrogates.validation import evaluate_suite
    from tests.integration.procs import db_rows

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
    assert evaluate_suite(suite_id) == 2  # model versions 1 and 2
    assert evaluate_suite(suite_id) == 0  # idempotent

    # a second campaign with the same oracle version and suite spec shares the suite (not replayed again);
    # its models are evaluated in their evaluate step, the suite being complete
    b, jobs = make_campaign(seed=2, settings=settings, stopping={"max_iterations": 2})
    protocol.drive_inline(b, jobs)
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
    from alcove.campaigns.results import get_detail, metrics_series
    from alcove.db import session_scope

    with session_scope() as s:
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

    from alcove.campaigns.export import export_zip

    with session_scope() as s:
        z = zipfile.ZipFile(io.BytesIO(export_zip(s, b, models=False)))
    names = z.namelist()
    assert [n for n in names if "/validation/" in n] == [
        f"campaign-{b}/validation/suite.json",
        *(f"campaign-{b}/validation/motion-{i:02d}.csv" for i in range(3)),
    ]
    doc = json.loads(z.read(f"campaign-{b}/validation/suite.json"))
    assert [m["version"] for m in doc["model_versions"]] == [1, 2] and len(doc["model_versions"][0]["per_motion"]) == 3
    metrics = list(csv.DictReader(io.StringIO(z.read(f"campaign-{b}/metrics.csv").decode())))
    assert all(float(r["validation_force_rmse"]) > 0 for r in metrics)
    motion = list(csv.DictReader(io.StringIO(z.read(f"campaign-{b}/validation/motion-00.csv").decode())))
    assert {"t", "q0", "qd0", "fx", "mz"} <= set(motion[0]) and max(abs(float(r["fx"])) for r in motion) > 0


def test_no_suite_when_the_campaign_asks_for_none(campaign_db: str, make_campaign: Any) -> None:
    from alcove.campaigns import protocol
    from tests.integration.procs import db_rows

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

    from alcove.campaigns import protocol
    from alcove.db import transaction
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

    lost, dead = transaction(age)

    def resent() -> list[int]:  # (other tests' suites share the database: only this suite's motions count)
        return [m for m in transaction(lambda s: reconcile_motions(s, timedelta(seconds=60))) if m in (lost, dead)]

    assert resent() == [lost]
    assert resent() == []  # re-sent once, not again at once

    def states(s: Any) -> tuple[str, str, str]:
        d, suite = s.get(ValidationMotion, dead), s.get(ValidationMotion, lost)
        return d.status, s.get(ValidationSuite, d.suite_id).status, suite.status

    assert transaction(states) == ("failed", "replaying", "queued")  # the lost one may still succeed
