"""The surrogate's campaign steps: training model version k on pool version k-1, and
evaluating it on iteration k's oracle data (the paper's error on an unseen trajectory).
Called by the campaign's job protocol; see :mod:`alcove.jobs.step_contract`."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from sqlalchemy.orm import Session

from alcove.db import open_transaction
from alcove.db.arrays import put_arrays
from alcove.jobs.step_contract import IterationRef, StepCancelled, StepOutput, StepRun
from alcove.models import IterationMetrics, ModelVersion, PoolVersion
from alcove.pool.service import FORCE_COLUMNS, dataset_arrays, load_training_pool
from alcove.science.series import split_wrench, stack_wrench
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
    with open_transaction() as s:
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
    run: StepRun, *, model_version_id: int, dataset_ids: list[int], record: dict[str, Any], kinematics: Any = None
) -> StepOutput:
    """Model version k's error on iteration k's oracle data (:mod:`alcove.science.surrogate.metrics`:
    force and moment RMSE, in contact, calibration, per component; the largest error) and the
    curves the dashboard plots (with the ensemble's std for K > 1), stored as the
    iteration's metrics row together with the iteration's other figures in ``record``
    (``IterationMetrics`` columns, plus ``extra``).

    A batch iteration (several picks, ``dataset_ids`` in pick order) is scored per picked
    trajectory (``result["picks"]``: dataset, RMSEs and the content hash of that pick's curves);
    its metrics row holds their mean (the largest errors: the largest of all) and the first
    pick's curves. With one dataset: that dataset's figures."""
    from alcove.models import Dataset
    from alcove.science.surrogate.metrics import wrench_metrics
    from alcove.science.surrogate.training import history_along, predict_ensemble

    if not dataset_ids:
        raise ValueError("dataset_ids: the iteration has no oracle dataset to evaluate on")
    with open_transaction() as s:
        mv = s.get(ModelVersion, model_version_id)
        assert mv is not None
        data = []
        for dataset_id in dataset_ids:
            ds = s.get(Dataset, dataset_id)
            assert ds is not None
            data.append((dataset_arrays(s, ds), (ds.headrest.offset, ds.headrest.tilt)))  # a scenario's headrest
        model = load_model(s, mv)
        model_info = {"seed": mv.seed, "force": mv.test_force_rmse, "moment": mv.test_moment_rmse}
        train_wall_time_s = mv.train_wall_time_s
    run.check_cancel()
    picks: list[dict[str, Any]] = []
    for a, (offset, tilt) in data:
        pred = predict_ensemble(
            model, a["q"], a["qd"], headrest_offset=offset, headrest_tilt=tilt, kinematics=kinematics, t=a["t"]
        )
        states = history_along(model, a["q"], a["qd"], a["t"], kinematics, offset, tilt)
        f_pred = stack_wrench(pred.force, pred.moment)
        f_std = stack_wrench(pred.force_std, pred.moment_std) if model.ensemble_size > 1 else None
        err = f_pred - a["f"]
        honest = wrench_metrics(f_pred, a["f"], f_std)
        picks.append(
            {
                "honest": honest,
                "force_max_error": float(np.linalg.norm(split_wrench(err)[0], axis=1).max()),
                "moment_max_error": float(np.linalg.norm(split_wrench(err)[1], axis=1).max()),
                "f_pred": f_pred,
                "f_std": f_std,
                "history": states,
            }
        )

    def mean(key: str) -> Any:
        values = [p["honest"][key] for p in picks if p["honest"][key] is not None]
        return float(np.mean(values)) if values else None

    metrics = {
        "force_rmse": mean("force_rmse"),
        "moment_rmse": mean("moment_rmse"),
        "force_rmse_contact": mean("force_rmse_contact"),
        "moment_rmse_contact": mean("moment_rmse_contact"),
        "calibration": mean("calibration"),
        "force_max_error": max(p["force_max_error"] for p in picks),
        "moment_max_error": max(p["moment_max_error"] for p in picks),
    }
    per_pick = [
        {"dataset_id": d, "force_rmse": p["honest"]["force_rmse"], "moment_rmse": p["honest"]["moment_rmse"]}
        for d, p in zip(dataset_ids, picks, strict=True)
    ]
    # every pick's curves (the first pick's are also the metrics row's): model k's prediction with
    # the ensemble's std against the oracle along each picked trajectory
    pick_curves = []
    for (arrays, _), p in zip(data, picks, strict=True):
        pc = {"t": arrays["t"], "q": arrays["q"], "qd": arrays["qd"], "f_true": arrays["f"], "f_pred": p["f_pred"]}
        if p["f_std"] is not None:
            pc["f_std"] = p["f_std"]
        if p["history"] is not None:
            pc["history"] = p["history"]
        pick_curves.append(pc)
    a, first = data[0][0], picks[0]
    honest = {
        **first["honest"],
        "n_contact_samples": sum(p["honest"]["n_contact_samples"] for p in picks),
        **{f"rmse_{c}": mean(f"rmse_{c}") for c in FORCE_COLUMNS},
    }
    dataset_id = dataset_ids[0]
    per_component = {c: honest[f"rmse_{c}"] for c in FORCE_COLUMNS}
    per_component_contact = {c: mean(f"rmse_{c}_contact") for c in FORCE_COLUMNS}
    curve_arrays = {"t": a["t"], "q": a["q"], "qd": a["qd"], "f_true": a["f"], "f_pred": first["f_pred"]}
    if first["f_std"] is not None:
        curve_arrays["f_std"] = first["f_std"]
    if first["history"] is not None:
        curve_arrays["history"] = first["history"]

    def write(s: Session, at: IterationRef) -> dict[str, Any]:
        curves = put_arrays(s, curve_arrays)
        extra = {
            **software_versions(),
            "model_seed": model_info["seed"],
            "rmse_components": per_component,
            "rmse_components_contact": per_component_contact,
            "n_samples": sum(len(d[0]["t"]) for d in data),
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
        shas = [curves if i == 0 else put_arrays(s, pc) for i, pc in enumerate(pick_curves)]
        picked = [{**p, "curves_sha256": sha} for p, sha in zip(per_pick, shas, strict=True)]
        return {"metrics_id": m.id, **metrics, "picks": picked}

    return StepOutput(write)
