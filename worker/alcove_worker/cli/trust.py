"""The surrogate's trust diagnostics and trust region for `alcove ocp solve --contact model:FILE`."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
import numpy as np

from alcove.science.geometry import HeadNeckPreset
from alcove.science.multibody import PlanarChain
from alcove.science.surrogate.mlp import SurrogateModel
from alcove.science.surrogate.trust import TrustReport, assess_solution


class TrustInputError(ValueError):
    def __init__(self, field: str, reason: str):
        self.field, self.reason = field, reason
        super().__init__(f"{field}: {reason}")


@dataclass
class TrustInputs:
    model: SurrogateModel
    preset: HeadNeckPreset
    path: tuple[ca.Function, float] | None
    pool_features: np.ndarray | None
    chain: PlanarChain | None = None

    @classmethod
    def load(
        cls,
        model_path: Path,
        preset: HeadNeckPreset,
        max_std: float | None,
        pool: Path | None,
        chain: PlanarChain | None = None,
    ) -> TrustInputs:
        """``chain``: a chain task's model (the features from its head's pose); None: the 1-DOF ``preset``."""
        from alcove.science.surrogate.artifact import load_artifact
        from alcove.science.surrogate.casadi_contact import casadi_contact_std_function, chain_kinematics
        from alcove.science.surrogate.dataset import PoolDataError, load_pool_dir
        from alcove.science.surrogate.history import history_inputs
        from alcove.science.surrogate.training import pool_features, pose_kinematics, preset_kinematics
        from alcove.science.surrogate.trust import force_variance_function

        try:
            model = load_artifact(model_path)
        except (ValueError, OSError, KeyError) as exc:
            raise TrustInputError("contact", f"cannot load the surrogate model: {exc}") from exc
        path = None
        if max_std is not None:
            if not (math.isfinite(max_std) and max_std > 0):
                raise TrustInputError("trust-region-max-std", f"must be a positive number of newtons, got {max_std!r}")
            if model.ensemble_size < 2:
                raise TrustInputError(
                    "trust-region-max-std", "the model is a single network (ensemble_size 1): it has no std to bound"
                )
            sym = None if chain is None else chain_kinematics(chain)
            path = (force_variance_function(casadi_contact_std_function(model, preset, sym)), max_std**2)
        features = None
        if pool is not None:
            if not pool.is_dir():
                raise TrustInputError("pool", f"{pool} is not a folder")
            try:
                kin = preset_kinematics(preset) if chain is None else pose_kinematics(chain.head_pose)
                inputs = history_inputs(model.config.features, model.config.history, preset)
                features = pool_features(load_pool_dir(pool), kin, inputs=inputs)
            except PoolDataError as exc:
                raise TrustInputError(f"pool.{exc.field}", exc.reason) from exc
        return cls(model, preset, path, features, chain)

    def assess(self, t: np.ndarray, q: np.ndarray) -> TrustReport:
        from alcove.science.surrogate.training import pose_kinematics

        kin = None if self.chain is None else pose_kinematics(self.chain.head_pose)
        return assess_solution(self.model, self.preset, t, q, self.pool_features, kinematics=kin)
