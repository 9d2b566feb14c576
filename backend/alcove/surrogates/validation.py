"""A model version's generalisation error: its error on every motion of the campaign's
held-out validation suite (motions no pool ever contains), one ``validation_metrics`` row
per model version.

Two ways in, both idempotent (a row exists at most once per model version; a race between
them is settled by the unique constraint, and both compute the same numbers):

* :func:`evaluate_model` from the campaign's ``evaluate`` step, when the suite is complete;
* :func:`evaluate_suite` (job ``alcove.default.validation_evaluate``) once the suite's last
  motion is stored: every model version of every campaign on that suite that has no row yet.

The metric is computed in ONE place, :func:`generalisation_error`.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np
import sqlalchemy as sa
from cachetools import LRUCache
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from alcove.models import Campaign, CampaignEvent, ModelVersion, SuiteStatus, ValidationMetrics, ValidationSuite
from alcove.pool.repository import validation_datasets
from alcove.pool.service import dataset_arrays
from alcove.science.series import split_wrench, stack_wrench
from alcove.surrogates.service import load_model

log = logging.getLogger(__name__)


def generalisation_error(pred: np.ndarray, true: np.ndarray, std: np.ndarray | None = None) -> dict[str, Any]:
    """The error of predicted wrenches ``pred`` against the oracle's ``true`` ((n, 6): fx fy fz mx my mz):
    ``force_rmse = sqrt(mean_i |F_pred,i - F_true,i|^2)``, ``moment_rmse`` likewise, the RMSE
    of each component over all samples and over the samples in contact and, given the ensemble's
    ``std`` (K > 1; None for a single model, which has no spread), the ``calibration`` (the fraction
    of oracle values inside the mean +- 2 std), by the one definition in :mod:`alcove.science.surrogate.metrics`."""
    from alcove.science.surrogate.metrics import MetricInputError, calibration, component_metrics, vector_rmse

    p, t = np.asarray(pred, float), np.asarray(true, float)
    if p.ndim != 2 or p.shape[1] != 6 or p.shape[0] == 0 or t.shape != p.shape:
        raise ValueError(f"prediction and oracle values must have shape (n >= 1, 6), got {p.shape} and {t.shape}")
    try:
        components = component_metrics(p, t)
        return {
            "force_rmse": vector_rmse(split_wrench(p)[0], split_wrench(t)[0]),
            "moment_rmse": vector_rmse(split_wrench(p)[1], split_wrench(t)[1]),
            "components": components,
            "calibration": None if std is None else calibration(p, t, std),
        }
    except MetricInputError as err:
        raise ValueError(str(err)) from err


def _suite_arrays(s: Session, suite_id: int) -> list[dict[str, Any]]:
    """Each replayed motion's arrays (t, q, qd, f) and its ``part`` (``core`` or ``stress``)."""
    out = []
    for ds in validation_datasets(s, suite_id):
        a: dict[str, Any] = dict(dataset_arrays(s, ds))
        a["part"] = ((ds.meta or {}).get("params") or {}).get("part", "core")
        out.append(a)
    return out


def suite_kinematics(suite: ValidationSuite) -> Any:
    """The kinematics of a chain suite's motions (features from the chain's head pose); None for
    the 1-DOF preset's suites (the model's own preset)."""
    if "chain_suite" not in (suite.preset or {}):
        return None
    from alcove.science.ocp.task_spec import ModelSpec
    from alcove.science.surrogate.training import pose_kinematics

    return pose_kinematics(ModelSpec.model_validate(suite.preset["chain_suite"]["model"]).pose_function())


#: the auxiliary law's error per complete suite (a complete suite's motions never change)
_aux_law_errors: LRUCache[int, dict[str, Any]] = LRUCache(maxsize=256)


def aux_law_error(s: Session, suite: ValidationSuite) -> dict[str, Any] | None:
    """The auxiliary penalty law's own error on a complete suite (:func:`generalisation_error` of its
    wrench, with its default parameters as the preliminary data use them, against the oracle's):
    the error a model of the preliminary data alone approaches, and the line a campaign's models must
    get below to have learnt from the oracle. None until the suite is complete."""
    if suite.status != SuiteStatus.complete.value:
        return None
    found = _aux_law_errors.get(suite.id)
    if found is not None:
        return found
    from alcove.science.ocp.task_spec import ModelSpec
    from alcove.science.oracles.aux_penalty import AuxPenaltyParams, aux_penalty_wrench
    from alcove.science.surrogate.training import preset_kinematics
    from alcove.science.validation_suite import ChainSuiteModel, suite_model_from_dict

    suite_model = suite_model_from_dict(suite.preset)
    if isinstance(suite_model, ChainSuiteModel):
        preset = ModelSpec.model_validate(suite_model.model).oracle_preset()
    else:
        preset = suite_model
    kinematics = suite_kinematics(suite) or preset_kinematics(preset)
    preds, trues = [], []
    for a in _suite_arrays(s, suite.id):
        if a["part"] != "core":
            continue
        force, moment = aux_penalty_wrench(preset, AuxPenaltyParams(), kinematics(a["q"], a["qd"]))
        preds.append(stack_wrench(force, moment))
        trues.append(a["f"])
    if not preds:
        return None
    error = generalisation_error(np.concatenate(preds), np.concatenate(trues))
    _aux_law_errors[suite.id] = error
    return error


def _metrics(model: Any, motions: list[dict[str, Any]], kinematics: Any = None) -> dict[str, Any]:
    """A model's row on the suite's motions (its core and stress parts; the reference motions are
    the best-possible line's training data, never scored)."""
    from alcove.science.surrogate.training import predict_ensemble

    preds, stds, trues, parts = [], [], [], []
    for a in motions:
        if a.get("part") == "reference":
            continue
        p = predict_ensemble(model, a["q"], a["qd"], kinematics, t=a["t"])
        preds.append(stack_wrench(p.force, p.moment))
        # a single model (K = 1) has no spread: no std, so its calibration is null (not 0)
        stds.append(stack_wrench(p.force_std, p.moment_std) if model.ensemble_size > 1 else None)
        trues.append(a["f"])
        parts.append(a.get("part", "core"))
    return metrics_from_predictions(preds, trues, stds, parts)


def _pooled(preds: list[np.ndarray], trues: list[np.ndarray], stds: list[np.ndarray | None]) -> dict[str, Any]:
    std_all = None if any(s is None for s in stds) else np.vstack([s for s in stds if s is not None])
    return {
        **generalisation_error(np.vstack(preds), np.vstack(trues), std_all),
        "n_samples": int(sum(map(len, preds))),
    }


def metrics_from_predictions(
    preds: list[np.ndarray],
    trues: list[np.ndarray],
    stds: list[np.ndarray | None],
    parts: list[str] | None = None,
) -> dict[str, Any]:
    """The validation-metrics row of one model version from its predictions on each motion
    (``stds``: the ensemble's std per motion, None for K = 1; ``parts``: each motion's part, all
    ``core`` if None): the generalisation error over all samples of the core motions, per motion,
    the calibration, and the same over the stress motions as ``stress`` (None without any)."""
    parts = parts if parts is not None else ["core"] * len(preds)
    per_motion = []
    for pred, true, std, part in zip(preds, trues, stds, parts, strict=True):
        e = generalisation_error(pred, true, std)
        row = {
            "force_rmse": e["force_rmse"],
            "moment_rmse": e["moment_rmse"],
            "calibration": e["calibration"],
            "n_samples": len(pred),
        }
        per_motion.append(row if part == "core" else {**row, "part": part})

    def of(part: str) -> tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray | None]]:
        keep = [i for i, p in enumerate(parts) if p == part]
        return [preds[i] for i in keep], [trues[i] for i in keep], [stds[i] for i in keep]

    core, stress = of("core"), of("stress")
    if not core[0]:
        raise ValueError("the validation suite has no core motion to score")
    return {
        **_pooled(*core),
        "calibration_recorded": True,
        "per_motion": per_motion,
        "stress": _pooled(*stress) if stress[0] else None,
    }


def _store(s: Session, model_version_id: int, suite_id: int, m: dict[str, Any]) -> bool:
    """Insert the row unless one exists (the unique constraint settles a race)."""
    exists = s.scalar(sa.select(ValidationMetrics.id).where(ValidationMetrics.model_version_id == model_version_id))
    if exists is not None:
        return False
    try:
        with s.begin_nested():
            s.add(ValidationMetrics(model_version_id=model_version_id, suite_id=suite_id, **m))
            s.flush()
    except IntegrityError:
        return False
    return True


def compute_for_model(model_version_id: int, suite_id: int) -> dict[str, Any] | None:
    """Model version's generalisation error on a complete suite (None if the suite is not complete)."""
    from alcove.db import open_transaction

    with open_transaction() as s:
        suite = s.get(ValidationSuite, suite_id)
        if suite is None or suite.status != SuiteStatus.complete.value:
            return None
        mv = s.get(ModelVersion, model_version_id)
        assert mv is not None
        model = load_model(s, mv)
        motions = _suite_arrays(s, suite_id)
        kinematics = suite_kinematics(suite)
    return _metrics(model, motions, kinematics)


def store_for_model(s: Session, model_version_id: int, suite_id: int, metrics: dict[str, Any]) -> bool:
    return _store(s, model_version_id, suite_id, metrics)


def pending_models(s: Session, suite_id: int) -> list[int]:
    """Model versions of campaigns on the suite without a validation row."""
    have = sa.select(ValidationMetrics.model_version_id)
    return list(
        s.scalars(
            sa.select(ModelVersion.id)
            .join(Campaign, Campaign.id == ModelVersion.campaign_id)
            .where(Campaign.validation_suite_id == suite_id, ModelVersion.id.not_in(have))
            .order_by(ModelVersion.id)
        )
    )


def evaluate_suite(suite_id: int) -> int:
    """Evaluate every waiting model version on a complete suite; returns how many rows it wrote."""
    from alcove.db import open_transaction, run_transaction

    with open_transaction() as s:
        suite = s.get(ValidationSuite, suite_id)
        if suite is None or suite.status != SuiteStatus.complete.value:
            return 0
        ids = pending_models(s, suite_id)
        motions = _suite_arrays(s, suite_id)
        kinematics = suite_kinematics(suite)
    written = 0
    for mv_id in ids:
        with open_transaction() as s:
            mv = s.get(ModelVersion, mv_id)
            if mv is None:
                continue
            model, campaign_id, version = load_model(s, mv), mv.campaign_id, mv.version
        m = _metrics(model, motions, kinematics)

        def store(
            s: Session, mv_id: int = mv_id, m: dict[str, Any] = m, c: Any = campaign_id, k: int = version
        ) -> bool:
            if not _store(s, mv_id, suite_id, m):
                return False
            # the campaign's live stream tells its pages that an earlier iteration's metrics changed
            s.add(
                CampaignEvent(
                    campaign_id=c,
                    iteration_index=k,
                    kind="validation_evaluated",
                    message=f"model version {k} evaluated on validation suite {suite_id}",
                    data={"suite_id": suite_id, "force_rmse": m["force_rmse"], "moment_rmse": m["moment_rmse"]},
                )
            )
            return True

        written += bool(run_transaction(store))
    log.info("validation suite %d: evaluated %d model version(s)", suite_id, written)
    return written
