"""The ranges of a task's parameters (``TaskSpec.ranges``) and their checks: the part of
:mod:`alcove.science.ocp.scenarios` the task spec itself needs (this module does not import the
task spec; the checks get its parser as an argument, so the science imports stay acyclic)."""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, SerializerFunctionWrapHandler, model_serializer

from alcove.science.spec_checks import quantity

#: the widest any rangeable parameter may go (the cost weights' bound, MAX_WEIGHT of the task spec);
#: each end is then checked against its parameter's own range
RANGE_LIMIT = 1e6

#: at most this many ranges per task
MAX_RANGES = 32

#: the headrest tilt, the one model geometry parameter besides the offset that a scenario may draw
TILT_PARAMETER = "model.tilt"

#: rad: a ranged headrest tilt stays within this of the task's own (the head-neck-1dof preset's
#: ``tilt`` as the task writes it, 0.31 rad in the paper): the headrest turns about its origin (the
#: head's back point at ``theta_contact``, moved by the offset), and the oracles' cushion covers
#: the contact zone over this range
MAX_TILT_DEVIATION = 0.05

#: the parameters that may be ranged: path pattern ({m} a phase, {j} a joint index) -> (what, unit)
PARAMETERS: dict[str, tuple[str, str]] = {
    "initial.q.{j}": ("initial angle", "rad"),
    "initial.qd.{j}": ("initial angular velocity", "rad/s"),
    "phases.{m}.duration": ("phase duration", "s"),
    "phases.{m}.w_tau": ("running-cost torque weight", "1/(N^2 m^2 s)"),
    "phases.{m}.w_T": ("running-cost kinetic-energy weight", "1/(J s)"),
    "phases.{m}.target_q.{j}": ("target pose at the phase end", "rad"),
    "final.q.{j}": ("final pose", "rad"),
    "endpoint_cost.w_q": ("endpoint pose weight", "1/rad^2"),
    "endpoint_cost.w_qd": ("endpoint velocity weight", "s^2/rad^2"),
    "endpoint_cost.q_ref.{j}": ("endpoint reference pose", "rad"),
    "model.headrest_offset": ("headrest offset along its normal", "m"),
    # an oracle dataset of a scenario that draws the tilt records it (meta.headrest_tilt): its
    # training features are relative to the tilted headrest
    TILT_PARAMETER: ("headrest inclination (backward)", "rad"),
    # not model.theta_contact: a dataset does not record the headrest's placement angle (not done yet)
}
_COMPILED = [
    (re.compile("^" + re.escape(p).replace(r"\{m\}", r"\d+").replace(r"\{j\}", r"\d+") + "$"), what)
    for p, what in PARAMETERS.items()
]
PARAMETER_NAMES = list(PARAMETERS)


#: how a range's values are drawn (alcove.science.ocp.scenarios.draw_value)
DISTRIBUTIONS = ("uniform", "normal", "triangular")


class ParameterRange(BaseModel):
    """The range of one task parameter, named by its dotted path in the task spec, and how its
    values are drawn: ``uniform`` on [low, high] (the default), ``normal`` with ``mean`` and
    ``std`` truncated to [low, high], or ``triangular`` on [low, high] with its peak at ``mode``."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    parameter: Annotated[
        str,
        Field(
            min_length=1,
            max_length=80,
            description="dotted path of the parameter in the task, e.g. initial.q.0, phases.0.duration, "
            "model.headrest_offset; one of: " + ", ".join(PARAMETER_NAMES),
        ),
    ]
    low: Annotated[
        float,
        quantity(
            "lower end of the range (no value is drawn below it)",
            "the parameter's unit",
            ge=-RANGE_LIMIT,
            le=RANGE_LIMIT,
            why="and within the parameter's own range",
        ),
    ]
    high: Annotated[
        float,
        quantity(
            "upper end of the range, at least low (no value is drawn above it)",
            "the parameter's unit",
            ge=-RANGE_LIMIT,
            le=RANGE_LIMIT,
            why="and within the parameter's own range",
        ),
    ]
    distribution: Annotated[
        Literal["uniform", "normal", "triangular"],
        Field(
            description="how values are drawn: uniform on [low, high]; normal with mean and std, truncated "
            "to [low, high]; triangular on [low, high] peaking at mode"
        ),
    ] = "uniform"
    mean: Annotated[
        float | None,
        quantity(
            "centre of the normal distribution, within [low, high]",
            "the parameter's unit",
            ge=-RANGE_LIMIT,
            le=RANGE_LIMIT,
            why="only with distribution normal",
        ),
    ] = None
    std: Annotated[
        float | None,
        quantity(
            "standard deviation of the normal distribution before truncation",
            "the parameter's unit",
            gt=0,
            le=RANGE_LIMIT,
            why="only with distribution normal",
        ),
    ] = None
    mode: Annotated[
        float | None,
        quantity(
            "peak of the triangular distribution, within [low, high]",
            "the parameter's unit",
            ge=-RANGE_LIMIT,
            le=RANGE_LIMIT,
            why="only with distribution triangular",
        ),
    ] = None

    @model_serializer(mode="wrap")
    def _without_defaults(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        """A uniform range dumps as before distributions existed (parameter, low, high), so stored
        task specs and their content hashes do not change; unused shape fields are left out."""
        data: dict[str, Any] = handler(self)
        if data.get("distribution") == "uniform":
            del data["distribution"]
        for key in ("mean", "std", "mode"):
            if data.get(key) is None:
                data.pop(key, None)
        return data


def check_distribution(r: ParameterRange) -> tuple[str, str] | None:
    """(field, reason) if ``r``'s distribution fields do not fit together, else None (low <= high
    is checked before)."""
    used = {"normal": ("mean", "std"), "triangular": ("mode",), "uniform": ()}[r.distribution]
    for key in ("mean", "std", "mode"):
        value = getattr(r, key)
        if key in used and value is None:
            return key, f"required with distribution {r.distribution}"
        if key not in used and value is not None:
            return key, f"only with distribution {'normal' if key != 'mode' else 'triangular'}, not {r.distribution}"
    for key in ("mean", "mode"):
        value = getattr(r, key)
        if value is not None and not r.low <= value <= r.high:
            return key, f"must lie within [low, high] = [{r.low:g}, {r.high:g}], got {value:g}"
    return None


def describe(parameter: str) -> tuple[str, str] | None:
    """(what, unit) of a parameter path that may be ranged, else None."""
    for pattern, what in _COMPILED:
        if pattern.match(parameter):
            return what
    return None


# ----------------------------------------------------------------------------- applying values


def _defaults(data: dict[str, Any], ndof: int) -> dict[str, list[float]]:
    """The task's initial state where it gives none: the model's starting pose (each chain
    joint's ``q0``, or the 1-DOF preset's ``theta0``), at rest."""
    model = data["model"]
    chain = model.get("chain")
    q = [float(j["q0"]) for j in chain["joints"]] if chain else [float(model["theta0"])] * ndof
    return {"initial.q": q, "initial.qd": [0.0] * ndof}


def set_value(data: dict[str, Any], parameter: str, value: float, ndof: int) -> None:
    """Set ``parameter`` (a dotted path) in the dumped task ``data``; raise ValueError(reason)."""
    parts = parameter.split(".")
    node: Any = data
    for depth, part in enumerate(parts[:-1]):
        key: Any = int(part) if part.isdigit() else part
        if isinstance(node, list):
            if key >= len(node):
                raise ValueError(f"index {key} out of range: the task has {len(node)} {parts[depth - 1]}")
            child = node[key]
        else:
            child = node.get(key)
        if child is None:
            prefix = ".".join(parts[: depth + 1])
            default = _defaults(data, ndof).get(prefix)
            if default is None:
                raise ValueError(f"the task has no {prefix} to vary (set it first)")
            child = list(default)
            node[key] = child
        node = child
    last = parts[-1]
    if isinstance(node, list):
        j = int(last)
        if j >= len(node):
            raise ValueError(f"joint index {j} out of range: the model has {len(node)} joint(s)")
        node[j] = float(value)
    else:
        node[last] = float(value)


def _check_tilt(i: int, r: ParameterRange, nominal: float) -> None:
    for end in ("low", "high"):
        value = float(getattr(r, end))
        if abs(value - nominal) > MAX_TILT_DEVIATION + 1e-12:
            raise ValueError(
                f"ranges.{i}.{end}: {TILT_PARAMETER} = {value:g} rad is {abs(value - nominal):.3g} rad from the "
                f"task's headrest tilt {nominal:g} rad; a ranged tilt stays within +-{MAX_TILT_DEVIATION:g} rad of it "
                "(the oracles' cushion covers the contact zone over that range)"
            )


def check_ranges(task: Any, parse: Callable[[dict[str, Any]], Any]) -> None:
    """Validate ``task.ranges`` (a TaskSpec): known parameters, low <= high, no duplicates, and
    each end a valid task (the model's validated ranges: ``parse`` builds the task with that one
    value set, all others as written). Raises ``ValueError("ranges.i.field: reason")``.

    The task's cross-field rules (start and target poses within the phase bounds, ...) each
    involve at most one parameter that may be ranged, so valid ends make every value between
    them valid; a draw is validated again all the same (:func:`~alcove.science.ocp.scenarios.draw`)."""
    ranges = task.ranges or []
    if len(ranges) > MAX_RANGES:
        raise ValueError(f"ranges: at most {MAX_RANGES} ranges, got {len(ranges)}")
    seen: dict[str, int] = {}
    for i, r in enumerate(ranges):
        if describe(r.parameter) is None:
            raise ValueError(
                f"ranges.{i}.parameter: {r.parameter!r} cannot be varied; known: {', '.join(PARAMETER_NAMES)}"
            )
        if r.parameter in seen:
            raise ValueError(f"ranges.{i}.parameter: {r.parameter} is ranged twice (also ranges.{seen[r.parameter]})")
        seen[r.parameter] = i
        if r.parameter.startswith("initial.qd.") and task.initial.velocity == "free":
            raise ValueError(f"ranges.{i}.parameter: the initial velocity is free (left to the optimizer)")
        if not r.low <= r.high:
            raise ValueError(f"ranges.{i}.high: must be at least low ({r.high:g} < {r.low:g})")
        problem = check_distribution(r)
        if problem is not None:
            raise ValueError(f"ranges.{i}.{problem[0]}: {problem[1]}")
        if r.parameter == TILT_PARAMETER:
            _check_tilt(i, r, float(task.model.tilt))
        for end in ("low", "high"):
            value = getattr(r, end)
            data = task.model_dump()
            data["ranges"] = None
            try:
                set_value(data, r.parameter, value, task.model.ndof)
            except ValueError as exc:
                raise ValueError(f"ranges.{i}.{end}: {r.parameter} = {value:g}: {exc}") from exc
            try:
                parse(data)
            except ValueError as exc:  # TaskSpecError: field and reason
                where = f"{getattr(exc, 'field', '')}: {getattr(exc, 'reason', exc)}"
                raise ValueError(f"ranges.{i}.{end}: {r.parameter} = {value:g} is not a valid task ({where})") from exc
