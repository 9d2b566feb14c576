"""The user's OCP task definition (pydantic), its validation and the task presets.

A task names a model preset with editable parameters, the initial state, one or more
phases (duration, intervals, cost weights w_tau / w_T, optional bounds and target pose at
the phase end), the final condition and an optional endpoint cost. Angles in rad, torques
in N m, durations in s. Lists have one entry per joint (the head-neck preset has one).

Errors name the field with its path, e.g. ``phases.1.duration: ...``; use
:func:`parse_task` to get a :class:`TaskSpecError` with ``field`` and ``reason``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from alcove.science.arrays import FloatArray
from alcove.science.geometry import HeadNeckPreset
from alcove.science.ocp.problem import DiscreteProblem, PhaseGrid

if TYPE_CHECKING:  # CasADi is imported only when a chain is built,
    # so validating a task (e.g. in the API process) stays light.
    from alcove.science.multibody import PlanarChain

_DEFAULT = HeadNeckPreset()


class TaskSpecError(ValueError):
    """Invalid task definition; ``field`` is the dotted path of the offending field."""

    def __init__(self, field: str, reason: str):
        self.field = field
        self.reason = reason
        super().__init__(f"{field}: {reason}")


class _Strict(BaseModel):
    # inf / NaN pass bounds like gt=0 (an infinite duration, a NaN headrest tilt): reject them
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


def _fail(field: str, reason: str) -> None:
    raise ValueError(f"{field}: {reason}")


class ModelSpec(_Strict):
    """Model preset and its parameters (defaults: the paper's head-neck model)."""

    preset: Literal["head-neck-1dof"] = "head-neck-1dof"
    mass: float = Field(_DEFAULT.mass, gt=0, description="head mass [kg]")
    com_distance: float = Field(_DEFAULT.com_distance, gt=0, description="joint -> head COG [m]")
    inertia_joint: float = Field(_DEFAULT.inertia_joint, gt=0, description="moment of inertia about the joint [kg m^2]")
    theta_min: float = Field(_DEFAULT.theta_min, description="lower joint limit [rad]")
    theta_max: float = Field(_DEFAULT.theta_max, description="upper joint limit [rad]")
    theta0: float = Field(_DEFAULT.theta0, description="initial angle [rad]")
    torque_limit: float = Field(_DEFAULT.torque_limit, gt=0, description="joint torque limit [N m]")
    gravity: float = Field(_DEFAULT.gravity, ge=0, description="gravitational acceleration [m/s^2]")
    theta_contact: float = Field(_DEFAULT.theta_contact, description="angle of first contact with the headrest [rad]")
    tilt: float = Field(_DEFAULT.tilt, description="headrest inclination [rad]")

    @model_validator(mode="after")
    def _consistent(self) -> ModelSpec:
        if not self.theta_min < self.theta_max:
            _fail("model.theta_max", f"must exceed theta_min ({self.theta_max} <= {self.theta_min})")
        if not self.theta_min <= self.theta0 <= self.theta_max:
            _fail("model.theta0", f"{self.theta0} lies outside the joint range [{self.theta_min}, {self.theta_max}]")
        if self.inertia_joint < self.mass * self.com_distance**2:
            _fail(
                "model.inertia_joint",
                "must be at least mass * com_distance^2 (inertia about the COG would be negative)",
            )
        return self

    @property
    def ndof(self) -> int:
        return 1

    def to_preset(self) -> HeadNeckPreset:
        data = self.model_dump(exclude={"preset"})
        return HeadNeckPreset(**data)


class InitialState(_Strict):
    """Initial state; ``q`` defaults to the model's theta0 and ``qd`` to rest."""

    q: list[float] | None = None
    qd: list[float] | None = Field(None, description="initial velocity; null = at rest")
    velocity: Literal["given", "free"] = Field(
        "given", description="'free' leaves the initial velocity to the optimizer"
    )


class FinalCondition(_Strict):
    """Final condition: at rest or free velocity; optional target pose."""

    velocity: Literal["rest", "free"] = "rest"
    q: list[float] | None = Field(None, description="target pose at the end; null = free")


class PhaseSpec(_Strict):
    name: str = ""
    duration: float = Field(gt=0, description="phase duration [s]")
    intervals: int = Field(100, ge=1, le=20000, description="DMOCC intervals in this phase")
    w_tau: float = Field(ge=0, description="weight of tau^T tau in the running cost")
    w_T: float = Field(ge=0, description="weight of the kinetic energy in the running cost")
    q_min: list[float] | None = Field(None, description="joint lower bounds in this phase (default: model range)")
    q_max: list[float] | None = Field(None, description="joint upper bounds in this phase (default: model range)")
    tau_max: list[float] | None = Field(None, description="torque bound |tau| <= tau_max (default: model limit)")
    target_q: list[float] | None = Field(None, description="pose to reach at the end of the phase")


class EndpointCost(_Strict):
    """E = w_q |q(t_F) - q_ref|^2 + w_qd |qd(t_F)|^2."""

    w_q: float = Field(0.0, ge=0)
    q_ref: list[float] | None = None
    w_qd: float = Field(0.0, ge=0)


class TaskSpec(_Strict):
    """A multi-phase OCP task."""

    name: str = "custom"
    description: str = ""
    model: ModelSpec = Field(default_factory=ModelSpec)
    initial: InitialState = Field(default_factory=InitialState)
    phases: list[PhaseSpec] = Field(min_length=1)
    final: FinalCondition = Field(default_factory=FinalCondition)
    endpoint_cost: EndpointCost | None = None

    @model_validator(mode="after")
    def _consistent(self) -> TaskSpec:
        n = self.model.ndof
        lo0, hi0 = np.array([self.model.theta_min]), np.array([self.model.theta_max])
        tmax0 = np.array([self.model.torque_limit])

        def vec(value: list[float] | None, path: str, default: FloatArray) -> FloatArray:
            if value is None:
                return default
            if len(value) != n:
                _fail(path, f"expected {n} value(s) (one per joint), got {len(value)}")
            arr = np.asarray(value, float)
            if not np.all(np.isfinite(arr)):
                _fail(path, "values must be finite")
            return arr

        def within(arr: FloatArray, lo: FloatArray, hi: FloatArray, path: str, what: str) -> None:
            if np.any(arr < lo) or np.any(arr > hi):
                _fail(path, f"{arr.tolist()} lies outside {what} [{lo.tolist()}, {hi.tolist()}]")

        bounds = []
        for m, ph in enumerate(self.phases):
            lo = vec(ph.q_min, f"phases.{m}.q_min", lo0)
            hi = vec(ph.q_max, f"phases.{m}.q_max", hi0)
            if np.any(lo >= hi):
                _fail(f"phases.{m}.q_min", f"must be below q_max ({lo.tolist()} >= {hi.tolist()})")
            within(lo, lo0, hi0, f"phases.{m}.q_min", "the model's joint range")
            within(hi, lo0, hi0, f"phases.{m}.q_max", "the model's joint range")
            tmax = vec(ph.tau_max, f"phases.{m}.tau_max", tmax0)
            if np.any(tmax <= 0):
                _fail(f"phases.{m}.tau_max", "must be > 0")
            if np.any(tmax > tmax0):
                _fail(f"phases.{m}.tau_max", f"exceeds the model's torque_limit {self.model.torque_limit}")
            if ph.target_q is not None:
                target = vec(ph.target_q, f"phases.{m}.target_q", lo)
                within(target, lo, hi, f"phases.{m}.target_q", "the phase bounds")
                if m + 1 < len(self.phases):
                    nxt = self.phases[m + 1]
                    within(
                        target,
                        vec(nxt.q_min, f"phases.{m + 1}.q_min", lo0),
                        vec(nxt.q_max, f"phases.{m + 1}.q_max", hi0),
                        f"phases.{m}.target_q",
                        "the next phase's bounds",
                    )
            bounds.append((lo, hi))
        q0 = vec(self.initial.q, "initial.q", np.array([self.model.theta0]))
        within(q0, *bounds[0], "initial.q", "the joint range of the first phase")
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
                vec(ec.q_ref, "endpoint_cost.q_ref", q0)
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
        return self.model.to_preset()

    def chain(self) -> PlanarChain:
        from alcove.science.multibody import PlanarChain

        return PlanarChain.from_preset(self.preset())

    def discrete_problem(self) -> DiscreteProblem:
        """Resolve defaults into the numbers the DMOCC transcription needs."""
        m = self.model
        lo0, hi0, t0 = np.array([m.theta_min]), np.array([m.theta_max]), np.array([m.torque_limit])

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
            q_start=arr(ini.q, np.array([m.theta0])),
            qd_start=None if ini.velocity == "free" else arr(ini.qd, np.zeros(m.ndof)),
            q_end=None if fin.q is None else np.asarray(fin.q, float),
            qd_end=np.zeros(m.ndof) if fin.velocity == "rest" else None,
            endpoint_w_q=0.0 if ec is None else ec.w_q,
            endpoint_q_ref=None if ec is None or ec.q_ref is None else np.asarray(ec.q_ref, float),
            endpoint_w_qd=0.0 if ec is None else ec.w_qd,
        )


def _error_from_validation(err: ValidationError) -> TaskSpecError:
    first = err.errors()[0]
    loc = ".".join(str(p) for p in first["loc"])
    msg = str(first["msg"]).removeprefix("Value error, ")
    head, sep, rest = msg.partition(": ")
    if sep and " " not in head:  # cross-field checks carry their own path
        loc, msg = head, rest
    return TaskSpecError(loc or "task", msg)


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
        "description": "The paper's proof of concept: 2 s in two phases of 1 s; the head moves onto the headrest and rests there.",
        "model": {"preset": "head-neck-1dof"},
        "initial": {"q": None, "qd": None},
        "phases": [
            {"name": "approach", "duration": 1.0, "intervals": 100, "w_tau": 1e-3, "w_T": 1e-4},
            {"name": "rest", "duration": 1.0, "intervals": 100, "w_tau": 1.0, "w_T": 1.0},
        ],
        "final": {"velocity": "rest"},
    }
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
