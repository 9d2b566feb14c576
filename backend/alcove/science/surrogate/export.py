"""CasADi SX rebuild of a trained surrogate for the OCP (no l4casadi).

The whole map (q, qd) -> relative kinematics -> 19 features -> input standardisation ->
force MLP and moment MLP -> output de-standardisation is rebuilt as one SX expression from
the weights, so IPOPT gets exact first and second derivatives. Softplus is written as
``fmax(x, 0) + log1p(exp(-|x|))``, the formula the torch nets use, so values match torch
to rounding; ``alpha_rel^2`` uses the smooth small-angle branch of :mod:`.features`.

The function is the OCP's contact-model slot: inputs ``q`` and ``qd`` (ndof x 1), one
output ``wrench`` (6 x 1) ``[fx, fy, fz, mx, my, mz]`` in the headrest frame, the moment
about the head frame origin. The generalized force is ``J^T [F; M]`` (the OCP's job).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

import casadi as ca
from alcove.science.geometry import HeadNeckPreset, relative_kinematics_symbolic
from alcove.science.surrogate.features import N_FEATURES, features_symbolic
from alcove.science.surrogate.mlp import MLP, Standardization, SurrogateModel

SymbolicKinematics = Callable[[Any, Any], tuple[Any, Any, Any, Any]]


def _activation(name: str, x: ca.SX) -> ca.SX:
    if name == "softplus":
        return ca.fmax(x, 0) + ca.log1p(ca.exp(-ca.fabs(x)))
    if name == "tanh":
        return ca.tanh(x)
    if name == "sigmoid":
        return 1 / (1 + ca.exp(-x))
    raise ValueError(f"activation: no CasADi rebuild for {name!r}")


def mlp_symbolic(net: MLP, x: ca.SX) -> ca.SX:
    """The MLP applied to a column vector ``x`` (SX), weights as float64 constants."""
    linears = net.linears()
    for i, lin in enumerate(linears):
        W = ca.DM(lin.weight.detach().double().numpy())
        b = ca.DM(lin.bias.detach().double().numpy())
        x = ca.mtimes(W, x) + b
        if i < len(linears) - 1:
            x = _activation(net.activation, x)
    return x


def _standardize(norm: Standardization, x: ca.SX) -> ca.SX:
    return (x - ca.DM(norm.mean)) / ca.DM(norm.divisor)


def _destandardize(norm: Standardization, z: ca.SX) -> ca.SX:
    return z * ca.DM(norm.scale) + ca.DM(norm.mean)


def wrench_symbolic(model: SurrogateModel, feats: ca.SX) -> ca.SX:
    """Wrench (6 x 1) from the raw feature vector (19 x 1)."""
    z = _standardize(model.input_norm, feats)
    force = _destandardize(model.force_norm, mlp_symbolic(model.force_net, z))
    moment = _destandardize(model.moment_norm, mlp_symbolic(model.moment_net, z))
    return ca.vertcat(force, moment)


def casadi_network_function(model: SurrogateModel) -> ca.Function:
    """``features (19 x 1) -> wrench (6 x 1)``: the networks with their normalisation."""
    x = ca.SX.sym("features", N_FEATURES)
    return ca.Function("surrogate_network", [x], [wrench_symbolic(model, x)], ["features"], ["wrench"])


def casadi_contact_function(model: SurrogateModel, preset: HeadNeckPreset,
                            kinematics: SymbolicKinematics | None = None) -> ca.Function:
    """``(q, qd) -> wrench``, the OCP's contact-model slot (see the module docstring).

    ``kinematics(q, qd)`` returns ``(r_rel, v_rel, T_rel, omega_rel)`` symbolically for
    chains other than the 1-DOF preset, whose kinematics come from
    :func:`alcove.science.geometry.relative_kinematics_symbolic`.
    """
    ndof = model.ndof
    q = ca.SX.sym("q", ndof)
    qd = ca.SX.sym("qd", ndof)
    if kinematics is None:
        if ndof != 1:
            raise ValueError(f"kinematics: the model has {ndof} degrees of freedom; pass symbolic kinematics for that chain")
        kin = relative_kinematics_symbolic(preset, q[0], qd[0])
    else:
        kin = kinematics(q, qd)
    wrench = wrench_symbolic(model, features_symbolic(*kin))
    return ca.Function("contact_surrogate", [q, qd], [wrench], ["q", "qd"], ["wrench"])


def casadi_contact_from_artifact(path: str | Path, preset: HeadNeckPreset) -> ca.Function:
    """Load a model artifact (directory or its ``surrogate.json``) and export it."""
    from alcove.science.surrogate.artifact import load_artifact

    return casadi_contact_function(load_artifact(path), preset)


__all__ = [
    "casadi_contact_from_artifact",
    "casadi_contact_function",
    "casadi_network_function",
    "mlp_symbolic",
    "wrench_symbolic",
]
