"""Task definitions: the preset, resolution into the discrete problem, and bad input."""

import copy
import json

import numpy as np
import pytest

from alcove.science.geometry import DEFAULT_PRESET
from alcove.science.ocp.task_spec import TASK_PRESETS, TaskSpecError, parse_task, task_preset


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
        (lambda d: d["phases"][0].update(q_min=[0.3], q_max=[0.2]), "phases.0.q_min", "below q_max"),
        (lambda d: d["phases"][0].update(q_max=[0.6]), "phases.0.q_max", "outside the model's joint range"),
        (lambda d: d["phases"][1].update(tau_max=[40.0]), "phases.1.tau_max", "torque_limit"),
        (lambda d: d["phases"][0].update(q_min=[0.3]), "initial.q", "outside the joint range of the first phase"),
        (lambda d: d.update(initial={"q": [0.5]}), "initial.q", "outside"),
        (lambda d: d.update(initial={"q": [0.2, 0.1]}), "initial.q", "expected 1 value"),
        (lambda d: d["model"].update(theta0=0.0), "model.theta0", "outside the joint range"),
        (lambda d: d["model"].update(theta_min=0.5), "model.theta_max", "must exceed theta_min"),
        (lambda d: d["model"].update(mass=0.0), "model.mass", "greater than 0"),
        (lambda d: d["phases"][0].update(target_q=[0.5]), "phases.0.target_q", "outside the phase bounds"),
        (lambda d: d.update(final={"q": [0.01]}), "final.q", "outside"),
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
