"""The held-out validation suite and the press family a campaign's settings ask for on its task:
the suite's model of the task (the 1-DOF preset or a chain's joint line), the ranges its motions
and the family's are drawn from, and why they cannot be drawn. Read when a campaign is created or
edited (a 422 at the range), by its first training (the suite it attaches) and by the
``press-family`` strategy's steps."""

from __future__ import annotations

from typing import Any


def suite_model(task: Any) -> Any:
    """The validation suite's model of a task (an ``alcove.science.ocp.task_spec.TaskSpec``): the
    1-DOF preset, or a chain's joint line (:func:`alcove.science.validation_suite.chain_suite_model`)."""
    m = task.model
    if not m.is_chain:
        return m.to_preset()
    from alcove.science.validation_suite import chain_suite_model

    return chain_suite_model(
        m.model_dump(mode="json"), m.pose_function(), m.oracle_preset(), m.q_initial, m.joint_min, m.joint_max
    )


def _task_angles(task: Any, parameter: str, nominal: float) -> tuple[float, float]:
    """The values a 1-DOF task's ``parameter`` takes: its range, or the nominal value."""
    for r in task.ranges or ():
        if r.parameter == parameter:
            return (min(r.low, nominal), max(r.high, nominal))
    return (nominal, nominal)


def task_box(task: Any, model: Any) -> Any:
    """The press family's box derived from ``task`` for its suite ``model``
    (:func:`alcove.science.validation_suite.task_ranges`)."""
    from alcove.science.validation_suite import ChainSuiteModel, task_ranges

    if isinstance(model, ChainSuiteModel):  # the reference angle of the 1-DOF preset along the chain's line
        return task_ranges(model, model.theta_contact)
    q0 = float(task.initial.q[0]) if task.initial.q is not None else float(task.model.q_initial[0])
    qd0 = float(task.initial.qd[0]) if task.initial.qd is not None else 0.0
    starts = _task_angles(task, "initial.q.0", q0)
    speeds = _task_angles(task, "initial.qd.0", qd0)
    return task_ranges(model, model.theta_contact, starts, max(abs(speeds[0]), abs(speeds[1])))


def family_box(settings: Any, task: Any, model: Any) -> Any:
    """The box strategy ``press-family`` draws its motions from: the task's, with ``family_ranges``."""
    from alcove.science.validation_suite import with_ranges

    return with_ranges(task_box(task, model), settings.family_ranges.given())


def suite_spec(settings: Any, task: Any, model: Any) -> Any:
    """The suite a campaign's run settings ask for on ``task`` with its suite ``model``: the
    ``validation_motions`` core motions of the box derived from the task
    (:func:`alcove.science.validation_suite.task_ranges`) with the ranges the user set, and the
    ``validation_stress_motions`` beyond it."""
    from alcove.science.validation_suite import SuiteSpec, stress_ranges, with_ranges

    core = with_ranges(task_box(task, model), settings.validation_ranges.given())
    n_stress = settings.validation_stress_motions
    stress = with_ranges(stress_ranges(core), settings.validation_stress_ranges.given()) if n_stress > 0 else None
    return SuiteSpec(
        motions=settings.validation_motions,
        seed=settings.validation_seed,
        ranges=core,
        stress_motions=n_stress,
        stress=stress,
        reference_motions=settings.validation_reference_motions,
    )


def suite_problem(settings: Any, task: Any, family: bool | None = None) -> tuple[str, str] | None:
    """Why the suite or the press family the settings ask for on ``task`` cannot be drawn, as
    (field, reason), or None (``family``: whether the campaign draws family motions; default:
    when its strategy is ``press-family``)."""
    from alcove.science.press_family import RangeError

    suite = settings.validation_motions > 0
    family = settings.strategy == "press-family" if family is None else family
    if not (suite or family):
        return None
    model = suite_model(task)
    spec = suite_spec(settings, task, model) if suite else None
    for part, ranges, field in (
        ("validation suite", spec.ranges if spec else None, "settings.validation_ranges"),
        ("validation suite stress", spec.stress if spec else None, "settings.validation_stress_ranges"),
        ("press family", family_box(settings, task, model) if family else None, "settings.family_ranges"),
    ):
        if ranges is None:
            continue
        try:
            ranges.check_for(model, part)
        except RangeError as err:
            return f"{field}.{err.parameter}", err.reason
    return None
