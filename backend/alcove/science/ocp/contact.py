"""Contact models for the OCP: the contact-model slot and its implementations.

The slot is a ``casadi.Function`` with inputs ``q`` (ndof x 1) and ``qd`` (ndof x 1) and one
output, the wrench (6 x 1) ``[fx, fy, fz, mx, my, mz]``: the contact force on the contact
body (the head) and its moment about the body frame origin (the head COG), both in the
headrest frame H. The OCP maps it to generalized forces with ``J(q)^T``
(:class:`alcove.science.multibody.PlanarChain`). An optional third input ``p`` (a column of
parameters, e.g. network weights) is passed through as an NLP parameter so a solver can be
reused when only the parameter values change.

Models:

* ``none``: no contact.
* ``aux``: a smooth form of the paper's auxiliary penalty model (one point r_sp of the head
  against the headrest plane). The literal model switches with ``if p > 0 and f > 0``,
  which IPOPT handles badly; here the penetration goes through a softplus of width
  ``penetration_width`` and the force through a smooth ramp of width ``force_width``. Both
  widths -> 0 recover the literal model (tested against
  :func:`alcove.science.oracles.aux_penalty.aux_penalty_wrench`).
* ``model:FILE``: a trained surrogate, built by
  ``alcove.science.surrogate.artifact.casadi_contact_from_artifact(path, preset)``.

A contact model with memory (a surrogate of the ``history`` feature set) takes the history
states ``z`` as an input named ``z`` after ``qd`` (``(q, qd, z[, p])``) and comes with a
:class:`ContactHistory`: the causal step of those states and their steady values, which the
transcription carries as extra discrete states (:mod:`.dmocc`).
"""

from __future__ import annotations

from pathlib import Path

import casadi as ca
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from alcove.science.arrays import FloatArray
from alcove.science.errors import FieldError
from alcove.science.geometry import HeadNeckPreset
from alcove.science.multibody import PlanarChain
from alcove.science.oracles.aux_penalty import AuxPenaltyParams, contact_point
from alcove.science.surrogate.history import ContactHistory
from alcove.science.symbolic import Symbolic

WRENCH_SIZE = 6


class ContactModelError(FieldError):
    """A contact model is malformed or cannot be built; ``field`` names what is wrong."""


class AuxSmoothing(BaseModel):
    """Smoothing widths of the OCP form of the auxiliary penalty model."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    penetration_width: float = Field(2e-4, gt=0, le=0.01, description="softplus width of the penetration [m]")
    force_width: float = Field(0.5, gt=0, le=100, description="width of the smooth ramp max(f, 0) [N]")


def softplus(x: Symbolic, width: float = 1.0) -> Symbolic:
    """Smooth max(x, 0) = width * log(1 + exp(x / width)), stable for large |x|."""
    z = x / width
    return width * (ca.log1p(ca.exp(-ca.fabs(z))) + ca.fmax(z, 0))


def smooth_ramp(x: Symbolic, width: float = 1.0) -> Symbolic:
    """Smooth max(x, 0) that is exactly 0 at x = 0 and tends to 0 for x -> -inf: x * sigmoid(x / width)."""
    return x * 0.5 * (1 + ca.tanh(0.5 * x / width))


def no_contact(ndof: int) -> ca.Function:
    """The ``none`` model: zero wrench."""
    q, qd = ca.SX.sym("q", ndof), ca.SX.sym("qd", ndof)
    return ca.Function("contact_none", [q, qd], [ca.SX.zeros(WRENCH_SIZE)], ["q", "qd"], ["wrench"])


def aux_contact(
    preset: HeadNeckPreset,
    params: AuxPenaltyParams | None = None,
    smoothing: AuxSmoothing | None = None,
    chain: PlanarChain | None = None,
) -> ca.Function:
    """The smooth auxiliary penalty model as a contact-model slot function.

    ``chain`` defaults to the 1-DOF chain of ``preset``; the point r_sp (default: the back
    point of ``preset``'s profile) is given in the frame of the chain's contact body (the head frame).
    """
    params = params or AuxPenaltyParams()
    return _aux(chain or PlanarChain.from_preset(preset), contact_point(preset, params), params, smoothing)


def chain_aux_contact(
    chain: PlanarChain, params: AuxPenaltyParams | None = None, smoothing: AuxSmoothing | None = None
) -> ca.Function:
    """The smooth auxiliary penalty model for any chain, fed by its contact body's pose; r_sp
    defaults to the back point of the chain's head profile."""
    params = params or AuxPenaltyParams()
    r_sp = np.asarray(params.r_sp, float) if params.r_sp is not None else chain.profile.back_point()
    if r_sp.size == 2:
        r_sp = np.array([r_sp[0], 0.0, r_sp[1]])
    return _aux(chain, r_sp, params, smoothing)


def _aux(chain: PlanarChain, r_sp: FloatArray, params: AuxPenaltyParams, smoothing: AuxSmoothing | None) -> ca.Function:
    smoothing = smoothing or AuxSmoothing()
    q, qd = ca.SX.sym("q", chain.ndof), ca.SX.sym("qd", chain.ndof)
    r_rel, v_rel, T_rel, omega_rel = chain.relative_kinematics_function(q, qd)
    arm = ca.mtimes(T_rel, ca.DM(r_sp))  # r_sp in H
    point = r_rel + arm
    point_vel = v_rel + ca.cross(omega_rel, arm)
    p = softplus(-point[0], smoothing.penetration_width)  # penetration along -x_H
    pdot = -point_vel[0]
    f = params.k * p**2 + pdot * params.d0 * (1 - ca.exp(-p / params.p_ref))
    force = ca.vertcat(smooth_ramp(f, smoothing.force_width), 0, 0)
    moment = ca.cross(arm, force)
    return ca.Function("contact_aux", [q, qd], [ca.vertcat(force, moment)], ["q", "qd"], ["wrench"])


def history_input_size(fn: ca.Function | None) -> int:
    """Rows of a contact function's history-state input ``z`` (0: it has none)."""
    return int(fn.size1_in(fn.index_in("z"))) if fn is not None and "z" in fn.name_in() else 0


def check_contact_function(fn: ca.Function, ndof: int) -> None:
    """Raise :class:`ContactModelError` unless ``fn`` fits the contact-model slot."""
    if not isinstance(fn, ca.Function):
        raise ContactModelError("contact", f"expected a casadi.Function, got {type(fn).__name__}")
    n_history = 1 if "z" in fn.name_in() else 0
    if fn.n_in() - n_history not in (2, 3) or fn.n_out() != 1 or (n_history and fn.name_in(2) != "z"):
        raise ContactModelError(
            "contact",
            f"expected inputs (q, qd[, z][, p]) and one output, got {fn.n_in()} inputs and {fn.n_out()} outputs",
        )
    for i, name in enumerate(("q", "qd")):
        if fn.size_in(i) != (ndof, 1):
            raise ContactModelError(
                f"contact.{name}", f"input {i} must be {ndof}x1, got {fn.size_in(i)[0]}x{fn.size_in(i)[1]}"
            )
    if fn.n_in() == 3 + n_history and fn.size2_in(fn.n_in() - 1) != 1:
        raise ContactModelError("contact.p", "the parameter input must be a column")
    if fn.size_out(0) != (WRENCH_SIZE, 1):
        raise ContactModelError("contact.wrench", f"output must be 6x1, got {fn.size_out(0)[0]}x{fn.size_out(0)[1]}")


def contact_from_spec(spec: str, preset: HeadNeckPreset | PlanarChain) -> ca.Function | None:
    """Parse ``aux``, ``none`` or ``model:FILE`` into a contact function (``None`` for none).

    ``preset``: the 1-DOF preset, or the task's chain (a surrogate then reads its contact body's pose)."""
    if spec == "none":
        return None
    if spec == "aux":
        return chain_aux_contact(preset) if isinstance(preset, PlanarChain) else aux_contact(preset)
    if spec.startswith("model:"):
        path = Path(spec.removeprefix("model:"))
        if not path.exists():
            raise ContactModelError("contact", f"model file {str(path)!r} does not exist")
        if isinstance(preset, PlanarChain):  # the features of the chain's contact body's pose
            from alcove.science.surrogate.artifact import load_artifact
            from alcove.science.surrogate.casadi_contact import casadi_contact_function, chain_kinematics

            model = load_artifact(path)
            if model.ndof != preset.ndof:
                raise ContactModelError(
                    "contact", f"the model was trained on {model.ndof} joint(s), the task's chain has {preset.ndof}"
                )
            return casadi_contact_function(model, model.preset, chain_kinematics(preset))
        from alcove.science.surrogate.artifact import casadi_contact_from_artifact  # lazy: torch

        return casadi_contact_from_artifact(path, preset)
    raise ContactModelError("contact", f"unknown contact model {spec!r}; use aux, none or model:FILE")


def contact_history_from_spec(spec: str, preset: HeadNeckPreset | PlanarChain) -> ContactHistory | None:
    """The history states of ``model:FILE`` when the model has memory (feature set 'history'),
    for :func:`contact_from_spec`'s function; None for every other contact model."""
    if not spec.startswith("model:"):
        return None
    from alcove.science.surrogate.artifact import load_artifact
    from alcove.science.surrogate.casadi_contact import surrogate_history

    model = load_artifact(Path(spec.removeprefix("model:")))
    if isinstance(preset, PlanarChain):
        return surrogate_history(model, model.preset, preset)
    return surrogate_history(model, preset)


__all__ = [
    "AuxSmoothing",
    "ContactHistory",
    "ContactModelError",
    "aux_contact",
    "chain_aux_contact",
    "check_contact_function",
    "contact_from_spec",
    "contact_history_from_spec",
    "history_input_size",
    "no_contact",
    "smooth_ramp",
    "softplus",
]
