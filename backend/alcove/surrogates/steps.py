"""The surrogate's campaign steps: training model version k on pool version k-1, and
evaluating it on iteration k's oracle data (the paper's error on an unseen trajectory).
Called by the campaign's job protocol; see :mod:`alcove.jobs.steps`."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from sqlalchemy.orm import Session

from alcove.db import session_scope
from alcove.db.arrays import put_arrays
from alcove.jobs.steps import IterationRef, StepCancelled, StepOutput, StepRun
from alcove.models import IterationMetrics, ModelVersion, PoolVersion
from alcove.pool.service import FORCE_COLUMNS, dataset_arrays, load_training_pool
from alcove.surrogates.service import load_model, software_versions, store_model


def train(
    run: StepRun,
    *,
    pool_version_id: int,
    spec: dict[str, Any],
    config_version_id: int,
    seed: int,
    parent_model_id: int | None,
    preset: Any,
    lineage: dict[str, Any],
    kinematics: Any = None,
) -> StepOutput:
    """Model version k: the force and moment networks trained on ``pool_version_id``
    (warm-started from the parent model if the config says so). ``kinematics``: a chain
    task's (features from its head's pose); None: the 1-DOF ``preset``'s."""
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import TrainingCancelled, train_surrogate

    config = SurrogateConfig.parse(spec)
    with session_scope() as s:
        pv = s.get(PoolVersion, pool_version_id)
        assert pv is not None
        pool = load_training_pool(s, pv)
        parent = s.get(ModelVersion, parent_model_id) if parent_model_id is not None else None
        warm = load_model(s, parent) if parent is not None and config.warm_start else None
    t0 = time.perf_counter()
    try:
        result = train_surrogate(
            pool, config, seed, warm_start=warm, cancel=run.cancelled, preset=preset, kinematics=kinematics
        )
    except TrainingCancelled as err:
        raise StepCancelled(str(err)) from None
    compute = time.perf_counter() - t0

    def write(s: Session, at: IterationRef) -> dict[str, Any]:
        mv = store_model(
            s,
            result,
            campaign_id=at.campaign_id,
            iteration_id=at.iteration_id,
            version=at.index,
            pool_version_id=pool_version_id,
            parent_model_id=parent_model_id,
            surrogate_config_version_id=config_version_id,
            seed=seed,
            lineage=lineage,
        )
        return {
            "model_version_id": mv.id,
            "pool_version_id": pool_version_id,
            "test_force_rmse": mv.test_force_rmse,
            "test_moment_rmse": mv.test_moment_rmse,
            "epochs": result.metrics.epochs,
        }

    return StepOutput(write, compute_s=compute)


def evaluate(
    run: StepRun, *, model_version_id: int, dataset_id: int, record: dict[str, Any], kinematics: Any = None
) -> StepOutput:
    """Model version k's error on iteration k's oracle data (:mod:`alcove.science.surrogate.metrics`:
    force and moment RMSE, in contact, calibration, per component; the largest error) and the
    curves the dashboard plots (with the ensemble's std for K > 1), stored as the
    iteration's metrics row together with the iteration's other figures in ``record``
    (``IterationMetrics`` columns, plus ``extra``)."""
    from alcove.models import Dataset
    from alcove.science.surrogate.metrics import wrench_metrics
    from alcove.science.surrogate.training import predict_ensemble

    with session_scope() as s:
        mv = s.get(ModelVersion, model_version_id)
        ds = s.get(Dataset, dataset_id)
        assert mv is not None and ds is not None
        a = dataset_arrays(s, ds)
        offset = (ds.meta or {}).get("headrest_offset")  # a scenario's moved headrest (issue 17)
        model = load_model(s, mv)
        model_info = {"seed": mv.seed, "force": mv.test_force_rmse, "moment": mv.test_moment_rmse}
        train_wall_time_s = mv.train_wall_time_s
    run.check_cancel()
    pred = predict_ensemble(model, a["q"], a["qd"], headrest_offset=offset, kinematics=kinematics)
    f_pred = np.hstack([pred.force, pred.moment])
    f_std = np.hstack([pred.force_std, pred.moment_std]) if model.ensemble_size > 1 else None
    f_true = a["f"]
    err = f_pred - f_true
    honest = wrench_metrics(f_pred, f_true, f_std)
    metrics = {
        "force_rmse": honest["force_rmse"],
        "moment_rmse": honest["moment_rmse"],
        "force_rmse_contact": honest["force_rmse_contact"],
        "moment_rmse_contact": honest["moment_rmse_contact"],
        "calibration": honest["calibration"],
        "force_max_error": float(np.linalg.norm(err[:, :3], axis=1).max()),
        "moment_max_error": float(np.linalg.norm(err[:, 3:], axis=1).max()),
    }
    per_component = {c: honest[f"rmse_{c}"] for c in FORCE_COLUMNS}
    curve_arrays = {"t": a["t"], "q": a["q"], "qd": a["qd"], "f_true": f_true, "f_pred": f_pred}
    if f_std is not None:
        curve_arrays["f_std"] = f_std

    def write(s: Session, at: IterationRef) -> dict[str, Any]:
        curves = put_arrays(s, curve_arrays)
        extra = {
            **software_versions(),
            "model_seed": model_info["seed"],
            "rmse_components": per_component,
            "n_samples": len(a["t"]),
            "n_contact_samples": honest["n_contact_samples"],
            "ensemble_size": model.ensemble_size,
            "model_test_rmse": {"force": model_info["force"], "moment": model_info["moment"]},
            **record.get("extra", {}),
        }
        m = IterationMetrics(
            campaign_id=at.campaign_id,
            iteration_id=at.iteration_id,
            iteration_index=at.index,
            model_version_id=model_version_id,
            dataset_id=dataset_id,
            **metrics,
            **{k: v for k, v in record.items() if k != "extra"},
            train_wall_time_s=train_wall_time_s,
            extra=extra,
            curves_sha256=curves,
        )
        s.add(m)
        s.flush()
        return {"metrics_id": m.id, **metrics}

    return StepOutput(write)
