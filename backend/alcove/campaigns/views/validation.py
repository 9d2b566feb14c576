"""What the campaign shows of its held-out validation suite: the suite's state and each model
version's generalisation error next to the in-loop metrics. The suite itself is the oracles
domain's (:mod:`alcove.oracles.validation`), the evaluation the surrogates domain's
(:mod:`alcove.surrogates.validation`)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove.campaigns.views.quality_schemas import (
    BestPossibleLine,
    BestPossiblePoint,
    ValidationPoint,
    ValidationReference,
    ValidationSeries,
    ValidationSuiteRead,
)
from alcove.campaigns.views.schemas import MetricsRead
from alcove.models import Campaign, ModelVersion, MotionStatus, ValidationMetrics, ValidationMotion, ValidationSuite


def validation_by_model(s: Session, model_version_ids: Sequence[int]) -> dict[int, ValidationMetrics]:
    ids = [i for i in model_version_ids if i is not None]
    if not ids:
        return {}
    rows = s.scalars(sa.select(ValidationMetrics).where(ValidationMetrics.model_version_id.in_(ids)))
    return {r.model_version_id: r for r in rows}


def with_validation(s: Session, rows: list[MetricsRead]) -> list[MetricsRead]:
    """The metrics rows with their model version's generalisation error (where evaluated)."""
    found = validation_by_model(s, [r.model_version_id for r in rows if r.model_version_id is not None])
    out = []
    for r in rows:
        v = found.get(r.model_version_id) if r.model_version_id is not None else None
        if v is None:
            out.append(r)
            continue
        out.append(
            r.model_copy(
                update={
                    "validation_force_rmse": v.force_rmse,
                    "validation_moment_rmse": v.moment_rmse,
                    "validation_components": dict(v.components),
                    "validation_calibration": v.calibration,
                    "validation_calibration_recorded": v.calibration_recorded,
                }
            )
        )
    return out


def suite_read(s: Session, campaign: Campaign) -> ValidationSuiteRead | None:
    if campaign.validation_suite_id is None:
        return None
    suite = s.get(ValidationSuite, campaign.validation_suite_id)
    if suite is None:
        return None
    done = s.scalar(
        sa.select(sa.func.count()).where(
            ValidationMotion.suite_id == suite.id, ValidationMotion.status == MotionStatus.succeeded.value
        )
    )
    shared = s.scalar(sa.select(sa.func.count()).where(Campaign.validation_suite_id == suite.id))
    return ValidationSuiteRead(
        id=suite.id,
        status=suite.status,
        n_motions=suite.n_motions,
        motions_done=int(done or 0),
        replay_wall_time_s=suite.replay_wall_time_s,
        shared_by=int(shared or 0),
        error=suite.error,
        n_stress_motions=int((suite.spec or {}).get("stress_motions", 0)),
        ranges=dict((suite.spec or {}).get("ranges") or {}),
        stress_ranges=(suite.spec or {}).get("stress"),
        n_reference_motions=int((suite.spec or {}).get("reference_motions", 0)),
        best_possible_computed=suite.reference is not None,
    )


def validation_series(s: Session, campaign: Campaign) -> ValidationSeries:
    """The suite and each own model version's generalisation error (the campaign page polls it
    apart from the incremental metrics series: an earlier model's error may arrive late)."""
    rows = s.execute(
        sa.select(ModelVersion.version, ValidationMetrics)
        .join(ValidationMetrics, ValidationMetrics.model_version_id == ModelVersion.id)
        .where(ModelVersion.campaign_id == campaign.id)
        .order_by(ModelVersion.version)
    ).all()
    from alcove.surrogates.validation import aux_law_error

    suite = s.get(ValidationSuite, campaign.validation_suite_id) if campaign.validation_suite_id is not None else None
    aux = aux_law_error(s, suite) if suite is not None else None
    return ValidationSeries(
        suite=suite_read(s, campaign),
        aux_law=ValidationReference(
            force_rmse=aux["force_rmse"], moment_rmse=aux["moment_rmse"], components=aux["components"]
        )
        if aux is not None
        else None,
        best_possible=_best_possible(suite.reference if suite is not None else None),
        points=[
            ValidationPoint(
                iteration_index=k,
                model_version_id=v.model_version_id,
                force_rmse=v.force_rmse,
                moment_rmse=v.moment_rmse,
                components=dict(v.components),
                calibration=v.calibration,
                calibration_recorded=v.calibration_recorded,
                per_motion=list(v.per_motion),
                stress=ValidationReference(
                    force_rmse=v.stress["force_rmse"],
                    moment_rmse=v.stress["moment_rmse"],
                    components=v.stress["components"],
                    calibration=v.stress.get("calibration"),
                )
                if v.stress
                else None,
            )
            for k, v in rows
        ],
    )


def _best_possible(line: dict[str, Any] | None) -> BestPossibleLine | None:
    if not line:
        return None
    points = [
        BestPossiblePoint(
            budget=int(p["budget"]),
            force_rmse=p["force_rmse"],
            moment_rmse=p["moment_rmse"],
            components=p["components"],
            calibration=p.get("calibration"),
        )
        for p in line.get("points", [])
    ]
    return BestPossibleLine(points=points, replays=int(line.get("replays", len(points))))


def validation_files(s: Session, campaign: Campaign) -> dict[str, bytes]:
    """The export's ``validation/``: ``suite.json`` (spec, motions, each own model version's
    generalisation error per component and per motion) and one ``motion-MM.csv`` per replayed
    motion (t, q, qd, fx..mz: the oracle's values)."""
    import io
    import json

    import numpy as np

    from alcove.pool.service import FORCE_COLUMNS, dataset_arrays

    if campaign.validation_suite_id is None:
        return {}
    suite = s.get(ValidationSuite, campaign.validation_suite_id)
    if suite is None:
        return {}
    motions = list(
        s.scalars(
            sa.select(ValidationMotion).where(ValidationMotion.suite_id == suite.id).order_by(ValidationMotion.index)
        )
    )
    models = s.execute(
        sa.select(ModelVersion.version, ValidationMetrics)
        .join(ValidationMetrics, ValidationMetrics.model_version_id == ModelVersion.id)
        .where(ModelVersion.campaign_id == campaign.id)
        .order_by(ModelVersion.version)
    ).all()
    doc = {
        "suite_id": suite.id,
        "oracle_version_id": suite.oracle_version_id,
        "status": suite.status,
        "spec": suite.spec,
        "replay_wall_time_s": suite.replay_wall_time_s,
        "best_possible": suite.reference,
        "motions": [
            {"index": m.index, "params": m.params, "status": m.status, "wall_time_s": m.wall_time_s, "error": m.error}
            for m in motions
        ],
        "model_versions": [
            {
                "version": version,
                "force_rmse": v.force_rmse,
                "moment_rmse": v.moment_rmse,
                "components": v.components,
                "calibration": v.calibration,
                "calibration_recorded": v.calibration_recorded,
                "per_motion": v.per_motion,
                "n_samples": v.n_samples,
                "stress": v.stress,
            }
            for version, v in models
        ],
    }
    files = {"validation/suite.json": json.dumps(doc, indent=1).encode()}
    from alcove.models import Dataset

    for m in motions:
        ds = s.get(Dataset, m.dataset_id) if m.dataset_id is not None else None
        if ds is None:
            continue
        a = dataset_arrays(s, ds)
        table = np.column_stack([a["t"], a["q"], a["qd"], a["f"]])
        ndof = a["q"].shape[1]
        head = ["t", *[f"q{j}" for j in range(ndof)], *[f"qd{j}" for j in range(ndof)], *FORCE_COLUMNS]
        buf = io.StringIO()
        np.savetxt(buf, table, delimiter=",", header=",".join(head), comments="", fmt="%.10g")
        files[f"validation/motion-{m.index:02d}.csv"] = buf.getvalue().encode()
    return files
