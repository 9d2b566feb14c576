"""Where a surrogate's OCP solution can be trusted: diagnostics along the solution and the trust region.

A surrogate is data: where the optimiser drives the head into states the pool never
covered, the networks extrapolate, and a force they invent there (a *ghost force*) can hold
the head at rest in mid-air. :func:`assess_solution` evaluates, at the points where the OCP
evaluates the contact model (the interval midpoints ``q_k+1/2 = (q_k + q_k+1) / 2`` with the
velocity ``(q_k+1 - q_k) / h``, :mod:`alcove.science.ocp.discrete_mechanics`):

* the geometric signed gap (:func:`alcove.science.geometry.signed_gap`) between head profile
  and undeformed headrest surface;
* the ensemble's standard deviation of the force, ``|sigma_F| = sqrt(sigma_fx^2 + sigma_fy^2 + sigma_fz^2)``
  [N]: its maximum and its time integral [N s] over the contact phase (the midpoints with
  ``gap <= gap_tolerance``);
* the predicted force ``|F|`` (ensemble mean) [N] where the gap is open by more than
  ``gap_tolerance``: the largest value, the gap [m] and time where it occurs;
* the distance from each midpoint to the nearest pool sample in the surrogate's scaled
  feature space (``(x - mean) / divisor`` of member 0's input standardisation, the space its
  first layer sees; :class:`scipy.spatial.cKDTree`), when the pool's features are given.

The solution is *not trusted* when it relies on force outside the data: a predicted force
above ``open_gap_force_tolerance`` while the gap is open by more than ``gap_tolerance``, or
an ensemble force std above ``contact_std_threshold`` in contact. The reasons are stated.

:func:`force_variance_function` gives ``sigma_F^2(q, qd[, p])`` as a CasADi function for the
OCP's trust-region path constraint ``sigma_F^2 <= max_std^2`` (the variance is smooth; its
square root is not where the members agree exactly).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import casadi as ca
import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from scipy.spatial import cKDTree

from alcove.science.arrays import FloatArray
from alcove.science.geometry import (
    HeadNeckPreset,
    RelativeKinematics,
    pose_from_kinematics,
    profile_gap,
    relative_kinematics,
    signed_gap,
)
from alcove.science.surrogate.features import features
from alcove.science.surrogate.history import history_inputs
from alcove.science.surrogate.mlp import SurrogateModel


class TrustThresholds(BaseModel):
    """When a surrogate's OCP solution is flagged as relying on force outside the data."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    gap_tolerance: float = Field(
        0.002,
        gt=0,
        le=0.05,
        description="the gap is 'clearly open' beyond this distance [m] (contact phase: gap <= it)",
    )
    open_gap_force_tolerance: float = Field(
        1.0, gt=0, le=1e4, description="largest predicted force |F| tolerated with the gap clearly open [N]"
    )
    contact_std_threshold: float = Field(
        10.0, gt=0, le=1e4, description="largest ensemble force std |sigma_F| tolerated in contact [N]"
    )


@dataclass
class TrustReport:
    """Diagnostics of one solution (see the module docstring); JSON-ready via :meth:`to_dict`."""

    trusted: bool
    reasons: list[str]
    ensemble_size: int
    contact_fraction: float  # fraction of the midpoints with gap <= gap_tolerance
    max_std_contact: float | None  # N, None without contact
    integral_std_contact: float  # N s
    max_std: float  # N, over the whole solution
    open_gap_max_force: float  # N, 0 when the gap is never clearly open
    open_gap_at_gap: float | None  # m, gap where that force is predicted
    open_gap_at_time: float | None  # s
    min_gap: float  # m
    max_pool_distance: float | None  # scaled feature distance to the nearest pool sample
    median_pool_distance: float | None
    thresholds: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class TrustCurves:
    """The per-midpoint values behind a :class:`TrustReport` (for plots and tests)."""

    t: FloatArray
    q: FloatArray
    gap: FloatArray
    force: FloatArray  # (n, 3) ensemble mean
    force_std: FloatArray  # (n,) |sigma_F|
    pool_distance: FloatArray | None


def midpoints(t: FloatArray, q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Interval midpoints of a solution on nodes ``t`` (N+1), ``q`` (N+1, ndof): (t, q, velocity)."""
    t, q = np.asarray(t, float), np.asarray(q, float).reshape(len(t), -1)
    h = np.diff(t)[:, None]
    return 0.5 * (t[:-1] + t[1:]), 0.5 * (q[:-1] + q[1:]), (q[1:] - q[:-1]) / h


def scaled_features(model: SurrogateModel, x: FloatArray) -> FloatArray:
    """Raw features (n, 19) in the surrogate's scaled feature space (member 0's input standardisation)."""
    norm = model.input_norm
    out: FloatArray = (np.asarray(x, float) - np.asarray(norm.mean)) / np.asarray(norm.divisor)
    return out


def trust_curves(
    model: SurrogateModel,
    preset: HeadNeckPreset,
    t: FloatArray,
    q: FloatArray,
    pool_features: FloatArray | None = None,
    kinematics: Callable[[FloatArray, FloatArray], RelativeKinematics] | None = None,
) -> TrustCurves:
    """Gap, ensemble mean force, force std and pool distance at the solution's interval midpoints:
    the 1-DOF ``preset``'s geometry, or a chain's head from ``kinematics(q, qd)`` (the gap of
    ``preset``'s head profile at the head's pose)."""
    tm, qm, v = midpoints(t, q)
    if kinematics is not None:
        kin = kinematics(qm, v)
        gap = profile_gap(preset.profile, pose_from_kinematics(kin))
    else:
        if model.ndof != 1:
            raise ValueError(f"model: the model has {model.ndof} DOF; pass the chain's kinematics")
        kin = relative_kinematics(preset, qm[:, 0], v[:, 0])
        gap = signed_gap(preset, qm[:, 0])
    # a model with history states sees them along the midpoints, as the OCP carries them
    inputs = history_inputs(model.config.features, model.config.history, preset)
    x = features(kin) if inputs is None else inputs(kin, tm)
    pred = model.predict_ensemble(x)
    distance: FloatArray | None = None
    if pool_features is not None:
        pool = np.asarray(pool_features, float)
        if pool.ndim != 2 or pool.shape[1] != x.shape[1] or pool.shape[0] == 0:
            raise ValueError(f"pool_features: expected a non-empty (n, {x.shape[1]}) array, got shape {pool.shape}")
        distance = np.asarray(cKDTree(scaled_features(model, pool)).query(scaled_features(model, x))[0], float)
    return TrustCurves(
        t=tm,
        q=qm[:, 0],
        gap=gap,
        force=pred.force,
        force_std=np.sqrt(np.sum(pred.force_std**2, axis=1)),
        pool_distance=distance,
    )


def assess_curves(curves: TrustCurves, ensemble_size: int, thresholds: TrustThresholds | None = None) -> TrustReport:
    """The :class:`TrustReport` of per-midpoint curves."""
    th = thresholds or TrustThresholds()
    contact = curves.gap <= th.gap_tolerance
    dt = np.gradient(curves.t) if curves.t.size > 1 else np.ones_like(curves.t)
    force_norm = np.linalg.norm(curves.force, axis=1)
    open_force = np.where(contact, 0.0, force_norm)
    k_open = int(np.argmax(open_force)) if open_force.size else 0
    open_max = float(open_force[k_open]) if open_force.size else 0.0
    max_std_contact = float(curves.force_std[contact].max()) if contact.any() else None
    reasons = []
    if open_max > th.open_gap_force_tolerance:
        reasons.append(
            f"ghost force: the surrogate predicts {open_max:.3g} N with the head {1e3 * curves.gap[k_open]:.3g} mm "
            f"clear of the cushion at t = {curves.t[k_open]:.3g} s (tolerance {th.open_gap_force_tolerance:g} N "
            f"beyond {1e3 * th.gap_tolerance:g} mm)"
        )
    if max_std_contact is not None and max_std_contact > th.contact_std_threshold:
        reasons.append(
            f"ensemble disagreement: force std up to {max_std_contact:.3g} N in contact "
            f"(threshold {th.contact_std_threshold:g} N)"
        )
    dist = curves.pool_distance
    return TrustReport(
        trusted=not reasons,
        reasons=reasons,
        ensemble_size=ensemble_size,
        contact_fraction=float(contact.mean()) if contact.size else 0.0,
        max_std_contact=max_std_contact,
        integral_std_contact=float(np.sum(curves.force_std * dt * contact)),
        max_std=float(curves.force_std.max()) if curves.force_std.size else 0.0,
        open_gap_max_force=open_max,
        open_gap_at_gap=float(curves.gap[k_open]) if open_max > 0 else None,
        open_gap_at_time=float(curves.t[k_open]) if open_max > 0 else None,
        min_gap=float(curves.gap.min()),
        max_pool_distance=None if dist is None else float(dist.max()),
        median_pool_distance=None if dist is None else float(np.median(dist)),
        thresholds=th.model_dump(),
    )


def assess_solution(
    model: SurrogateModel,
    preset: HeadNeckPreset,
    t: FloatArray,
    q: FloatArray,
    pool_features: FloatArray | None = None,
    thresholds: TrustThresholds | None = None,
    kinematics: Callable[[FloatArray, FloatArray], RelativeKinematics] | None = None,
) -> TrustReport:
    """Trust diagnostics of an OCP solution (nodes ``t``, ``q``) solved with ``model`` as the contact
    (``kinematics``: a chain's, see :func:`trust_curves`)."""
    curves = trust_curves(model, preset, t, q, pool_features, kinematics)
    return assess_curves(curves, model.ensemble_size, thresholds)


def force_variance_function(std_function: ca.Function) -> ca.Function:
    """``(q, qd[, p]) -> sigma_F^2`` (scalar) from an ensemble std function with outputs ``(std, var)``
    (:func:`alcove.science.surrogate.casadi_contact.casadi_contact_std_function` or ``surrogate_contact_std``)."""
    ins = [ca.SX.sym(std_function.name_in(i), std_function.sparsity_in(i)) for i in range(std_function.n_in())]
    var = std_function(*ins)[1]
    return ca.Function("force_variance", ins, [ca.sum1(var[:3])], std_function.name_in(), ["force_var"])


__all__ = [
    "TrustCurves",
    "TrustReport",
    "TrustThresholds",
    "assess_curves",
    "assess_solution",
    "force_variance_function",
    "midpoints",
    "scaled_features",
    "trust_curves",
]
