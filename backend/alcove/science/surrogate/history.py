"""History states of a contact surrogate with memory: causal recursions along a motion.

The paper's surrogate is a function of the state (q, qd) alone. The FE oracle's friction is not:
the tangential force depends on the path (sticking, the direction of slip), so two motions through
the same state give different fz. The ``history`` feature set adds states that remember the path,
each a causal recursion over the motion's samples,

    z_{k+1} = g(z_k, kin_{k+1}, t_{k+1} - t_k),   z_0 = g(z_init, kin_0, 0),

with a fixed initial value ``z_init`` and a step ``g`` that is C1 in its arguments, so IPOPT can
carry the states inside the optimal control problem. All are properties of the contact point
``r_sp`` of the head (the back point of its profile, the auxiliary law's point) in the headrest
frame H:

``max_indentation`` [m]
    the largest indentation p = -x_H(r_sp) so far, through a C1 ramp:
    ``z_{k+1} = z_k + ramp(p_{k+1} - z_k)`` with ``ramp(x) = 0`` for x <= 0, ``x^2 / (2 e)`` up to
    ``e``, ``x - e / 2`` beyond (``e = indentation_ramp``). It never decreases, does not drift
    while the head holds or retreats, and lags a deepening press by e / 2. ``z_init = 0``.
``slip_velocity_y``, ``slip_velocity_z`` [m/s]
    the velocity of the contact point along the headrest surface (H's y and z), low-pass filtered
    with time constant ``slip_time_constant`` by the implicit Euler step
    ``z_{k+1} = (z_k + a v_{k+1}) / (1 + a)``, ``a = dt / tau``: unconditionally stable on any grid
    and, as dt -> 0, the solution of ``tau z' = v - z``. ``z_init = v_0`` (the filter at rest
    with the first sample's velocity).

A prediction at independent states (not along a motion) takes the states of a motion arriving at
each state steadily (:func:`steady_history`): ``ramp(p)`` (the recursion's first sample) and the
slip velocity itself. The preliminary data are independent samples of the auxiliary law, which has
no memory: its wrench is the same whatever the path, so each of its samples is given a history
drawn at random (:func:`memoryless_history`: a deepest indentation between the sample's and the
deepest of its data set, a filtered slip velocity within the data set's range of slip velocities,
seeded by the data set). Given only steady histories, the networks would tie the history inputs
to the state (they are functions of it there) and read an unloading head, whose deepest
indentation exceeds its indentation, as a deeper press.

The same step serves every user: training (the pool's motions), prediction along a trajectory,
the validation suite, the trust diagnostics, and the OCP (:func:`history_step_symbolic`, the
discrete states' equality constraints). The low-pass time constant and the ramp width are part
of the surrogate's configuration (:class:`HistoryConfig`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Annotated

import numpy as np
from pydantic import BaseModel, ConfigDict

from alcove.science.arrays import FloatArray
from alcove.science.errors import FieldError
from alcove.science.geometry import HeadNeckPreset, RelativeKinematics
from alcove.science.spec_checks import quantity
from alcove.science.surrogate.features import features

if TYPE_CHECKING:
    import casadi as ca

    from alcove.science.symbolic import Symbolic

HISTORY_NAMES: tuple[str, ...] = ("max_indentation", "slip_velocity_y", "slip_velocity_z")
N_HISTORY = len(HISTORY_NAMES)


class HistoryError(FieldError):
    """History states cannot be computed for these samples; ``field`` names what is wrong."""


class HistoryConfig(BaseModel):
    """Parameters of the history states (the ``history`` feature set)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    slip_time_constant: Annotated[
        float,
        quantity(
            "time constant of the low-pass filter of the contact point's tangential velocity",
            "s",
            gt=1e-4,
            le=10.0,
            why="50 ms: the friction's memory of the slip direction over a press",
        ),
    ] = 0.05
    indentation_ramp: Annotated[
        float,
        quantity(
            "width of the C1 ramp of the largest indentation (it lags a deepening press by half of it)",
            "m",
            gt=1e-7,
            le=0.01,
            why="0.1 mm, small against indentations of millimetres",
        ),
    ] = 1e-4


def contact_point_motion(preset: HeadNeckPreset, kin: RelativeKinematics) -> tuple[FloatArray, FloatArray]:
    """Indentation p (n,) of the contact point r_sp into the headrest plane [m] and its velocity
    along the surface, (n, 2): H's y and z [m/s]."""
    bx, bz = preset.profile.back_point()
    arm = np.einsum("nij,j->ni", kin.T_rel, np.array([bx, 0.0, bz]))
    point = kin.r_rel + arm
    velocity = kin.v_rel + np.cross(kin.omega_rel, arm)
    return -point[:, 0], velocity[:, 1:3]


def ramp(x: FloatArray, width: float) -> FloatArray:
    """C1 max(x, 0) - (width / 2) for x >= width: 0 below 0, x^2 / (2 width) up to width."""
    return np.where(x <= 0.0, 0.0, np.where(x < width, x * x / (2.0 * width), x - width / 2.0))


def history_step(
    z: FloatArray, p_next: FloatArray, v_next: FloatArray, dt: FloatArray, config: HistoryConfig
) -> FloatArray:
    """One step of the recursion for m motions at once: z (m, 3) -> z_next (m, 3) from the next
    sample's indentation p_next (m,), tangential velocity v_next (m, 2) and the step dt (m,)."""
    a = (np.asarray(dt, float) / config.slip_time_constant)[:, None]
    deepest = z[:, 0] + ramp(p_next - z[:, 0], config.indentation_ramp)
    return np.column_stack([deepest, (z[:, 1:] + a * v_next) / (1.0 + a)])


def history_states(preset: HeadNeckPreset, kin: RelativeKinematics, t: FloatArray, config: HistoryConfig) -> FloatArray:
    """The history states (n, 3) along one motion sampled at times t (n,), strictly increasing."""
    t = np.asarray(t, float)
    if t.ndim != 1 or t.shape[0] != kin.r_rel.shape[0]:
        raise HistoryError("t", f"has shape {t.shape}, expected ({kin.r_rel.shape[0]},): one time per sample")
    if t.shape[0] > 1 and not np.all(np.diff(t) > 0):
        raise HistoryError("t", "must increase strictly: history states follow the motion sample by sample")
    p, v = contact_point_motion(preset, kin)
    z = np.empty((t.shape[0], N_HISTORY))
    z[0] = [ramp(p[:1], config.indentation_ramp)[0], *v[0]]
    for k in range(1, t.shape[0]):
        z[k] = history_step(z[k - 1 : k], p[k : k + 1], v[k : k + 1], t[k : k + 1] - t[k - 1 : k], config)[0]
    return z


def steady_history(preset: HeadNeckPreset, kin: RelativeKinematics, config: HistoryConfig) -> FloatArray:
    """History states (n, 3) of independent samples: those of a motion arriving at each state
    steadily (the recursion's value at its first sample)."""
    p, v = contact_point_motion(preset, kin)
    return np.column_stack([ramp(p, config.indentation_ramp), v])


def memoryless_history(preset: HeadNeckPreset, kin: RelativeKinematics, config: HistoryConfig, seed: int) -> FloatArray:
    """History states (n, 3) drawn at random for samples of a law without memory (module
    docstring): the deepest indentation uniform between ``ramp(p)`` and the largest ``ramp(p)`` of
    the samples, each filtered slip velocity uniform within +- the largest |slip velocity|."""
    steady = steady_history(preset, kin, config)
    rng = np.random.default_rng(seed)
    n = steady.shape[0]
    deepest = steady[:, 0] + rng.uniform(0.0, 1.0, n) * (steady[:, 0].max() - steady[:, 0])
    bound = np.abs(steady[:, 1:]).max(axis=0)
    slip = rng.uniform(-1.0, 1.0, (n, 2)) * bound
    return np.column_stack([deepest, slip])


@dataclass(frozen=True)
class HistoryInputs:
    """The networks' inputs of the ``history`` feature set: the paper's 19 features of each
    sample, then its history states (n, 22)."""

    preset: HeadNeckPreset
    config: HistoryConfig

    def __call__(
        self, kin: RelativeKinematics, t: FloatArray | None, *, steady: bool = False, memoryless: int | None = None
    ) -> FloatArray:
        """Along one motion at times ``t``; or (``steady``) at independent states; or, given
        ``memoryless`` (a seed), at samples of a law without memory (:func:`memoryless_history`)."""
        if memoryless is not None:
            z = memoryless_history(self.preset, kin, self.config, memoryless)
        elif steady:
            z = steady_history(self.preset, kin, self.config)
        elif t is None:
            raise HistoryError("t", "history states follow a motion: give its times")
        else:
            z = history_states(self.preset, kin, t, self.config)
        return np.hstack([features(kin), z])


def history_inputs(feature_set: str, config: HistoryConfig, preset: HeadNeckPreset) -> HistoryInputs | None:
    """The inputs with history states for ``feature_set`` 'history'; None for the paper's features."""
    return HistoryInputs(preset, config) if feature_set == "history" else None


def history_step_symbolic(
    z: Symbolic, p_next: Symbolic, v_next: Symbolic, dt: float | Symbolic, config: HistoryConfig
) -> Symbolic:
    """:func:`history_step` for one motion in CasADi: z (3 x 1) -> z_next (3 x 1), p_next scalar,
    v_next (2 x 1)."""
    import casadi as ca

    w = config.indentation_ramp
    x = p_next - z[0]
    ramped = ca.if_else(x <= 0, 0, ca.if_else(x < w, x * x / (2 * w), x - w / 2))
    a = dt / config.slip_time_constant
    return ca.vertcat(z[0] + ramped, (z[1:3] + a * v_next) / (1 + a))


def contact_point_motion_symbolic(
    preset: HeadNeckPreset, r_rel: Symbolic, v_rel: Symbolic, T_rel: Symbolic, omega_rel: Symbolic
) -> tuple[Symbolic, Symbolic]:
    """:func:`contact_point_motion` in CasADi for one sample: p (scalar) and v (2 x 1)."""
    import casadi as ca

    bx, bz = preset.profile.back_point()
    arm = T_rel @ ca.DM([bx, 0.0, bz])
    point = r_rel + arm
    velocity = v_rel + ca.cross(omega_rel, arm)
    return -point[0], velocity[1:3]


@dataclass(frozen=True)
class ContactHistory:
    """The history states as an optimal control problem takes them (built by
    :func:`alcove.science.surrogate.casadi_contact.surrogate_history`): ``step`` ``(z, q, qd, dt) ->
    z_next`` (the states at the next sample, from the state there and the time since the last
    sample) and ``steady`` ``(q, qd) -> z`` (the states of the first sample). The transcription
    (:mod:`alcove.science.ocp.dmocc`) carries the states as discrete unknowns with this recursion."""

    step: ca.Function
    steady: ca.Function

    @property
    def size(self) -> int:
        return int(self.steady.size1_out(0))


__all__ = [
    "HISTORY_NAMES",
    "N_HISTORY",
    "ContactHistory",
    "HistoryConfig",
    "HistoryError",
    "HistoryInputs",
    "contact_point_motion",
    "contact_point_motion_symbolic",
    "history_inputs",
    "history_states",
    "history_step",
    "history_step_symbolic",
    "memoryless_history",
    "ramp",
    "steady_history",
]
