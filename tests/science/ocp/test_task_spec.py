"""Task definitions: the preset, resolution into the discrete problem, and bad input."""

import copy
import itertools
import json
import math

import numpy as np
import pytest
from pydantic import ValidationError

from alcove.errors import field_errors_from_pydantic
from alcove.science.geometry import DEFAULT_PRESET
from alcove.science.ocp.task_spec import TASK_PRESETS, TaskSpec, TaskSpecError, parse_task, task_preset


def test_head_headrest_preset_is_the_papers_setup():
    task = task_preset("head-headrest-2phase")
    assert task.duration == 2.0 and task.intervals == 200
    (p1, p2) = task.phases
    assert (p1.duration, p1.w_tau, p1.w_T) == (1.0, 1e-3, 1e-4)
    assert (p2.duration, p2.w_tau, p2.w_T) == (1.0, 1.0, 1.0)
    prob = task.discrete_problem()
    assert prob.q_start[0] == DEFAULT_PRESET.theta0 and prob.qd_start[0] == 0.0  # at rest at t = 0
    assert prob.qd_end[0] == 0.0 and prob.q_end is None  # at rest at t = 2 s, pose free
    assert prob.phases[0].tau_max[0] == DEFAULT_PRESET.torque_limit
    np.testing.assert_allclose(prob.time_grid()[[0, 100, 200]], [0.0, 1.0, 2.0])
    assert task.preset() == DEFAULT_PRESET


def test_json_roundtrip_and_interval_override():
    task = task_preset("head-headrest-2phase")
    again = parse_task(task.model_dump_json())
    assert again == task
    assert task.with_intervals(30).intervals == 60


def bad(mutate):
    data = copy.deepcopy(TASK_PRESETS["head-headrest-2phase"])
    mutate(data)
    with pytest.raises(TaskSpecError) as info:
        parse_task(data)
    return info.value


@pytest.mark.parametrize(
    "mutate, field, reason",
    [
        (lambda d: d["phases"][0].update(duration=-1.0), "phases.0.duration", "greater than 0"),
        (lambda d: d["phases"][1].update(w_tau=-1.0), "phases.1.w_tau", "greater than or equal to 0"),
        (lambda d: d["phases"][1].update(w_T=-0.5), "phases.1.w_T", "greater than or equal to 0"),
        (lambda d: d["phases"][0].update(intervals=0), "phases.0.intervals", "greater than or equal to 1"),
        (lambda d: d.update(phases=[]), "phases", "at least 1"),
        (lambda d: d["phases"][0].update(q_min=[0.3], q_max=[0.2]), "phases.0.q_min.0", "below q_max"),
        (lambda d: d["phases"][0].update(q_max=[0.6]), "phases.0.q_max.0", "outside the model's joint range"),
        (lambda d: d["phases"][1].update(tau_max=[40.0]), "phases.1.tau_max.0", "torque_limit"),
        (lambda d: d["phases"][0].update(q_min=[0.3]), "initial.q.0", "outside the joint range of the first phase"),
        (lambda d: d.update(initial={"q": [0.5]}), "initial.q.0", "outside"),
        (lambda d: d.update(initial={"q": [0.2, 0.1]}), "initial.q", "expected 1 value"),
        (lambda d: d["model"].update(theta0=0.0), "model.theta0", "outside the joint range"),
        (lambda d: d["model"].update(theta_min=0.5), "model.theta_max", "must exceed theta_min"),
        (lambda d: d["model"].update(mass=0.0), "model.mass", "greater than 0"),
        (lambda d: d["phases"][0].update(target_q=[0.5]), "phases.0.target_q.0", "outside the phase bounds"),
        (lambda d: d.update(final={"q": [0.01]}), "final.q.0", "outside"),
        (lambda d: d.update(endpoint_cost={"w_q": 1.0}), "endpoint_cost.q_ref", "required"),
        (lambda d: d["phases"][0].update(speed=3), "phases.0.speed", "Extra inputs"),
        # non-finite numbers pass bounds like gt=0 unless rejected explicitly
        (lambda d: d["phases"][0].update(duration=float("inf")), "phases.0.duration", "finite number"),
        (lambda d: d["phases"][1].update(w_T=float("inf")), "phases.1.w_T", "finite number"),
        (lambda d: d["model"].update(tilt=float("nan")), "model.tilt", "finite number"),
        (lambda d: d["model"].update(theta_min=float("-inf")), "model.theta_min", "finite number"),
        (lambda d: d["model"].update(gravity=float("inf")), "model.gravity", "finite number"),
        (lambda d: d.update(endpoint_cost={"w_qd": float("nan")}), "endpoint_cost.w_qd", "finite number"),
        (lambda d: d["phases"][0].update(tau_max=[float("inf")]), "phases.0.tau_max.0", "finite number"),
        # a model preset that is not a string (found by schemathesis: a TypeError, unhashable, before)
        (lambda d: d["model"].update(preset={}), "model.preset", "Input should be"),
        (lambda d: d["model"].update(preset=[None, None]), "model.preset", "Input should be"),
    ],
)
def test_bad_input_names_the_field(mutate, field, reason):
    err = bad(mutate)
    assert err.field == field
    assert reason in err.reason
    assert str(err).startswith(f"{field}: ")


def test_unknown_preset_and_unreadable_file(tmp_path):
    with pytest.raises(TaskSpecError, match=r"^task: unknown task preset"):
        task_preset("nope")
    f = tmp_path / "t.json"
    f.write_text("{not json")
    with pytest.raises(TaskSpecError, match=r"^task: cannot read"):
        parse_task(f)
    f.write_text(json.dumps(TASK_PRESETS["head-headrest-2phase"]))
    assert parse_task(f).name == "head-headrest-2phase"
    # JSON's non-standard Infinity (Python's json writes it) is rejected from a file too
    data = copy.deepcopy(TASK_PRESETS["head-headrest-2phase"])
    data["phases"][1]["duration"] = float("inf")
    f.write_text(json.dumps(data))
    with pytest.raises(TaskSpecError, match=r"^phases.1.duration: .*finite"):
        parse_task(f)


# ---- ranges: every user-facing number has a plausible physical range -----------------------------
def set_path(data: dict, path: str, value: object) -> None:
    """Set ``data[...]`` at a dotted path (list indices as numbers), creating missing objects."""
    keys = [int(p) if p.isdigit() else p for p in path.split(".")]
    node = data
    for key, following in itertools.pairwise(keys):
        if isinstance(key, str) and node.get(key) is None:
            node[key] = [None] if isinstance(following, int) else {}
        node = node[key]
    node[keys[-1]] = value


# (field, a realistic value, the same field too large) for every number of a task
NUMBERS = [
    ("model.mass", 4.2, 1e308),
    ("model.com_distance", 0.15, 10.0),
    ("model.inertia_joint", 0.2, 1e3),
    ("model.theta_min", -0.2, -4.0),
    ("model.theta_max", 0.8, 4.0),
    ("model.theta0", 0.1, 1e308),
    ("model.torque_limit", 45.0, 1e308),
    ("model.gravity", 9.81, 1e308),
    ("model.theta_contact", 0.35, 3.2),
    ("model.tilt", 0.25, 1e308),
    ("phases.0.duration", 0.5, 1e308),
    ("phases.0.w_tau", 0.01, 1e308),
    ("phases.0.w_T", 0.5, 1e308),
    ("initial.qd.0", 0.4, 1e308),
    ("endpoint_cost.w_q", 10.0, 1e308),
    ("endpoint_cost.w_qd", 1.0, 1e308),
]
# joint angles: within +-pi/2 as numbers, and within the model's (validated) joint range as a pose
ANGLES = ["phases.0.q_min.0", "phases.0.q_max.0", "phases.0.target_q.0", "initial.q.0", "final.q.0"]


def preset_with(path: str, value: object) -> dict:
    data = copy.deepcopy(TASK_PRESETS["head-headrest-2phase"])
    set_path(data, path, value)
    if path.startswith("endpoint_cost"):
        data["endpoint_cost"].setdefault("q_ref", [0.3])
    return data


@pytest.mark.parametrize(("path", "value", "reason"), [(p, big, "less than or equal to") for p, _, big in NUMBERS])
def test_too_large_numbers_name_the_field(path, value, reason):
    """gravity or a duration of 1e308 is refused, with the field and the largest value allowed."""
    if path == "model.theta_min":
        reason = "greater than or equal to -1.5707"
    with pytest.raises(TaskSpecError) as info:
        parse_task(preset_with(path, value))
    assert info.value.field == path and reason in info.value.reason


@pytest.mark.parametrize("value", [float("nan"), float("inf"), float("-inf")])
@pytest.mark.parametrize("path", [p for p, _, _ in NUMBERS] + ANGLES + ["phases.0.tau_max.0", "endpoint_cost.q_ref.0"])
def test_non_finite_numbers_name_the_field(path, value):
    with pytest.raises(TaskSpecError) as info:
        parse_task(preset_with(path, value))
    assert info.value.field == path and "finite number" in info.value.reason


@pytest.mark.parametrize(
    ("value", "reason"),
    [
        (2.5, "whole number, got 2.5"),
        ("100", "whole number, not text"),
        (True, "whole number, not true or false"),
        (1e308, "less than or equal to 20000"),
        (0, "greater than or equal to 1"),
    ],
)
def test_interval_counts_are_whole_numbers(value, reason):
    with pytest.raises(TaskSpecError) as info:
        parse_task(preset_with("phases.1.intervals", value))
    assert info.value.field == "phases.1.intervals" and reason in info.value.reason


def test_a_whole_float_is_a_whole_number():
    """JSON Schema's "integer" accepts 40.0 (a JSON number written with a fraction of zero)."""
    task = parse_task(preset_with("phases.0.intervals", 40.0))
    assert task.phases[0].intervals == 40 and type(task.phases[0].intervals) is int


@pytest.mark.parametrize("path", [*ANGLES, "endpoint_cost.q_ref.0"])
def test_angles_far_outside_any_joint_range_are_refused_as_numbers(path):
    with pytest.raises(TaskSpecError) as info:
        parse_task(preset_with(path, 1e308))
    assert info.value.field == path and "less than or equal to 1.5707" in info.value.reason


@pytest.mark.parametrize(
    ("path", "value", "reason"),
    [
        ("phases.0.q_min.0", 0.0, "0 rad lies outside the model's joint range [0.032, 0.432] rad"),
        ("phases.1.q_max.0", 0.5, "0.5 rad lies outside the model's joint range [0.032, 0.432] rad"),
        ("phases.0.target_q.0", 0.45, "0.45 rad lies outside the phase bounds [0.032, 0.432] rad"),
        ("initial.q.0", 0.02, "0.02 rad lies outside the joint range of the first phase [0.032, 0.432] rad"),
        ("final.q.0", 1.0, "1 rad lies outside the joint range of the last phase [0.032, 0.432] rad"),
        ("endpoint_cost.q_ref.0", -0.1, "-0.1 rad lies outside the model's joint range [0.032, 0.432] rad"),
        ("phases.1.tau_max.0", 30.5, "30.5 N m exceeds the model's torque_limit 30 N m"),
        ("model.theta0", 0.5, "0.5 rad lies outside the joint range [0.032, 0.432] rad"),
        ("model.inertia_joint", 0.05, "must be at least mass * com_distance^2 = 0.072 kg m^2"),
    ],
)
def test_values_outside_the_models_validated_range_name_the_field_and_the_range(path, value, reason):
    with pytest.raises(TaskSpecError) as info:
        parse_task(preset_with(path, value))
    assert info.value.field == path and info.value.reason.startswith(reason)


@pytest.mark.parametrize(
    ("path", "value"),
    [("phases.0.intervals", 2.5), ("model.gravity", 1e308), ("phases.0.q_min.0", 0.0), ("model.theta_max", 0.01)],
)
def test_the_api_reports_the_same_field(path, value):
    """The API turns pydantic errors into field errors (alcove.errors): the same path, under 'spec'."""
    with pytest.raises(ValidationError) as info:
        TaskSpec.model_validate(preset_with(path, value))
    (first, *_) = field_errors_from_pydantic(info.value, base=("spec",))
    assert first.field == f"spec.{path}"


def test_realistic_values_pass():
    """The preset, every number set to a realistic other value, the limits of every range, and the
    adjusted task of the paper's reproduction (scripts/reproduce.py) all validate."""
    assert task_preset("head-headrest-2phase").model.gravity == 9.81
    data = copy.deepcopy(TASK_PRESETS["head-headrest-2phase"])
    for path, realistic, _ in NUMBERS:
        set_path(data, path, realistic)
    data["initial"]["q"] = [0.2]
    data["endpoint_cost"]["q_ref"] = [0.35]
    data["phases"][0].update(q_min=[0.0], q_max=[0.6], target_q=[0.4], tau_max=[20.0], intervals=250)
    data["final"]["q"] = [0.3]
    task = parse_task(data)
    assert task.model.mass == 4.2 and task.phases[0].target_q == [0.4] and task.initial.qd == [0.4]
    # the limits themselves
    limits = copy.deepcopy(TASK_PRESETS["head-headrest-2phase"])
    limits["model"].update(gravity=0.0, theta_min=-math.pi / 2, theta_max=math.pi / 2, tilt=-math.pi / 2)
    limits["model"].update(mass=20.0, com_distance=0.5, inertia_joint=5.0, torque_limit=200.0)
    limits["phases"][0].update(duration=60.0, intervals=20000, w_tau=1e6, w_T=0.0, tau_max=[200.0])
    limits["initial"] = {"q": [math.pi / 2], "qd": [-100.0]}
    parse_task(limits)
    adjusted = task_preset("head-headrest-2phase").model_dump(mode="json")
    adjusted["initial"]["q"] = [round(DEFAULT_PRESET.theta0 - 0.05, 6)]
    assert parse_task(adjusted).initial.q == [0.182]


def test_the_schema_states_units_and_ranges():
    """What the web form shows: every number of a task has its unit and range in its description."""
    schema = TaskSpec.model_json_schema()
    model = schema["$defs"]["ModelSpec"]["properties"]
    assert model["gravity"]["description"].startswith("gravitational acceleration [m/s^2], 0 to 100 m/s^2")
    assert (model["gravity"]["minimum"], model["gravity"]["maximum"]) == (0, 100)
    phase = schema["$defs"]["PhaseSpec"]["properties"]
    assert phase["duration"]["description"].startswith("phase duration [s], above 0, at most 60 s")
    assert phase["intervals"]["type"] == "integer" and phase["intervals"]["maximum"] == 20000
    q_min = phase["q_min"]["anyOf"][0]["items"]
    assert q_min["maximum"] == pytest.approx(math.pi / 2) and "[rad]" in q_min["description"]
