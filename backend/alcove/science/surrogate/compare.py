"""Surrogate variants side by side: the ``paper`` model, the ``gated`` architecture and the
``history`` feature set (:data:`VARIANTS`), trained on the same pool with the same protocol and
seed, scored on the same held-out motions (the validation suite,
:mod:`alcove.science.validation_suite`, replayed by an oracle; never in the pool).

Per variant (:class:`SuiteScore`), over all samples of all suite motions:

* ``force_rmse``, ``moment_rmse``: the vector RMSE of :mod:`.metrics`, ``sqrt(mean_i |F_pred,i - F_true,i|^2)``
  (the moment likewise), and the same over the samples in contact (``|F_true| > 0``); the RMSE of
  the components fx, fz and my;
* the *ghost force* where the geometry says the gap is open (signed gap of
  :func:`alcove.science.geometry.signed_gap` >= ``gap_tolerance``, default 2 mm, the trust
  diagnostics' "clearly open"): the largest and the RMS predicted ``|F|`` [N] and the largest
  ``|M|`` [N m] over those suite samples, with the oracle's own largest ``|F|`` there (0 when the
  oracle agrees the head is free);
* the ghost force on a grid of states over the whole joint range (``GRID`` angles x velocities,
  the gap open): where the networks extrapolate, as an OCP may drive them;
* the members' mean test RMSE on their own test simulations (the in-training metric), the epochs
  (the most over members) and the training wall time (the first training of a process also pays
  one-off start-up costs: not a speed comparison).

Every variant sees the same pool, the same config except its ``architecture`` and ``features``,
and the same seed. A ``history`` model predicts along each suite motion (its times).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from alcove.science.arrays import FloatArray
from alcove.science.geometry import HeadNeckPreset, signed_gap
from alcove.science.series import ForceSeries, Trajectory, stack_wrench
from alcove.science.surrogate.config import SurrogateConfig
from alcove.science.surrogate.dataset import PoolDataset
from alcove.science.surrogate.metrics import wrench_metrics
from alcove.science.surrogate.mlp import SurrogateModel
from alcove.science.surrogate.training import predict_ensemble, train_surrogate

#: the variants: what each changes in the configuration
VARIANTS: dict[str, dict[str, str]] = {
    "paper": {"architecture": "paper", "features": "paper"},
    "gated": {"architecture": "gated", "features": "paper"},
    "history": {"architecture": "paper", "features": "history"},
}
GAP_TOLERANCE = 0.002  # m, as alcove.science.surrogate.trust.TrustThresholds.gap_tolerance
GRID = (81, 21)  # angles over the joint range x velocities over [-GRID_SPEED, GRID_SPEED]
GRID_SPEED = 2.0  # rad/s


@dataclass
class SuiteScore:
    """One variant's figures (module docstring); JSON-ready via :meth:`to_dict`."""

    variant: str
    architecture: str
    features: str
    force_rmse: float | None
    moment_rmse: float | None
    force_rmse_contact: float | None
    moment_rmse_contact: float | None
    fx_rmse: float | None
    fz_rmse: float | None
    my_rmse: float | None
    ghost_force_max: float  # N, max |F_pred| over suite samples with the gap open
    ghost_force_rms: float  # N
    ghost_moment_max: float  # N m
    oracle_force_open_max: float  # N, the oracle's max |F| over the same samples
    grid_ghost_force_max: float  # N, max |F_pred| over the grid states with the gap open
    n_samples: int
    n_open_samples: int
    n_contact_samples: int
    test_force_rmse: float | None
    test_moment_rmse: float | None
    epochs: dict[str, int]
    train_wall_time_s: float

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def replay_suite(
    run: Callable[[Trajectory], ForceSeries], trajectories: Sequence[Trajectory], prefix: str = "validation"
) -> list[PoolDataset]:
    """The suite's motions with the oracle's forces (``run`` raises on a failed replay); where the
    oracle reports on its own time grid the motion is resampled onto it (as a campaign stores it)."""
    out = []
    for i, traj in enumerate(trajectories):
        forces = run(traj)
        if len(forces.t) != len(traj.t) or not np.allclose(forces.t, traj.t, rtol=0, atol=1e-12):
            traj = traj.resample(forces.t)
        out.append(PoolDataset.from_series(f"{prefix}-{i:02d}", traj, forces, "oracle"))
    return out


def _ghost_grid(model: SurrogateModel, preset: HeadNeckPreset, gap_tolerance: float) -> float:
    th = np.linspace(preset.theta_min, preset.theta_max, GRID[0])
    q, qd = (a.ravel() for a in np.meshgrid(th, np.linspace(-GRID_SPEED, GRID_SPEED, GRID[1])))
    open_ = signed_gap(preset, q) >= gap_tolerance
    if not open_.any():
        return 0.0
    p = predict_ensemble(model, q[open_], qd[open_], steady=True)
    return float(np.linalg.norm(p.force, axis=1).max())


def score_on_suite(
    model: SurrogateModel,
    suite: Sequence[PoolDataset],
    preset: HeadNeckPreset,
    gap_tolerance: float = GAP_TOLERANCE,
) -> dict[str, Any]:
    """The suite figures of one model (the keys of :class:`SuiteScore` without the training ones)."""
    if not suite:
        raise ValueError("suite: no held-out motions to score on")
    preds, trues, gaps = [], [], []
    for ds in suite:
        p = predict_ensemble(model, ds.q, ds.qd, t=ds.t)
        preds.append(stack_wrench(p.force, p.moment))
        trues.append(stack_wrench(ds.force, ds.moment))
        gaps.append(signed_gap(preset, ds.q[:, 0]))
    pred, true, gap = np.vstack(preds), np.vstack(trues), np.concatenate(gaps)
    m = wrench_metrics(pred, true)
    open_ = gap >= gap_tolerance

    def largest(a: FloatArray) -> float:
        return float(a.max()) if a.size else 0.0

    f_open = np.linalg.norm(pred[open_, :3], axis=1)
    return {
        "force_rmse": m["force_rmse"],
        "moment_rmse": m["moment_rmse"],
        "force_rmse_contact": m["force_rmse_contact"],
        "moment_rmse_contact": m["moment_rmse_contact"],
        "fx_rmse": m["rmse_fx"],
        "fz_rmse": m["rmse_fz"],
        "my_rmse": m["rmse_my"],
        "ghost_force_max": largest(f_open),
        "ghost_force_rms": float(np.sqrt(np.mean(f_open**2))) if f_open.size else 0.0,
        "ghost_moment_max": largest(np.linalg.norm(pred[open_, 3:], axis=1)),
        "oracle_force_open_max": largest(np.linalg.norm(true[open_, :3], axis=1)),
        "grid_ghost_force_max": _ghost_grid(model, preset, gap_tolerance),
        "n_samples": int(pred.shape[0]),
        "n_open_samples": int(open_.sum()),
        "n_contact_samples": m["n_contact_samples"],
    }


def compare_variants(
    pool: list[PoolDataset],
    suite: Sequence[PoolDataset],
    config: SurrogateConfig,
    seed: int,
    preset: HeadNeckPreset,
    variants: Sequence[str] = tuple(VARIANTS),
    gap_tolerance: float = GAP_TOLERANCE,
) -> tuple[list[SuiteScore], dict[str, SurrogateModel]]:
    """Train ``config`` as each variant of :data:`VARIANTS` on ``pool`` (same seed) and score each on ``suite``."""
    unknown = [v for v in variants if v not in VARIANTS]
    if unknown:
        raise ValueError(f"variants: {', '.join(map(repr, unknown))} not one of {', '.join(VARIANTS)}")
    scores, models = [], {}
    for variant in variants:
        cfg = config.model_copy(update=VARIANTS[variant])
        t0 = time.perf_counter()
        result = train_surrogate(pool, cfg, seed, preset=preset)
        wall = time.perf_counter() - t0
        rmse = result.metrics.rmse
        scores.append(
            SuiteScore(
                variant=variant,
                architecture=cfg.architecture,
                features=cfg.features,
                **score_on_suite(result.model, suite, preset, gap_tolerance),
                test_force_rmse=rmse["force"]["test"],
                test_moment_rmse=rmse["moment"]["test"],
                epochs=dict(result.metrics.epochs),
                train_wall_time_s=wall,
            )
        )
        models[variant] = result.model
    return scores, models


__all__ = ["GAP_TOLERANCE", "VARIANTS", "SuiteScore", "compare_variants", "replay_suite", "score_on_suite"]
