"""The contact-aware output layer of the ``gated`` architecture.

A surrogate config with ``"architecture": "gated"`` keeps the paper's two MLPs and features
and puts this layer after their de-standardised outputs: in training (:mod:`.ensemble`, the
loss is taken on the gated output), prediction (:class:`.mlp.SurrogateModel`), the OCP's
CasADi function (:mod:`.casadi_contact`), TorchScript (:mod:`.artifact`) and the portable CasADi and
ONNX exports (:mod:`.portable`). The gate parameters are the config's ``gate`` (:func:`gate_params`;
default :data:`DEFAULT_GATE`, recorded in ``surrogate.json``); the head profile is the model's
preset's (the OCP's function takes the task's preset).

Signed gap from the 19 features
    The features hold the head origin in the headrest frame (``r_x``) and the first column of
    ``T_rel = R_y(-a)``, ``(cos a, 0, sin a)`` (``T_00``, ``T_20``), so the signed gap of
    :func:`alcove.science.geometry.signed_gap` (head profile ellipse to undeformed headrest
    surface along its normal) is a function of the features and the head profile:
    ``gap = r_x + T_00 cx - T_20 cz - sqrt((ax T_00)^2 + (az T_20)^2)``.

Output layer
    With the networks' (de-standardised) outputs ``u`` (force 3, moment 3) and
    ``s = clip((open_gap - gap) / blend, 0, 1)``, the gate is the quintic smoothstep
    ``g(s) = s^3 (10 - 15 s + 6 s^2)`` (C2: value, first and second derivatives continuous at
    ``s = 0`` and ``s = 1``): exactly 0 when ``gap >= open_gap`` (clearly open), 1 when
    ``gap <= open_gap - blend``. The wrench is ``gate * (softplus_w(u_fx), u_fy, u_fz, u_m)``,
    with ``softplus_w(x) = w log(1 + exp(x / w))`` >= 0: the normal force pushes the head away
    (``fx >= 0`` in H) and vanishes with the gate, smoothly in the state.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import torch

from alcove.science.arrays import FloatArray
from alcove.science.geometry import HeadProfile

if TYPE_CHECKING:
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.symbolic import Symbolic

R_X, T_00, T_20 = 0, 6, 8  # indices in FEATURE_NAMES


@dataclass(frozen=True)
class GateParams:
    """Where the gate closes: exactly zero for gap >= open_gap [m], one for gap <= open_gap - blend."""

    open_gap: float = 0.002
    blend: float = 0.002
    force_width: float = 1.0  # N, width of the softplus of the normal force

    def __post_init__(self) -> None:
        for name in ("open_gap", "blend", "force_width"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name}: must be a positive finite number, got {value!r}")


DEFAULT_GATE = GateParams()


def gate_params(config: SurrogateConfig) -> GateParams:
    """The gate parameters of a surrogate config (its ``gate`` entry)."""
    g = config.gate
    return GateParams(open_gap=g.open_gap, blend=g.blend, force_width=g.force_width)


@dataclass(frozen=True)
class Gate:
    """The gate of a model: where it closes and the head profile the gap is measured from."""

    params: GateParams
    profile: HeadProfile


def gate_value(gap: FloatArray, params: GateParams) -> FloatArray:
    """The gate ``g(s)`` in [0, 1] (NumPy): 0 for gap >= open_gap, 1 for gap <= open_gap - blend."""
    s = np.clip((params.open_gap - np.asarray(gap, float)) / params.blend, 0.0, 1.0)
    out: FloatArray = s**3 * (10 - 15 * s + 6 * s**2)
    return out


def gate_torch(gap: torch.Tensor, params: GateParams) -> torch.Tensor:
    """The gate ``g(s)`` (PyTorch)."""
    s = torch.clamp((params.open_gap - gap) / params.blend, 0.0, 1.0)
    return s**3 * (10 - 15 * s + 6 * s**2)


def softplus_width_torch(x: torch.Tensor, width: float) -> torch.Tensor:
    """``w log(1 + exp(x / w))`` written as the CasADi and ONNX exports write it."""
    z = x / width
    return width * (torch.clamp(z, min=0) + torch.log1p(torch.exp(-z.abs())))


def gated_net_output_torch(
    net: str, u: torch.Tensor, gate: torch.Tensor, params: GateParams, axis: int
) -> torch.Tensor:
    """One net's gated output: ``u`` its de-standardised outputs (3 along ``axis``), ``gate`` broadcastable.

    ``force``: ``gate * (softplus_w(u_fx), u_fy, u_fz)``; ``moment``: ``gate * u``.
    """
    if net == "force":
        fx = softplus_width_torch(u.narrow(axis, 0, 1), params.force_width)
        u = torch.cat([fx, u.narrow(axis, 1, u.shape[axis] - 1)], axis)
    return gate * u


def gated_net_output_symbolic(net: str, u: Symbolic, gap: Symbolic, params: GateParams) -> Symbolic:
    """CasADi version of :func:`gated_net_output_torch` for one net's column ``u`` (3 x 1)."""
    import casadi as ca

    s = ca.fmin(ca.fmax((params.open_gap - gap) / params.blend, 0), 1)
    gate = s**3 * (10 - 15 * s + 6 * s**2)
    if net == "force":
        z = u[0] / params.force_width
        u = ca.vertcat(params.force_width * (ca.fmax(z, 0) + ca.log1p(ca.exp(-ca.fabs(z)))), u[1:])
    return gate * u


def gap_from_features(x: FloatArray, profile: HeadProfile) -> FloatArray:
    """Signed gap [m] from raw features (n, 19) (NumPy)."""
    x = np.asarray(x, float)
    c, s = x[:, T_00], x[:, T_20]
    gap: FloatArray = (
        x[:, R_X] + c * profile.cx - s * profile.cz - np.sqrt((profile.ax * c) ** 2 + (profile.az * s) ** 2)
    )
    return gap


def gap_from_features_torch(x: torch.Tensor, profile: HeadProfile) -> torch.Tensor:
    """Signed gap from raw features (..., 19) (PyTorch, differentiable)."""
    c, s = x[..., T_00], x[..., T_20]
    return x[..., R_X] + c * profile.cx - s * profile.cz - torch.sqrt((profile.ax * c) ** 2 + (profile.az * s) ** 2)


def gap_from_features_symbolic(x: Symbolic, profile: HeadProfile) -> Symbolic:
    """Signed gap from a raw feature column (19 x 1) (CasADi)."""
    import casadi as ca

    c, s = x[T_00], x[T_20]
    return x[R_X] + c * profile.cx - s * profile.cz - ca.sqrt((profile.ax * c) ** 2 + (profile.az * s) ** 2)


def gated_wrench_torch(u: torch.Tensor, gap: torch.Tensor, params: GateParams) -> torch.Tensor:
    """The output layer (module docstring): raw outputs ``u`` (..., 6), gap (...) -> wrench (..., 6)."""
    s = torch.clamp((params.open_gap - gap) / params.blend, 0.0, 1.0)
    gate = s**3 * (10 - 15 * s + 6 * s**2)
    z = u[..., :1] / params.force_width
    fx = params.force_width * (torch.clamp(z, min=0) + torch.log1p(torch.exp(-z.abs())))  # the CasADi formula
    return gate.unsqueeze(-1) * torch.cat([fx, u[..., 1:]], -1)


def gated_wrench_symbolic(u: Symbolic, gap: Symbolic, params: GateParams) -> Symbolic:
    """CasADi version of :func:`gated_wrench_torch` for one column ``u`` (6 x 1)."""
    import casadi as ca

    s = ca.fmin(ca.fmax((params.open_gap - gap) / params.blend, 0), 1)
    gate = s**3 * (10 - 15 * s + 6 * s**2)
    z = u[0] / params.force_width
    fx = params.force_width * (ca.fmax(z, 0) + ca.log1p(ca.exp(-ca.fabs(z))))
    return gate * ca.vertcat(fx, u[1:])


__all__ = [
    "DEFAULT_GATE",
    "Gate",
    "GateParams",
    "gap_from_features",
    "gap_from_features_symbolic",
    "gap_from_features_torch",
    "gate_params",
    "gate_torch",
    "gate_value",
    "gated_net_output_symbolic",
    "gated_net_output_torch",
    "gated_wrench_symbolic",
    "gated_wrench_torch",
    "softplus_width_torch",
]
