"""Error metrics of a contact surrogate, defined once (pure NumPy; docs/concepts.md repeats the formulas).

Arrays are wrenches in the headrest frame, one row per sample, columns ``fx fy fz mx my mz``
(shape (n, 6)); ``pred`` is the model's (ensemble mean) prediction, ``true`` the oracle's value,
``std`` the ensemble's standard deviation per output (same shape). With F = (fx, fy, fz) and
M = (mx, my, mz):

* per component c:   ``rmse_c = sqrt(mean_i (pred_ic - true_ic)^2)``                  [N or N m]
  (and ``rmse_c_contact`` over the samples in contact, below)
* force:             ``force_rmse = sqrt(mean_i |F_pred,i - F_true,i|^2)``              [N]
  (the root mean square of the error vector's norm; equals sqrt(rmse_fx^2 + rmse_fy^2 + rmse_fz^2),
  so a structurally zero component (fy in the planar model) does not dilute it)
* moment:            ``moment_rmse = sqrt(mean_i |M_pred,i - M_true,i|^2)``             [N m]
* in contact:        the same two over the samples with ``|F_true,i| > contact_threshold``
  (default 0: the oracle reports exact zeros out of contact); None when there is none
* calibration:       the fraction of (sample, component) pairs with
  ``|pred_ic - true_ic| <= 2 std_ic``, over the components whose oracle value is not zero in every
  sample (structural zeros would count as trivially inside); None without ``std`` or such a component.
  A calibrated Gaussian ensemble gives about 0.95.

Every function returns plain Python floats (None where the set is empty), ready for JSON.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from alcove.science.arrays import BoolArray, FloatArray
from alcove.science.errors import FieldError
from alcove.science.series import split_wrench

COMPONENTS = ("fx", "fy", "fz", "mx", "my", "mz")
CALIBRATION_K = 2.0  # half-width of the calibration band in standard deviations


class MetricInputError(FieldError):
    """Arrays of the wrong shape or with non-finite values; ``field`` names the array."""


def _wrench(name: str, a: ArrayLike, shape: tuple[int, ...] | None = None) -> FloatArray:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 6:
        raise MetricInputError(name, f"must have shape (n, 6) (fx fy fz mx my mz), got {arr.shape}")
    if shape is not None and arr.shape != shape:
        raise MetricInputError(name, f"has shape {arr.shape}, expected {shape} like the prediction")
    if not np.all(np.isfinite(arr)):
        raise MetricInputError(name, "contains NaN or infinite values")
    return arr


def _rms(values: FloatArray) -> float | None:
    return float(np.sqrt(np.mean(values))) if values.size else None


def component_rmse(pred: ArrayLike, true: ArrayLike) -> dict[str, float | None]:
    """RMSE of each wrench component: ``{"fx": .., .., "mz": ..}`` (None for no samples)."""
    p = _wrench("pred", pred)
    t = _wrench("true", true, p.shape)
    sq = (p - t) ** 2
    return {c: _rms(sq[:, j]) for j, c in enumerate(COMPONENTS)}


def component_metrics(pred: ArrayLike, true: ArrayLike, contact_threshold: float = 0.0) -> dict[str, float | None]:
    """RMSE of each component over all samples (keys ``fx`` .. ``mz``) and over the samples in contact
    (``fx_contact`` .. ``mz_contact``, :func:`contact_mask`; None when none is in contact)."""
    p = _wrench("pred", pred)
    t = _wrench("true", true, p.shape)
    contact = contact_mask(t, contact_threshold)
    return {
        **component_rmse(p, t),
        **{f"{c}_contact": v for c, v in component_rmse(p[contact], t[contact]).items()},
    }


def vector_rmse(pred: ArrayLike, true: ArrayLike) -> float | None:
    """``sqrt(mean_i |pred_i - true_i|^2)`` for rows of 3-vectors (n, 3); None for n = 0."""
    p = np.asarray(pred, dtype=np.float64)
    t = np.asarray(true, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise MetricInputError("pred", f"must have shape (n, 3), got {p.shape}")
    if t.shape != p.shape:
        raise MetricInputError("true", f"has shape {t.shape}, expected {p.shape} like the prediction")
    return _rms(np.sum((p - t) ** 2, axis=1))


def contact_mask(true: ArrayLike, contact_threshold: float = 0.0) -> BoolArray:
    """Samples in contact: the oracle's force norm above ``contact_threshold`` [N]."""
    t = _wrench("true", true)
    return np.asarray(np.linalg.norm(split_wrench(t)[0], axis=1) > contact_threshold)


def calibration(pred: ArrayLike, true: ArrayLike, std: ArrayLike, k: float = CALIBRATION_K) -> float | None:
    """Fraction of oracle values inside ``pred +- k std``, over the components not zero in every sample."""
    p = _wrench("pred", pred)
    t = _wrench("true", true, p.shape)
    s = _wrench("std", std, p.shape)
    if np.any(s < 0):
        raise MetricInputError("std", "has negative values")
    informative = np.any(t != 0.0, axis=0)
    if p.shape[0] == 0 or not informative.any():
        return None
    inside = np.abs(p - t)[:, informative] <= k * s[:, informative]
    return float(np.mean(inside))


def wrench_metrics(
    pred: ArrayLike, true: ArrayLike, std: ArrayLike | None = None, *, contact_threshold: float = 0.0
) -> dict[str, Any]:
    """All metrics of one prediction against oracle data (keys: see :data:`METRIC_KEYS`)."""
    p = _wrench("pred", pred)
    t = _wrench("true", true, p.shape)
    contact = contact_mask(t, contact_threshold)
    out: dict[str, Any] = {f"rmse_{c}": v for c, v in component_rmse(p, t).items()}
    out.update({f"rmse_{c}_contact": v for c, v in component_rmse(p[contact], t[contact]).items()})
    (p_force, p_moment), (t_force, t_moment) = split_wrench(p), split_wrench(t)
    out["force_rmse"] = vector_rmse(p_force, t_force)
    out["moment_rmse"] = vector_rmse(p_moment, t_moment)
    out["force_rmse_contact"] = vector_rmse(p_force[contact], t_force[contact])
    out["moment_rmse_contact"] = vector_rmse(p_moment[contact], t_moment[contact])
    out["calibration"] = calibration(p, t, std) if std is not None else None
    out["n_samples"] = int(p.shape[0])
    out["n_contact_samples"] = int(contact.sum())
    return out


METRIC_KEYS = (
    *(f"rmse_{c}" for c in COMPONENTS),
    *(f"rmse_{c}_contact" for c in COMPONENTS),
    "force_rmse",
    "moment_rmse",
    "force_rmse_contact",
    "moment_rmse_contact",
    "calibration",
    "n_samples",
    "n_contact_samples",
)

# One sentence per metric, for API field descriptions and docs (the same words everywhere).
DESCRIPTIONS = {
    "force_rmse": "force RMSE [N]: sqrt(mean over samples of |F_pred - F_true|^2), F = (fx, fy, fz)",
    "moment_rmse": "moment RMSE [N m]: sqrt(mean over samples of |M_pred - M_true|^2), M = (mx, my, mz)",
    "force_rmse_contact": "force RMSE [N] over the samples in contact (oracle |F_true| > 0); null if none",
    "moment_rmse_contact": "moment RMSE [N m] over the samples in contact (oracle |F_true| > 0); null if none",
    "calibration": "fraction of oracle values inside the ensemble mean +- 2 std, over the components not zero "
    "in every sample; null for a single model (K = 1)",
    "rmse_components": "per-component RMSE sqrt(mean (pred_c - true_c)^2) for c in fx fy fz [N], mx my mz [N m], "
    "over all samples (keys fx .. mz) and over the samples in contact, oracle |F_true| > 0 (keys fx_contact .. "
    "mz_contact; null if none)",
}

__all__ = [
    "CALIBRATION_K",
    "COMPONENTS",
    "DESCRIPTIONS",
    "METRIC_KEYS",
    "MetricInputError",
    "calibration",
    "component_metrics",
    "component_rmse",
    "contact_mask",
    "vector_rmse",
    "wrench_metrics",
]
