"""CasADi SX rebuild of a trained surrogate for the OCP (no l4casadi).

The whole map (q, qd) -> relative kinematics -> 19 features -> input standardisation ->
force MLP and moment MLP -> output de-standardisation is rebuilt as one SX expression from
the weights, so IPOPT gets exact first and second derivatives. Softplus is written as
``fmax(x, 0) + log1p(exp(-|x|))``, the formula the torch nets use, so values match torch
to rounding; ``alpha_rel^2`` uses the smooth small-angle branch of :mod:`.features`.

The function is the OCP's contact-model slot: inputs ``q`` and ``qd`` (ndof x 1), one
output ``wrench`` (6 x 1) ``[fx, fy, fz, mx, my, mz]`` in the headrest frame, the moment
about the head frame origin. The generalized force is ``J^T [F; M]`` (the OCP's job).
For an ensemble (K > 1) the wrench is the members' mean; :func:`casadi_contact_std_function`
and :func:`surrogate_contact_std` give the members' standard deviation
``sqrt(mean_k (w_k - mean)^2)`` (not differentiable where it is 0, e.g. the structurally zero
outputs: constrain its square, output ``var``, in an NLP).

:func:`surrogate_contact` gives the same map with the weights and normalisations as a third
input ``p`` (:func:`surrogate_parameters`): one function per architecture, so the OCP's NLP
and IPOPT solver are built once and reused for every model version of that architecture.

The ``gated`` architecture (:mod:`.gated`) adds its output layer after the de-standardisation:
the signed gap is computed from the same symbolic features with the head profile of the
preset passed in (the task's, for the OCP's functions; the model's own for the network-only
function and the portable exports).
"""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np

from alcove.science.arrays import FloatArray
from alcove.science.geometry import HeadNeckPreset, HeadProfile, relative_kinematics_symbolic
from alcove.science.surrogate.features import N_FEATURES, features_symbolic
from alcove.science.surrogate.gated import GateParams, gap_from_features_symbolic, gated_net_output_symbolic
from alcove.science.surrogate.history import (
    N_HISTORY,
    ContactHistory,
    contact_point_motion_symbolic,
    history_step_symbolic,
)
from alcove.science.surrogate.mlp import MLP, Standardization, SurrogateModel

if TYPE_CHECKING:
    from alcove.science.multibody import PlanarChain

#: (q, qd) -> (r_rel, v_rel, T_rel, omega_rel) of the contact body in the headrest frame, as SX
SymbolicKinematics = Callable[[ca.SX, ca.SX], tuple[ca.SX, ca.SX, ca.SX, ca.SX]]
#: a network's activation and the (rows, columns) of its layers' weights
#: activation, per layer (rows, cols), and per layer the column-major positions of the weights that may be
#: non-zero (a net of blocks: the weights between blocks are not parameters) or None (dense)
NetArchitecture = tuple[str, tuple[tuple[int, int], ...], tuple[tuple[int, ...] | None, ...]]
#: ndof, number of inputs, force net, force outputs, moment net, moment outputs, ensemble members,
#: the gate parameters (open_gap, blend, force_width) of the gated architecture or None
Architecture = tuple[int, int, NetArchitecture, int, NetArchitecture, int, int, tuple[float, float, float] | None]


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


def _gated(force: ca.SX, moment: ca.SX, gap: ca.SX | None, params: GateParams | None) -> ca.SX:
    if gap is None or params is None:
        return ca.vertcat(force, moment)
    return ca.vertcat(
        gated_net_output_symbolic("force", force, gap, params),
        gated_net_output_symbolic("moment", moment, gap, params),
    )


def member_wrenches_symbolic(model: SurrogateModel, feats: ca.SX, profile: HeadProfile | None = None) -> list[ca.SX]:
    """Every member's wrench (6 x 1) from the raw feature vector (19 x 1); the gated
    architecture's gap with ``profile`` (default: the model's preset's head profile)."""
    gate = model.gate
    gap = None if gate is None else gap_from_features_symbolic(feats, profile or gate.profile)
    out = []
    for m in model.members:
        z = _standardize(m.input_norm, feats)
        force = _destandardize(m.force_norm, mlp_symbolic(m.force_net, z))
        moment = _destandardize(m.moment_norm, mlp_symbolic(m.moment_net, z))
        out.append(_gated(force, moment, gap, None if gate is None else gate.params))
    return out


def _mean_var(wrenches: list[ca.SX]) -> tuple[ca.SX, ca.SX]:
    k = len(wrenches)
    mean = wrenches[0] if k == 1 else sum(wrenches[1:], wrenches[0]) / k
    var = sum(((w - mean) ** 2 for w in wrenches[1:]), (wrenches[0] - mean) ** 2) / k
    return mean, var


def wrench_symbolic(model: SurrogateModel, feats: ca.SX, profile: HeadProfile | None = None) -> ca.SX:
    """Wrench (6 x 1), the ensemble mean, from the raw feature vector (19 x 1)."""
    return _mean_var(member_wrenches_symbolic(model, feats, profile))[0]


def wrench_var_symbolic(model: SurrogateModel, feats: ca.SX, profile: HeadProfile | None = None) -> ca.SX:
    """The members' variance of the wrench (6 x 1), ``mean_k (w_k - mean)^2``."""
    return _mean_var(member_wrenches_symbolic(model, feats, profile))[1]


def casadi_network_function(model: SurrogateModel) -> ca.Function:
    """``features (19 x 1) -> wrench (6 x 1)``: the networks with their normalisation."""
    x = ca.SX.sym("features", N_FEATURES)
    return ca.Function("surrogate_network", [x], [wrench_symbolic(model, x)], ["features"], ["wrench"])


def casadi_contact_function(
    model: SurrogateModel, preset: HeadNeckPreset, kinematics: SymbolicKinematics | None = None
) -> ca.Function:
    """``(q, qd) -> wrench``, the OCP's contact-model slot (see the module docstring).

    ``kinematics(q, qd)`` returns ``(r_rel, v_rel, T_rel, omega_rel)`` symbolically for
    chains other than the 1-DOF preset, whose kinematics come from
    :func:`alcove.science.geometry.relative_kinematics_symbolic`.
    """
    q, qd, feats = _state_features(model, preset, kinematics)
    inputs, names, feats = _with_history(model, [q, qd], feats)
    wrench = wrench_symbolic(model, feats, preset.profile)
    return ca.Function("contact_surrogate", inputs, [wrench], names, ["wrench"])


def _with_history(model: SurrogateModel, state: list[ca.SX], feats: ca.SX) -> tuple[list[ca.SX], list[str], ca.SX]:
    """The inputs (q, qd) and the features, with the history states z as a third input and the
    last inputs of the networks for a model of the ``history`` feature set."""
    if model.config.features != "history":
        return state, ["q", "qd"], feats
    z = ca.SX.sym("z", N_HISTORY)
    return [*state, z], ["q", "qd", "z"], ca.vertcat(feats, z)


def _state_features(
    model: SurrogateModel, preset: HeadNeckPreset, kinematics: SymbolicKinematics | None
) -> tuple[ca.SX, ca.SX, ca.SX]:
    ndof = model.ndof
    q = ca.SX.sym("q", ndof)
    qd = ca.SX.sym("qd", ndof)
    if kinematics is None:
        if ndof != 1:
            raise ValueError(
                f"kinematics: the model has {ndof} degrees of freedom; pass symbolic kinematics for that chain"
            )
        kin = relative_kinematics_symbolic(preset, q[0], qd[0])
    else:
        kin = kinematics(q, qd)
    return q, qd, features_symbolic(*kin)


def chain_kinematics(chain: PlanarChain) -> SymbolicKinematics:
    """A chain's symbolic kinematics of its contact body relative to the headrest (the features'
    input, for :func:`casadi_contact_function`)."""

    def kin(q: ca.SX, qd: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX, ca.SX]:
        r_rel, v_rel, T_rel, omega_rel = chain.relative_kinematics_function(q, qd)
        return r_rel, v_rel, T_rel, omega_rel

    return kin


def casadi_contact_std_function(
    model: SurrogateModel, preset: HeadNeckPreset, kinematics: SymbolicKinematics | None = None
) -> ca.Function:
    """``(q, qd) -> (std, var)`` (6 x 1 each): the ensemble's standard deviation and variance per output."""
    q, qd, feats = _state_features(model, preset, kinematics)
    inputs, names, feats = _with_history(model, [q, qd], feats)
    _, var = _mean_var(member_wrenches_symbolic(model, feats, preset.profile))
    return ca.Function("contact_surrogate_std", inputs, [ca.sqrt(var), var], names, ["std", "var"])


# ---- parametric form: the weights as an input -------------------------------------------
def _weight_positions(net: MLP) -> tuple[tuple[int, ...] | None, ...]:
    """Per layer, the column-major positions of the weights that may be non-zero; None for a dense layer."""
    masks = net.masks()
    if masks is None:
        return tuple(None for _ in net.linears())
    return tuple(tuple(np.flatnonzero(m.numpy().ravel(order="F")).tolist()) for m in masks)


def _net_architecture(net: MLP) -> NetArchitecture:
    return (
        net.activation,
        tuple((lin.out_features, lin.in_features) for lin in net.linears()),
        _weight_positions(net),
    )


def surrogate_architecture(model: SurrogateModel) -> Architecture:
    """What the parametric contact function depends on besides the parameter values."""
    return (
        model.ndof,
        len(model.input_norm.mean),
        _net_architecture(model.force_net),
        len(model.force_norm.mean),
        _net_architecture(model.moment_net),
        len(model.moment_norm.mean),
        model.ensemble_size,
        None if (gate := model.gate) is None else (gate.params.open_gap, gate.params.blend, gate.params.force_width),
    )


def _net_parameters(net: MLP, input_norm: Standardization) -> list[FloatArray]:
    """Layers as (weights column-major, biases); the input standardisation folded into the
    first layer: W (x - mean) / divisor + b = (W / divisor) x + (b - (W / divisor) mean)."""
    out = []
    for i, (lin, positions) in enumerate(zip(net.linears(), _weight_positions(net), strict=True)):
        W, b = lin.weight.detach().double().numpy(), lin.bias.detach().double().numpy()
        if i == 0:
            W = W / np.asarray(input_norm.divisor, float)[None, :]
            b = b - W @ np.asarray(input_norm.mean, float)
        weights = W.ravel(order="F")
        out += [weights if positions is None else weights[list(positions)], b.ravel()]
    return out


def surrogate_parameters(model: SurrogateModel) -> FloatArray:
    """The parameter vector ``p`` of :func:`surrogate_contact` for ``model``: per member, per
    network (force, then moment) its layers (weights column-major, then biases; the input
    standardisation folded into the first layer) and its output scale and mean."""
    parts: list[FloatArray] = []
    for m in model.members:
        for net, norm in ((m.force_net, m.force_norm), (m.moment_net, m.moment_norm)):
            parts += [*_net_parameters(net, m.input_norm), norm.scale, norm.mean]
    return np.concatenate([np.asarray(a, float).ravel() for a in parts])


class _Reader:
    """Consecutive slices of a symbolic parameter column."""

    def __init__(self, p: ca.SX):
        self.p, self.at = p, 0

    def take(self, rows: int, cols: int = 1) -> ca.SX:
        block = ca.reshape(self.p[self.at : self.at + rows * cols], rows, cols)
        self.at += rows * cols
        return block


def _mlp_parametric(arch: NetArchitecture, x: ca.SX, read: _Reader) -> ca.SX:
    activation, shapes, positions = arch
    for i, ((rows, cols), where) in enumerate(zip(shapes, positions, strict=True)):
        if where is None:
            W = read.take(rows, cols)
        else:  # only the weights within blocks: the products across blocks are not in the graph
            pattern = ca.Sparsity.triplet(rows, cols, [k % rows for k in where], [k // rows for k in where])
            W = ca.SX(pattern, read.take(len(where)))
        b = read.take(rows)
        x = ca.mtimes(W, x) + b
        if i < len(shapes) - 1:
            x = _activation(activation, x)
    return x


class _ThreadCache(threading.local):
    """SX graphs are not for concurrent use: one cache of parametric contacts per thread, as the OCP's."""

    def __init__(self) -> None:
        self.contacts: dict[tuple[Architecture, HeadNeckPreset, bool, Any], ca.Function] = {}


_LOCAL = _ThreadCache()


def _parametric_contact(
    architecture: Architecture, preset: HeadNeckPreset, std: bool = False, chain: PlanarChain | None = None
) -> ca.Function:
    cache = _LOCAL.contacts
    key = (architecture, preset, std, None if chain is None else dataclasses.astuple(chain))
    if key not in cache:
        if len(cache) >= 16:
            cache.pop(next(iter(cache)))
        cache[key] = _build_parametric_contact(architecture, preset, std, chain)
    return cache[key]


def _build_parametric_contact(
    architecture: Architecture, preset: HeadNeckPreset, std: bool, chain: PlanarChain | None = None
) -> ca.Function:
    ndof, n_inputs, force_arch, n_force, moment_arch, n_moment, n_members, gate = architecture
    if ndof != (1 if chain is None else chain.ndof):
        raise ValueError(
            f"kinematics: the model has {ndof} degrees of freedom, the "
            + ("1-DOF preset 1" if chain is None else f"chain {chain.ndof}")
        )
    n_member = 2 * (n_force + n_moment) + sum(
        (r * c if where is None else len(where)) + r
        for arch in (force_arch, moment_arch)
        for (r, c), where in zip(arch[1], arch[2], strict=True)
    )
    n_par = n_members * n_member
    q, qd, p = ca.SX.sym("q", ndof), ca.SX.sym("qd", ndof), ca.SX.sym("p", n_par)
    read = _Reader(p)
    # the features of the contact body's pose: the 1-DOF preset's geometry, or the chain's
    kin = (
        relative_kinematics_symbolic(preset, q[0], qd[0])
        if chain is None
        else chain.relative_kinematics_function(q, qd)
    )
    feats = features_symbolic(*kin)
    params = None if gate is None else GateParams(*gate)
    gap = None if gate is None else gap_from_features_symbolic(feats, preset.profile)
    # a model with history states takes them as the input z, after the 19 features
    z = ca.SX.sym("z", n_inputs - N_FEATURES)
    inputs, names = ([q, qd, z, p], ["q", "qd", "z", "p"]) if n_inputs > N_FEATURES else ([q, qd, p], ["q", "qd", "p"])
    feats = ca.vertcat(feats, z) if n_inputs > N_FEATURES else feats
    wrenches = []
    for _ in range(n_members):
        # structurally zero features (planar motion) drop out of the first layer
        force = _mlp_parametric(force_arch, feats, read)
        force = force * read.take(n_force) + read.take(n_force)
        moment = _mlp_parametric(moment_arch, feats, read)
        moment = moment * read.take(n_moment) + read.take(n_moment)
        wrenches.append(_gated(force, moment, gap, params))
    assert read.at == n_par
    mean, var = _mean_var(wrenches)
    if std:
        return ca.Function("contact_surrogate_std_p", inputs, [ca.sqrt(var), var], names, ["std", "var"])
    return ca.Function("contact_surrogate_p", inputs, [mean], names, ["wrench"])


def surrogate_history(
    model: SurrogateModel, preset: HeadNeckPreset, chain: PlanarChain | None = None
) -> ContactHistory | None:
    """The OCP's history states of a model of the ``history`` feature set (None for 'paper'):
    the step ``(z, q, qd, dt) -> z_next`` and the steady states ``(q, qd) -> z`` of
    :mod:`.history` at the state of the 1-DOF ``preset`` or of the ``chain``'s contact body."""
    if model.config.features != "history":
        return None
    ndof = 1 if chain is None else chain.ndof
    z, q, qd, dt = ca.SX.sym("z", N_HISTORY), ca.SX.sym("q", ndof), ca.SX.sym("qd", ndof), ca.SX.sym("dt")
    kin = (
        relative_kinematics_symbolic(preset, q[0], qd[0])
        if chain is None
        else chain.relative_kinematics_function(q, qd)
    )
    pen, slip = contact_point_motion_symbolic(preset, *kin)
    cfg = model.config.history
    step = ca.Function(
        "history_step",
        [z, q, qd, dt],
        [history_step_symbolic(z, pen, slip, dt, cfg)],
        ["z", "q", "qd", "dt"],
        ["z_next"],
    )
    # the steady states: the step from no indentation and the current slip velocity, with dt 0
    steady_z = history_step_symbolic(ca.vertcat(0, slip), pen, slip, 0.0, cfg)
    steady = ca.Function("history_steady", [q, qd], [steady_z], ["q", "qd"], ["z"])
    return ContactHistory(step, steady)


def surrogate_contact_std(
    model: SurrogateModel, preset: HeadNeckPreset, chain: PlanarChain | None = None
) -> tuple[ca.Function, FloatArray]:
    """``((q, qd, p) -> (std, var), p values)``: the ensemble's spread with the weights as
    parameters (the same ``p`` as :func:`surrogate_contact`)."""
    _check_parametric(model)
    return _parametric_contact(surrogate_architecture(model), preset, True, chain), surrogate_parameters(model)


def _check_parametric(model: SurrogateModel) -> None:
    n_inputs = len(model.config.input_names)
    for m in model.members:
        if (
            len(m.force_norm.mean) != m.force_net.linears()[-1].out_features
            or len(m.moment_norm.mean) != m.moment_net.linears()[-1].out_features
        ):
            raise ValueError("model: the output normalisation does not match the networks' outputs")
        if m.force_net.linears()[0].in_features != n_inputs or m.moment_net.linears()[0].in_features != n_inputs:
            raise ValueError(f"model: the networks must take the {n_inputs} inputs of {model.config.input_names}")


def surrogate_contact(
    model: SurrogateModel, preset: HeadNeckPreset, chain: PlanarChain | None = None
) -> tuple[ca.Function, FloatArray]:
    """``((q, qd, p) -> wrench, p values)``: the contact-model slot with the weights as parameters.

    ``chain``: the task's chain (its contact body's pose gives the features); None: the 1-DOF
    ``preset``. ``preset`` gives the head profile of the gated architecture.

    The function depends only on the architecture and the preset (one cached object per
    pair and thread), so ``solve_task(task, fn, contact_params=p)`` reuses one NLP for every model
    version of an architecture. Same values as :func:`casadi_contact_function`.
    """
    _check_parametric(model)
    return _parametric_contact(surrogate_architecture(model), preset, False, chain), surrogate_parameters(model)


__all__ = [
    "casadi_contact_function",
    "casadi_contact_std_function",
    "casadi_network_function",
    "chain_kinematics",
    "member_wrenches_symbolic",
    "mlp_symbolic",
    "surrogate_architecture",
    "surrogate_contact",
    "surrogate_contact_std",
    "surrogate_history",
    "surrogate_parameters",
    "wrench_symbolic",
    "wrench_var_symbolic",
]
