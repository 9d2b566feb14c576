"""The ghost-force case (an ensemble whose members disagree about a force out of contact), built reproducibly.

An ensemble of K = 4: two members trained on the auxiliary penalty model's preliminary data
(honest: zero force while the head is clear of the cushion), two trained on the same states
with an invented force: a bump of 80 N along the headrest normal (with its moment about the
head COG) while the gap is open, centred at 8 mm with a 3 mm width (exp(-((gap - 8 mm) / 3 mm)^2)).
Deep in contact and far from the cushion the members agree; in the band they disagree, and
their mean holds the head in mid-air: the OCP's "hovering rest" of the issue, where the
ensemble's force std is large.
"""

from __future__ import annotations

import numpy as np

from alcove.science.geometry import HeadNeckPreset, relative_kinematics, signed_gap
from alcove.science.oracles.aux_penalty import AuxPenaltyParams, contact_point
from alcove.science.surrogate.config import NetworkConfig, SurrogateConfig
from alcove.science.surrogate.dataset import PoolDataset
from alcove.science.surrogate.mlp import SurrogateModel
from alcove.science.surrogate.preliminary import preliminary_pool
from alcove.science.surrogate.training import train_surrogate

GHOST_AMPLITUDE = 80.0  # N
GHOST_GAP = 0.008  # m
GHOST_WIDTH = 0.003  # m


def ghost_force(preset: HeadNeckPreset, q: np.ndarray) -> np.ndarray:
    """The invented normal force [N] at the head angles q."""
    return GHOST_AMPLITUDE * np.exp(-(((signed_gap(preset, q) - GHOST_GAP) / GHOST_WIDTH) ** 2))


def _with_ghost(preset: HeadNeckPreset, ds: PoolDataset) -> PoolDataset:
    q, qd = ds.q[:, 0], ds.qd[:, 0]
    kin = relative_kinematics(preset, q, qd)
    arm = np.einsum("nij,j->ni", kin.T_rel, contact_point(preset, AuxPenaltyParams()))
    extra = np.zeros((q.size, 3))
    extra[:, 0] = ghost_force(preset, q)
    return PoolDataset(ds.name, ds.t, ds.q, ds.qd, ds.force + extra, ds.moment + np.cross(arm, extra), ds.origin)


def ghost_pools(preset: HeadNeckPreset) -> tuple[list[PoolDataset], list[PoolDataset]]:
    honest = preliminary_pool(preset, samples=1500, seed=0)
    return honest, [_with_ghost(preset, ds) for ds in honest]


def ghost_ensemble(preset: HeadNeckPreset) -> tuple[SurrogateModel, list[PoolDataset]]:
    """The K = 4 ghost-force ensemble and the honest pool (whose features cover the whole range)."""
    honest, ghost = ghost_pools(preset)
    net = NetworkConfig(hidden=(24, 24))
    # float64 training, the paper's early stopping (patience in epochs alone) and the paper's shared force
    # net: the case (its members' disagreement where the ghost holds the head) was built with them
    cfg = SurrogateConfig(
        max_epochs=300,
        ensemble_size=2,
        force=net,
        moment=net,
        dtype="float64",
        patience_steps=0,
        normal_force="shared",
    )
    a = train_surrogate(honest, cfg, seed=0, preset=preset).model
    b = train_surrogate(ghost, cfg, seed=1, preset=preset).model
    model = SurrogateModel.from_members(
        a.members + b.members, cfg.model_copy(update={"ensemble_size": 4}), preset, lineage={"case": "ghost-force"}
    )
    return model, honest
