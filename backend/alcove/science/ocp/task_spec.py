"""The user's OCP task definition (pydantic), its validation and the task presets.

A task names a model (the 1-DOF head-neck preset with editable parameters, an n-DOF preset
or a user-defined planar chain, :mod:`.chain_model`), the initial state, one or more
phases (duration, intervals, cost weights w_tau / w_T, optional bounds and target pose at
the phase end), the final condition and an optional endpoint cost. Angles in rad, torques
in N m, durations in s. Lists have one entry per joint (the 1-DOF preset has one).

Errors name the field with its path, e.g. ``phases.1.duration: ...``; use
:func:`parse_task` to get a :class:`TaskSpecError` with ``field`` and ``reason``.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    SerializationInfo,
    SerializerFunctionWrapHandler,
    ValidationError,
    model_serializer,
    model_validator,
)

from alcove.science.arrays import FloatArray
from alcove.science.errors import FieldError
from alcove.science.geometry import (
    ANGLE_LIMIT,
    MAX_ANGULAR_VELOCITY,
    HeadNeckPreset,
    PoseFunction,
    preset_pose_function,
)
from alcove.science.ocp.chain_model import CHAIN_PRESETS, ChainSpec, chain_preset
from alcove.science.ocp.problem import DiscreteProblem, PhaseGrid
from alcove.science.ocp.scenario_ranges import ParameterRange, check_ranges
from alcove.science.spec_checks import WholeNumber, error_location, quantity

if TYPE_CHECKING:  # CasADi is imported only when a chain is built,
    # so validating a task (e.g. in the API process) stays light.
    from alcove.science.multibody import PlanarChain

_DEFAULT = HeadNeckPreset()

MAX_TORQUE = 200.0  # N m: an adult neck's largest extension torque is about 30-60 N m
MAX_WEIGHT = 1e6  # cost weights: the paper's are 1e-4 to 1
MAX_HEADREST_OFFSET = 0.02  # m: the largest headrest offset a scenario range may reach (the presets use +-5 mm)

Angle = Annotated[
    float, quantity("joint angle", "rad", ge=-ANGLE_LIMIT, le=ANGLE_LIMIT, why="within the model's joint range")
]
AngularVelocity = Annotated[
    float, quantity("joint angular velocity", "rad/s", ge=-MAX_ANGULAR_VELOCITY, le=MAX_ANGULAR_VELOCITY)
]
TorqueBound = Annotated[
    float, quantity("joint torque bound", "N m", gt=0, le=MAX_TORQUE, why="at most the model's torque_limit")
]


class TaskSpecError(FieldError):
    """Invalid task definition; ``field`` is the dotted path of the offending field."""


class _Strict(BaseModel):
    # inf / NaN pass bounds like gt=0 (an infinite duration, a NaN headrest tilt): reject them
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


def _fail(field: str, reason: str) -> None:
    raise ValueError(f"{field}: {reason}")


ONE_DOF: Literal["head-neck-1dof"] = "head-neck-1dof"
#: the 1-DOF preset's own parameters (the other models are described by ``chain``)
ONE_DOF_FIELDS = (
    "mass",
    "com_distance",
    "inertia_joint",
    "theta_min",
    "theta_max",
    "theta0",
    "torque_limit",
    "gravity",
    "theta_contact",
    "tilt",
)


class ModelSpec(_Strict):
    """The model: the paper's 1-DOF head-neck preset with its parameters (the default), an
    n-DOF preset (``head-neck-2dof``, ``trunk-neck-head-3dof``) or a user-defined planar chain
    (``preset: "chain"``). The last three are described by ``chain``; an n-DOF preset fills in
    every part of ``chain`` that is not given (top-level keys: give ``links`` and you give all links)."""

    preset: Literal["head-neck-1dof", "head-neck-2dof", "trunk-neck-head-3dof", "chain"] = Field(
        ONE_DOF,
        description="head-neck-1dof (the paper's model; its parameters are the fields below), head-neck-2dof, "
        "trunk-neck-head-3dof or chain (a user-defined chain: give model.chain)",
    )
    chain: ChainSpec | None = Field(
        None, description="the planar chain of an n-DOF preset or of a user-defined model; null for head-neck-1dof"
    )
    mass: Annotated[
        float, quantity("head mass", "kg", gt=0, le=20, why="an adult head weighs about 4-5 kg (de Leva 1996)")
    ] = _DEFAULT.mass
    com_distance: Annotated[float, quantity("distance from the joint (C7/T1) to the head COG", "m", gt=0, le=0.5)] = (
        _DEFAULT.com_distance
    )
    inertia_joint: Annotated[
        float,
        quantity(
            "moment of inertia about the joint",
            "kg m^2",
            gt=0,
            le=5,
            why="at least mass * com_distance^2 (the inertia about the COG is not negative)",
        ),
    ] = _DEFAULT.inertia_joint
    theta_min: Annotated[
        float, quantity("lower joint limit (backward tilt from the vertical)", "rad", ge=-ANGLE_LIMIT, le=ANGLE_LIMIT)
    ] = _DEFAULT.theta_min
    theta_max: Annotated[
        float, quantity("upper joint limit", "rad", ge=-ANGLE_LIMIT, le=ANGLE_LIMIT, why="above theta_min")
    ] = _DEFAULT.theta_max
    theta0: Annotated[
        float, quantity("initial angle", "rad", ge=-ANGLE_LIMIT, le=ANGLE_LIMIT, why="within theta_min..theta_max")
    ] = _DEFAULT.theta0
    torque_limit: Annotated[
        float,
        quantity("joint torque limit", "N m", gt=0, le=MAX_TORQUE, why="an adult neck's largest is about 30-60 N m"),
    ] = _DEFAULT.torque_limit
    gravity: Annotated[
        float,
        quantity("gravitational acceleration", "m/s^2", ge=0, le=100, why="0 is weightless, 100 is about 10 g"),
    ] = _DEFAULT.gravity
    theta_contact: Annotated[
        float,
        quantity("angle of first contact with the undeformed headrest", "rad", ge=-ANGLE_LIMIT, le=ANGLE_LIMIT),
    ] = _DEFAULT.theta_contact
    tilt: Annotated[float, quantity("headrest inclination (backward)", "rad", ge=-ANGLE_LIMIT, le=ANGLE_LIMIT)] = (
        _DEFAULT.tilt
    )
    headrest_offset: Annotated[
        float,
        quantity(
            "headrest moved along its normal from its theta_contact placement (positive: toward the head)",
            "m",
            ge=-MAX_HEADREST_OFFSET,
            le=MAX_HEADREST_OFFSET,
            why="a headrest adjustment; the oracles' cushion covers the contact zone over this range",
        ),
    ] = _DEFAULT.headrest_offset

    @model_validator(mode="before")
    @classmethod
    def _fill_preset_chain(cls, data: Any) -> Any:
        # only a string names a preset (a list or an object is left to pydantic to report, unhashed)
        if isinstance(data, dict) and isinstance(data.get("preset"), str) and data["preset"] in CHAIN_PRESETS:
            given = data.get("chain")
            chain = chain_preset(data["preset"])
            if isinstance(given, dict):
                chain.update(given)
            elif given is not None:
                return data  # let pydantic report the wrong type
            data = {**data, "chain": chain}
        return data

    @model_serializer(mode="wrap")
    def _dump(self, handler: SerializerFunctionWrapHandler, info: SerializationInfo) -> dict[str, Any]:
        # a 1-DOF model dumps as before chains and scenarios existed (stored task versions keep
        # their content; headrest_offset only when it is not 0); a chain model without the
        # unused 1-DOF fields
        data: dict[str, Any] = handler(self)
        if data.get("headrest_offset") == 0.0:
            data.pop("headrest_offset")
        if self.preset == ONE_DOF:
            data.pop("chain", None)
        else:
            for name in ONE_DOF_FIELDS:
                data.pop(name, None)
        return data

    @model_validator(mode="after")
    def _consistent(self) -> ModelSpec:
        if self.preset != ONE_DOF:
            if self.chain is None:
                _fail("model.chain", f"is required with preset {self.preset!r}")
            if self.headrest_offset != 0.0:
                _fail(
                    "model.headrest_offset",
                    f"moves the head-neck-1dof preset's headrest; with preset {self.preset!r} place the headrest "
                    "in model.chain.headrest",
                )
            for name in ONE_DOF_FIELDS:  # a form may send the defaults along: only a changed value is an error
                if name in self.model_fields_set and getattr(self, name) != type(self).model_fields[name].default:
                    _fail(
                        f"model.{name}",
                        f"belongs to the head-neck-1dof preset; with preset {self.preset!r} edit model.chain instead",
                    )
            return self
        if self.chain is not None:
            _fail("model.chain", "must be null with the head-neck-1dof preset (its parameters are the model's fields)")
        if not self.theta_min < self.theta_max:
            _fail("model.theta_max", f"must exceed theta_min ({self.theta_max:g} <= {self.theta_min:g} rad)")
        if not self.theta_min <= self.theta0 <= self.theta_max:
            _fail(
                "model.theta0",
                f"{self.theta0:g} rad lies outside the joint range [{self.theta_min:g}, {self.theta_max:g}] rad",
            )
        if self.inertia_joint < self.mass * self.com_distance**2:
            _fail(
                "model.inertia_joint",
                f"must be at least mass * com_distance^2 = {self.mass * self.com_distance**2:g} kg m^2 "
                "(the inertia about the COG would be negative)",
            )
        return self

    @property
    def ndof(self) -> int:
        return 1 if self.chain is None else self.chain.ndof

    @property
    def is_chain(self) -> bool:
        """True for every model but the 1-DOF preset."""
        return self.chain is not None

    @property
    def joint_min(self) -> FloatArray:
        """Lower joint limits [rad], one per joint."""
        return np.array([self.theta_min]) if self.chain is None else self.chain.q_min

    @property
    def joint_max(self) -> FloatArray:
        return np.array([self.theta_max]) if self.chain is None else self.chain.q_max

    @property
    def torque_limits(self) -> FloatArray:
        return np.array([self.torque_limit]) if self.chain is None else self.chain.torque_limits

    @property
    def q_initial(self) -> FloatArray:
        """The model's initial pose [rad] (theta0, or the chain's joint q0)."""
        return np.array([self.theta0]) if self.chain is None else self.chain.q0

    def to_preset(self) -> HeadNeckPreset:
        if self.chain is not None:
            raise TaskSpecError(
                "model.preset",
                f"{self.preset!r} is a chain model; this step takes only the head-neck-1dof preset so far",
            )
        data = self.model_dump(exclude={"preset", "chain"})
        return HeadNeckPreset(**data)

    def to_chain(self) -> PlanarChain:
        """The model as a planar chain (CasADi)."""
        from alcove.science.multibody import PlanarChain

        if self.chain is not None:
            return self.chain.to_chain()
        return PlanarChain.from_preset(self.to_preset())

    def pose_function(self) -> PoseFunction:
        """``(q, qd) -> pose (n, 6)``: the contact body's pose and twist relative to the headrest
        (:data:`alcove.science.geometry.POSE_COLUMNS`) at joint states of this model. The 1-DOF
        preset's is the NumPy geometry (:func:`alcove.science.geometry.preset_pose`, headrest
        offset included); a chain's is its CasADi kinematics (``PlanarChain.head_pose``)."""
        if self.chain is None:
            return preset_pose_function(self.to_preset())
        return self.chain.to_chain().head_pose

    def oracle_preset(self) -> HeadNeckPreset:
        """What an oracle reads of the model besides a trajectory's pose: the head profile and
        the headrest tilt. The 1-DOF preset itself (a 1-joint trajectory without a pose is its);
        for a chain a preset carrying the chain's profile and headrest tilt (its joint fields
        are never read: the chain's trajectories carry their pose)."""
        if self.chain is None:
            return self.to_preset()
        tilt = self.chain.headrest.tilt
        return HeadNeckPreset(tilt=tilt, theta_contact=tilt, profile=self.chain.contact_body.profile.to_profile())


class InitialState(_Strict):
    """Initial state; ``q`` defaults to the model's theta0 and ``qd`` to rest."""

    q: list[Angle] | None = Field(
        None,
        description="initial pose [rad], one per joint, within the first phase's joint range; null = model.theta0",
    )
    qd: list[AngularVelocity] | None = Field(
        None,
        description=f"initial velocity [rad/s], one per joint, -{MAX_ANGULAR_VELOCITY:g} to {MAX_ANGULAR_VELOCITY:g}; "
        "null = at rest",
    )
    velocity: Literal["given", "free"] = Field(
        "given", description="'free' leaves the initial velocity to the optimizer"
    )


class FinalCondition(_Strict):
    """Final condition: at rest or free velocity; optional target pose."""

    velocity: Literal["rest", "free"] = "rest"
    q: list[Angle] | None = Field(
        None, description="target pose at the end [rad], one per joint, within the last phase's bounds; null = free"
    )


class PhaseSpec(_Strict):
    name: str = ""
    duration: Annotated[float, quantity("phase duration", "s", gt=0, le=60, why="a head motion lasts seconds")]
    intervals: WholeNumber = Field(
        100, ge=1, le=20000, description="DMOCC intervals in this phase [-], a whole number from 1 to 20000"
    )
    w_tau: Annotated[
        float,
        quantity("weight of tau^T tau in the running cost", "1/(N^2 m^2 s)", ge=0, le=MAX_WEIGHT, why="paper: 1e-3, 1"),
    ]
    w_T: Annotated[
        float,
        quantity(
            "weight of the kinetic energy in the running cost", "1/(J s)", ge=0, le=MAX_WEIGHT, why="paper: 1e-4, 1"
        ),
    ]
    q_min: list[Angle] | None = Field(
        None,
        description="joint lower bounds in this phase [rad], one per joint, within the model's joint range "
        "(default: model.theta_min)",
    )
    q_max: list[Angle] | None = Field(
        None,
        description="joint upper bounds in this phase [rad], one per joint, within the model's joint range "
        "(default: model.theta_max)",
    )
    tau_max: list[TorqueBound] | None = Field(
        None,
        description="torque bounds |tau| <= tau_max in this phase [N m], one per joint, above 0 and at most the "
        "model's torque_limit (default: the limit)",
    )
    target_q: list[Angle] | None = Field(
        None, description="pose to reach at the end of the phase [rad], one per joint, within the phase bounds"
    )


class EndpointCost(_Strict):
    """E = w_q |q(t_F) - q_ref|^2 + w_qd |qd(t_F)|^2."""

    w_q: Annotated[float, quantity("weight of the final pose error", "1/rad^2", ge=0, le=MAX_WEIGHT)] = 0.0
    q_ref: list[Angle] | None = Field(
        None, description="reference final pose [rad], one per joint, within the model's joint range"
    )
    w_qd: Annotated[float, quantity("weight of the final velocity", "s^2/rad^2", ge=0, le=MAX_WEIGHT)] = 0.0


class TaskSpec(_Strict):
    """A multi-phase OCP task."""

    name: str = "custom"
    description: str = ""
    model: ModelSpec = Field(default_factory=ModelSpec)
    initial: InitialState = Field(default_factory=InitialState)
    phases: list[PhaseSpec] = Field(min_length=1)
    final: FinalCondition = Field(default_factory=FinalCondition)
    endpoint_cost: EndpointCost | None = None
    ranges: list[ParameterRange] | None = Field(
        None,
        description="scenario ranges: ranges of some parameters and how their values are drawn (uniform, "
        "truncated normal or triangular; alcove.science.ocp.scenarios); null or empty: the task has one "
        "scenario, itself",
    )
    exploration_weight: Annotated[
        float,
        quantity(
            "weight of the exploration term: with a surrogate ensemble, the cost rewards the members' "
            "disagreement along the motion, minus w times the integral of their force variance "
            "sigma_F^2 over the interval midpoints (docs/active-learning.md); with the aux contact or one "
            "model it is 0",
            "1/(N^2 s)",
            ge=0,
            le=MAX_WEIGHT,
            why="0: the paper's loop",
        ),
    ] = 0.0

    @model_validator(mode="after")
    def _consistent(self) -> TaskSpec:
        n = self.model.ndof
        joint_lo, joint_hi = self.model.joint_min, self.model.joint_max
        torque_limit = self.model.torque_limits

        def vec(value: Sequence[float] | None, path: str, default: FloatArray) -> FloatArray:
            if value is None:
                return default
            if len(value) != n:
                _fail(path, f"expected {n} value(s) (one per joint), got {len(value)}")
            return np.asarray(value, float)

        def within(values: FloatArray, lo: FloatArray, hi: FloatArray, path: str, what: str) -> None:
            for j, (v, a, b) in enumerate(zip(values, lo, hi, strict=True)):
                if not a <= v <= b:
                    _fail(f"{path}.{j}", f"{v:g} rad lies outside {what} [{a:g}, {b:g}] rad")

        model_range = "the model's joint range"
        bounds = []
        for m, ph in enumerate(self.phases):
            lo = vec(ph.q_min, f"phases.{m}.q_min", joint_lo)
            hi = vec(ph.q_max, f"phases.{m}.q_max", joint_hi)
            within(lo, joint_lo, joint_hi, f"phases.{m}.q_min", model_range)
            within(hi, joint_lo, joint_hi, f"phases.{m}.q_max", model_range)
            for j in np.flatnonzero(lo >= hi):
                _fail(f"phases.{m}.q_min.{j}", f"must be below q_max ({lo[j]:g} >= {hi[j]:g} rad)")
            tmax = vec(ph.tau_max, f"phases.{m}.tau_max", torque_limit)
            for j in np.flatnonzero(tmax > torque_limit):
                _fail(
                    f"phases.{m}.tau_max.{j}",
                    f"{tmax[j]:g} N m exceeds the model's torque_limit {torque_limit[j]:g} N m",
                )
            if ph.target_q is not None:
                target = vec(ph.target_q, f"phases.{m}.target_q", lo)
                within(target, lo, hi, f"phases.{m}.target_q", "the phase bounds")
                if m + 1 < len(self.phases):
                    nxt = self.phases[m + 1]
                    within(
                        target,
                        vec(nxt.q_min, f"phases.{m + 1}.q_min", joint_lo),
                        vec(nxt.q_max, f"phases.{m + 1}.q_max", joint_hi),
                        f"phases.{m}.target_q",
                        "the next phase's bounds",
                    )
            bounds.append((lo, hi))
        q0 = vec(self.initial.q, "initial.q", self.model.q_initial)
        within(q0, *bounds[0], "initial.q", "the joint range of the first phase")
        if self.model.chain is not None and self.initial.q is not None:
            gap = self.model.chain.head_gap(q0)
            if not gap > 0:
                _fail("initial.q", f"the head starts inside the cushion (gap {gap * 1e3:.3g} mm)")
        vec(self.initial.qd, "initial.qd", np.zeros(n))
        if self.initial.velocity == "free" and self.initial.qd is not None:
            _fail("initial.qd", "must be null when the initial velocity is free")
        if self.final.q is not None:
            within(vec(self.final.q, "final.q", q0), *bounds[-1], "final.q", "the joint range of the last phase")
        if self.endpoint_cost is not None:
            ec = self.endpoint_cost
            if ec.w_q > 0 and ec.q_ref is None:
                _fail("endpoint_cost.q_ref", "is required when w_q > 0")
            if ec.q_ref is not None:
                within(vec(ec.q_ref, "endpoint_cost.q_ref", q0), joint_lo, joint_hi, "endpoint_cost.q_ref", model_range)
        if self.ranges:
            check_ranges(self, parse_task)
        return self

    # ---- derived ------------------------------------------------------------------
    @property
    def duration(self) -> float:
        return float(sum(ph.duration for ph in self.phases))

    @property
    def intervals(self) -> int:
        return int(sum(ph.intervals for ph in self.phases))

    def with_intervals(self, per_phase: int) -> TaskSpec:
        """The same task with ``per_phase`` intervals in every phase."""
        data = self.model_dump()
        for ph in data["phases"]:
            ph["intervals"] = per_phase
        return parse_task(data)

    def preset(self) -> HeadNeckPreset:
        """The 1-DOF preset's parameters (:class:`TaskSpecError` for a chain model)."""
        return self.model.to_preset()

    def chain(self) -> PlanarChain:
        return self.model.to_chain()

    def discrete_problem(self) -> DiscreteProblem:
        """Resolve defaults into the numbers the DMOCC transcription needs."""
        m = self.model
        lo0, hi0, t0 = m.joint_min, m.joint_max, m.torque_limits

        def arr(value: list[float] | None, default: FloatArray) -> FloatArray:
            return default if value is None else np.asarray(value, float)

        phases = tuple(
            PhaseGrid(
                duration=ph.duration,
                intervals=ph.intervals,
                w_tau=ph.w_tau,
                w_T=ph.w_T,
                q_min=arr(ph.q_min, lo0),
                q_max=arr(ph.q_max, hi0),
                tau_max=arr(ph.tau_max, t0),
                target_q=None if ph.target_q is None else np.asarray(ph.target_q, float),
            )
            for ph in self.phases
        )
        ini, fin, ec = self.initial, self.final, self.endpoint_cost
        return DiscreteProblem(
            phases=phases,
            q_start=arr(ini.q, m.q_initial),
            qd_start=None if ini.velocity == "free" else arr(ini.qd, np.zeros(m.ndof)),
            q_end=None if fin.q is None else np.asarray(fin.q, float),
            qd_end=np.zeros(m.ndof) if fin.velocity == "rest" else None,
            endpoint_w_q=0.0 if ec is None else ec.w_q,
            endpoint_q_ref=None if ec is None or ec.q_ref is None else np.asarray(ec.q_ref, float),
            endpoint_w_qd=0.0 if ec is None else ec.w_qd,
        )


def _error_from_validation(err: ValidationError) -> TaskSpecError:
    field, reason = error_location(err.errors()[0])  # cross-field checks carry their own path
    return TaskSpecError(field or "task", reason)


def parse_task(data: dict[str, Any] | str | Path) -> TaskSpec:
    """Validate a task from a dict, a JSON string or a JSON file; raise :class:`TaskSpecError`."""
    if isinstance(data, Path):
        try:
            data = json.loads(data.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise TaskSpecError("task", f"cannot read task file: {exc}") from exc
    try:
        if isinstance(data, str):
            return TaskSpec.model_validate_json(data)
        return TaskSpec.model_validate(data)
    except ValidationError as err:
        raise _error_from_validation(err) from err


TASK_PRESETS: dict[str, dict[str, Any]] = {
    "head-headrest-2phase": {
        "name": "head-headrest-2phase",
        "description": (
            "The paper's proof of concept: 2 s in two phases of 1 s; the head moves onto the headrest and rests there."
        ),
        "model": {"preset": "head-neck-1dof"},
        "initial": {"q": None, "qd": None},
        "phases": [
            {"name": "approach", "duration": 1.0, "intervals": 100, "w_tau": 1e-3, "w_T": 1e-4},
            {"name": "rest", "duration": 1.0, "intervals": 100, "w_tau": 1.0, "w_T": 1.0},
        ],
        "final": {"velocity": "rest"},
    },
    "head-headrest-smooth": {
        "name": "head-headrest-smooth",
        "description": (
            "The paper's task with w_T / w_tau = 1000 in the approach (w_T = 1 instead of 1e-4): the actuation holds "
            "the head against gravity and lowers it onto the headrest (first contact at about 0.25 rad/s, one force "
            "peak) instead of letting it fall (about 1.5 rad/s, a bounce). See docs/reproduction.md, the weight sweep."
        ),
        "model": {"preset": "head-neck-1dof"},
        "initial": {"q": None, "qd": None},
        "phases": [
            {"name": "approach", "duration": 1.0, "intervals": 100, "w_tau": 1e-3, "w_T": 1.0},
            {"name": "rest", "duration": 1.0, "intervals": 100, "w_tau": 1.0, "w_T": 1.0},
        ],
        "final": {"velocity": "rest"},
    },
    "head-headrest-2dof": {
        "name": "head-headrest-2dof",
        "description": (
            "The paper's two-phase task (2 s, two phases of 1 s) on the two-pivot head-neck model (C7/T1 and C0/C1, "
            "model preset head-neck-2dof): the head moves onto the headrest and rests there."
        ),
        "model": {"preset": "head-neck-2dof"},
        "initial": {"q": None, "qd": None},
        "phases": [
            {"name": "approach", "duration": 1.0, "intervals": 100, "w_tau": 1e-3, "w_T": 1e-4},
            {"name": "rest", "duration": 1.0, "intervals": 100, "w_tau": 1.0, "w_T": 1.0},
        ],
        "final": {"velocity": "rest"},
    },
}
TASK_PRESETS["head-headrest-scenarios"] = {
    **TASK_PRESETS["head-headrest-2phase"],
    "name": "head-headrest-scenarios",
    "description": (
        "The paper's task (head-headrest-2phase) as a distribution of scenarios: start angle 0.15 to "
        "0.30 rad, initial speed 0 to 0.5 rad/s toward the headrest, headrest moved +-5 mm along its normal. "
        "Its nominal scenario is the paper's task; a random-scenarios campaign solves a new draw every iteration."
    ),
    "ranges": [
        {"parameter": "initial.q.0", "low": 0.15, "high": 0.30},
        {"parameter": "initial.qd.0", "low": 0.0, "high": 0.5},
        {"parameter": "model.headrest_offset", "low": -0.005, "high": 0.005},
    ],
}


def task_preset(name: str) -> TaskSpec:
    """A task preset by name."""
    if name not in TASK_PRESETS:
        raise TaskSpecError("task", f"unknown task preset {name!r}; known: {', '.join(sorted(TASK_PRESETS))}")
    return parse_task(TASK_PRESETS[name])


__all__ = [
    "TASK_PRESETS",
    "EndpointCost",
    "FinalCondition",
    "InitialState",
    "ModelSpec",
    "PhaseSpec",
    "TaskSpec",
    "TaskSpecError",
    "parse_task",
    "task_preset",
]
