"""Scenarios: a task as a distribution.

A task may declare **ranges** for some of its numeric parameters (``TaskSpec.ranges``): each
names the parameter by its dotted path in the task spec, gives ``low`` and ``high`` and how values
are drawn between them (``distribution``: ``uniform``, the default; ``normal`` with ``mean`` and
``std``, truncated to [low, high]; ``triangular`` peaking at ``mode``).
A **scenario** is one concrete, validated task instance: the task with every ranged parameter
set to a value drawn from its range and no ranges left. A task without ranges has exactly one
scenario, the task itself (the paper's case: :func:`nominal` returns the very same object).

Parameters that may be ranged (``{j}`` a joint index, ``{m}`` a phase index):

==============================  =======================================================
``initial.q.{j}``               initial angle [rad] (default: ``model.theta0``)
``initial.qd.{j}``              initial angular velocity [rad/s] (default: at rest;
                                not with ``initial.velocity = "free"``)
``phases.{m}.duration``         phase duration [s]
``phases.{m}.w_tau``,           running-cost weights
``phases.{m}.w_T``
``phases.{m}.target_q.{j}``     target pose at the phase end [rad] (the phase must have one)
``final.q.{j}``                 final pose [rad] (the task must have one)
``endpoint_cost.w_q``,          endpoint-cost weights and reference pose (the task must
``endpoint_cost.w_qd``,         have an endpoint cost)
``endpoint_cost.q_ref.{j}``
``model.headrest_offset``       headrest moved along its normal [m] (positive: toward the head)
``model.tilt``                  headrest inclination [rad], within +-0.05 rad
                                (``MAX_TILT_DEVIATION``) of the task's own; the headrest
                                turns about its origin (the head's back point at
                                ``theta_contact``), so the head touches it earlier
==============================  =======================================================

Every range is checked against the model's validated ranges by building the task at its
``low`` and at its ``high`` (all other parameters nominal); every drawn scenario is validated
again as a whole, so a combination that breaks a cross-field rule is an error naming the ranges,
never a silently clipped value.

Draws are seeded: scenario ``(seed, iteration, slot)`` uses NumPy's ``Generator`` on
``SeedSequence([seed, iteration, slot, SALT])``, so a campaign's iteration k (slot 0 at batch
size q = 1; slots 0..q-1 when batches come) always draws the same scenario, on any worker.

Pure science: imports neither web nor database code. The ranges and their checks, which the
task spec needs, are in :mod:`alcove.science.ocp.scenario_ranges`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.stats import truncnorm

from alcove.science.ocp.scenario_ranges import PARAMETERS, ParameterRange, describe, set_value
from alcove.science.ocp.task_spec import TaskSpec, TaskSpecError, parse_task

#: distinguishes the scenario stream from other streams derived from the same campaign seed
SALT = 0x5CE7A210


def apply_values(task: TaskSpec, values: dict[str, float]) -> TaskSpec:
    """The concrete task with ``values`` (parameter path -> value) set and no ranges; raises
    :class:`~alcove.science.ocp.task_spec.TaskSpecError` naming the task field if it is invalid."""
    data = task.model_dump()
    data["ranges"] = None
    for parameter, value in values.items():
        try:
            set_value(data, parameter, value, task.model.ndof)
        except ValueError as exc:
            raise TaskSpecError(parameter, str(exc)) from exc
    return parse_task(data)


def apply_to_spec(spec: dict[str, Any], values: dict[str, float]) -> dict[str, Any]:
    """A stored task spec (JSON) with a scenario's values set (for reading: phase durations)."""
    return apply_values(parse_task(spec), values).model_dump(mode="json")


# ----------------------------------------------------------------------------- scenarios


@dataclass(frozen=True)
class Scenario:
    """One concrete task instance: ``task`` (no ranges), drawn as ``values`` with ``(seed, iteration, slot)``."""

    task: TaskSpec
    values: dict[str, float] = field(default_factory=dict)
    seed: int | None = None
    iteration: int | None = None
    slot: int = 0

    def to_json(self) -> dict[str, Any]:
        """What is stored with an iteration (the task follows from the task version and ``values``)."""
        return {"seed": self.seed, "iteration": self.iteration, "slot": self.slot, "values": dict(self.values)}


def nominal(task: TaskSpec) -> TaskSpec:
    """The task without ranges (every parameter as written); the same object if it has none."""
    if not task.ranges:
        return task
    return task.model_copy(update={"ranges": None})


def generator(seed: int, iteration: int, slot: int = 0) -> np.random.Generator:
    """The random stream of scenario ``(seed, iteration, slot)``."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), int(iteration), int(slot), SALT]))


def draw_value(r: ParameterRange, rng: np.random.Generator) -> float:
    """One value of range ``r`` from ``rng``: uniform on [low, high]; normal (mean, std) truncated to
    [low, high] (SciPy's ``truncnorm``, by inversion: one uniform number per draw, like the others);
    triangular on [low, high] with its peak at ``mode``. A range with low = high gives low."""
    if not r.high > r.low:
        return float(r.low)
    if r.distribution == "normal":
        assert r.mean is not None and r.std is not None
        a, b = (r.low - r.mean) / r.std, (r.high - r.mean) / r.std
        value = float(truncnorm.ppf(rng.uniform(), a, b, loc=r.mean, scale=r.std))
        return min(max(value, r.low), r.high)  # the inversion's last bit of rounding
    if r.distribution == "triangular":
        assert r.mode is not None
        return float(rng.triangular(r.low, r.mode, r.high))
    return float(rng.uniform(r.low, r.high))


def draw(task: TaskSpec, seed: int, iteration: int, slot: int = 0) -> Scenario:
    """Scenario ``(seed, iteration, slot)`` of ``task``: every range drawn from its distribution
    (:func:`draw_value`), in the order declared. A task without ranges gives its nominal spec
    unchanged (the same object).

    Raises :class:`~alcove.science.ocp.task_spec.TaskSpecError` (field ``ranges``) if the drawn
    combination breaks a cross-field rule of the task."""
    if not task.ranges:
        return Scenario(task=task, seed=seed, iteration=iteration, slot=slot)
    rng = generator(seed, iteration, slot)
    values = {r.parameter: draw_value(r, rng) for r in task.ranges}
    try:
        concrete = apply_values(task, values)
    except TaskSpecError as exc:
        raise TaskSpecError(
            "ranges",
            f"the scenario drawn with seed {seed}, iteration {iteration} is not a valid task "
            f"({exc.field}: {exc.reason}); narrow the ranges",
        ) from exc
    return Scenario(task=concrete, values=values, seed=seed, iteration=iteration, slot=slot)


def from_json(task: TaskSpec, stored: dict[str, Any] | None) -> TaskSpec:
    """The concrete task of a stored scenario (``None``: the nominal task)."""
    if stored is None:
        return nominal(task)
    values = {str(k): float(v) for k, v in (stored.get("values") or {}).items()}
    return apply_values(task, values) if values else nominal(task)


def preview(task: TaskSpec, seed: int, n: int) -> list[Scenario]:
    """The scenarios iterations 1..n of a ``random-scenarios`` campaign with ``seed`` would solve."""
    return [draw(task, seed, k) for k in range(1, n + 1)]


__all__ = [
    "PARAMETERS",
    "ParameterRange",
    "Scenario",
    "apply_to_spec",
    "apply_values",
    "describe",
    "draw",
    "draw_value",
    "from_json",
    "generator",
    "nominal",
    "preview",
]
