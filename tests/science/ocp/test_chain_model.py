"""Chain models in a task: validation with field paths, presets, the NumPy checks against the
CasADi chain, and OCPs on n-joint chains with the aux contact fed by the head's pose."""

import copy
import json

import numpy as np
import pytest

from alcove.science.geometry import DEFAULT_PRESET, signed_gap
from alcove.science.ocp.chain_model import CHAIN_PRESETS, ChainSpec, chain_preset
from alcove.science.ocp.contact import aux_contact, chain_aux_contact, contact_from_spec
from alcove.science.ocp.solve import solve_task
from alcove.science.ocp.task_spec import ONE_DOF_FIELDS, TASK_PRESETS, TaskSpecError, parse_task

PHASES = copy.deepcopy(TASK_PRESETS["head-headrest-2phase"]["phases"])


def chain_task(model: dict, **extra) -> dict:
    return {
        "name": "chain-task",
        "model": model,
        "phases": copy.deepcopy(PHASES),
        "final": {"velocity": "rest"},
        **extra,
    }


def one_dof_as_chain() -> dict:
    """The paper's 1-DOF preset written as a user-defined one-link chain."""
    p = DEFAULT_PRESET
    o = p.headrest_origin
    return {
        "preset": "chain",
        "chain": {
            "links": [{"name": "head", "mass": p.mass, "com": [0.0, p.com_distance], "inertia_com": p.inertia_com}],
            "joints": [
                {
                    "name": "C7/T1",
                    "q_min": p.theta_min,
                    "q_max": p.theta_max,
                    "q0": p.theta0,
                    "torque_limit": p.torque_limit,
                }
            ],
            "gravity": p.gravity,
            "headrest": {"tilt": p.tilt, "origin": [float(o[0]), float(o[1])]},
        },
    }


def bad(model: dict, **extra) -> TaskSpecError:
    with pytest.raises(TaskSpecError) as info:
        parse_task(chain_task(model, **extra))
    return info.value


# ---- validation ---------------------------------------------------------------------------
def two_dof_with(path: str, value: object) -> dict:
    """The 2-DOF preset's chain with ``chain.<path>`` set (dotted, list indices as numbers)."""
    chain = chain_preset("head-neck-2dof")
    keys = [int(k) if k.isdigit() else k for k in path.split(".")]
    node = chain
    for key in keys[:-1]:
        node = node[key]
    node[keys[-1]] = value
    return {"preset": "chain", "chain": chain}


@pytest.mark.parametrize(
    ("path", "value", "field", "reason"),
    [
        ("links.0.mass", -1.0, "model.chain.links.0.mass", "greater than 0"),
        ("links.1.inertia_com", -0.01, "model.chain.links.1.inertia_com", "greater than or equal to 0"),
        ("joints.1.q0", 0.5, "model.chain.joints.1.q0", "outside the joint range"),
        ("joints.0.q_max", -0.8, "model.chain.joints.0.q_max", "must exceed q_min"),
        ("joints.0.torque_limit", 500.0, "model.chain.joints.0.torque_limit", "less than or equal to 200"),
        ("joints.1.damping", -1.0, "model.chain.joints.1.damping", "greater than or equal to 0"),
        ("contact_body.link", 2, "model.chain.contact_body.link", "must be a link index 0..1"),
        ("headrest.touch_q", [0.31], "model.chain.headrest.touch_q", "expected 2 value(s)"),
        ("headrest.touch_q", [0.31, 0.5], "model.chain.headrest.touch_q.1", "outside the joint range"),
        ("headrest.origin", [0.0, 0.2], "model.chain.headrest", "exactly one of origin and touch_q"),
        # the headrest touches the head at the start pose tilted back less than it starts
        ("headrest.touch_q", [0.1, 0.0], "model.chain.joints", "starts inside the cushion"),
        ("joints", chain_preset("head-neck-2dof")["joints"][:1], "model.chain.joints", "expected 2 joints"),
        ("links", [chain_preset("head-neck-2dof")["links"][0]] * 7, "model.chain.links", "at most 6"),
        ("links.0.speed", 3, "model.chain.links.0.speed", "Extra inputs"),
    ],
)
def test_bad_chains_name_the_field(path, value, field, reason):
    err = bad(two_dof_with(path, value))
    assert err.field == field, err
    assert reason in err.reason, err


def test_task_level_checks_use_the_chains_joints():
    """Initial pose, phase bounds and torque bounds are checked per joint against the chain."""
    model = {"preset": "head-neck-2dof"}
    err = bad(model, initial={"q": [0.232]})
    assert (err.field, "expected 2 value(s)" in err.reason) == ("initial.q", True)
    err = bad(model, initial={"q": [0.5, 0.0]})
    assert err.field == "initial.q" and "inside the cushion" in err.reason
    phases = copy.deepcopy(PHASES)
    phases[0]["tau_max"] = [20.0, 40.0]
    with pytest.raises(TaskSpecError, match=r"^phases.0.tau_max.1: 40 N m exceeds the model's torque_limit 30 N m"):
        parse_task({**chain_task(model), "phases": phases})
    err = bad({"preset": "head-neck-2dof", "mass": 4.0})
    assert err.field == "model.mass" and "edit model.chain" in err.reason
    assert bad({"preset": "chain"}).field == "model.chain"
    assert bad({"preset": "head-neck-1dof", "chain": chain_preset("head-neck-2dof")}).field == "model.chain"


def test_presets_fill_in_what_is_not_given_and_round_trip():
    task = parse_task(chain_task({"preset": "head-neck-2dof", "chain": {"gravity": 0.0}}))
    assert task.model.chain.gravity == 0.0
    assert task.model.chain.links == parse_task(chain_task({"preset": "head-neck-2dof"})).model.chain.links
    dumped = task.model_dump(mode="json")
    assert not set(ONE_DOF_FIELDS) & set(dumped["model"])  # the 1-DOF parameters do not apply
    assert parse_task(json.loads(json.dumps(dumped))) == task
    # a 1-DOF task dumps exactly as before chains existed (stored task versions stay equal)
    one = parse_task(TASK_PRESETS["head-headrest-2phase"]).model_dump(mode="json")
    assert "chain" not in one["model"] and set(one["model"]) == {"preset", *ONE_DOF_FIELDS}
    for name in CHAIN_PRESETS:
        model = parse_task(chain_task({"preset": name})).model
        assert model.ndof == len(CHAIN_PRESETS[name]["links"])


def test_the_1dof_parameters_of_a_chain_are_refused_and_its_oracles_get_its_head():
    task = parse_task(chain_task({"preset": "head-neck-2dof"}))
    with pytest.raises(TaskSpecError, match=r"^model.preset: 'head-neck-2dof' is a chain model"):
        task.preset()
    head = task.model.oracle_preset()  # what an oracle reads besides the pose: the profile and the tilt
    assert head.profile == task.model.chain.contact_body.profile.to_profile()
    assert head.tilt == task.model.chain.headrest.tilt


# ---- the NumPy kinematics of validation against the CasADi chain --------------------------------
@pytest.mark.parametrize("name", sorted(CHAIN_PRESETS))
def test_validation_kinematics_agree_with_the_casadi_chain(name):
    """head_pose_world / head_gap (NumPy, no CasADi at validation) against the PlanarChain's pose
    in H and the closed-form gap of the profile ellipse, to 1e-12; the headrest passes through
    the profile at touch_q (gap 0 to 1e-12)."""
    spec = ChainSpec.model_validate(chain_preset(name))
    chain = spec.to_chain()
    rng = np.random.default_rng(0)
    pr = spec.contact_body.profile
    for q in rng.uniform(spec.q_min, spec.q_max, (10, spec.ndof)):
        pos, phi = spec.head_pose_world(q)
        cpos, cphi = chain.contact_pose_world(q)
        np.testing.assert_allclose(pos, np.asarray(cpos).ravel(), atol=1e-12)
        assert phi == pytest.approx(float(cphi), abs=1e-12)
        kin = chain.relative_kinematics(q, np.zeros(spec.ndof))
        a = kin.angle[0]
        gap = kin.r_rel[0, 0] + np.cos(a) * pr.cx - np.sin(a) * pr.cz - np.hypot(pr.ax * np.cos(a), pr.az * np.sin(a))
        assert spec.head_gap(q) == pytest.approx(gap, abs=1e-12)
        # brute force over the profile: the smallest x_H of 20001 profile points
        s = np.linspace(0, 2 * np.pi, 20001)
        pts = np.stack([pr.cx + pr.ax * np.cos(s), np.zeros_like(s), pr.cz + pr.az * np.sin(s)], -1)
        assert spec.head_gap(q) == pytest.approx((kin.r_rel[0] + pts @ kin.T_rel[0].T)[:, 0].min(), abs=1e-8)
    assert abs(spec.head_gap(np.asarray(spec.headrest.touch_q))) < 1e-12
    assert spec.head_gap(spec.q0) > 0


def test_one_link_chain_is_the_one_dof_preset():
    """The 1-DOF preset written as a chain: the same gap function and the same relative kinematics."""
    spec = parse_task(chain_task(one_dof_as_chain())).model.chain
    theta = np.linspace(DEFAULT_PRESET.theta_min, DEFAULT_PRESET.theta_max, 7)
    np.testing.assert_allclose([spec.head_gap([t]) for t in theta], signed_gap(DEFAULT_PRESET, theta), atol=1e-15)


# ---- OCPs ------------------------------------------------------------------------------------
def test_the_one_dof_preset_and_the_same_model_as_a_chain_give_the_same_ocp_solution():
    """The paper's task solved through the preset (the code path of every 1-DOF number) and through
    the generic chain path (ChainSpec -> PlanarChain, chain_aux_contact): the same optimum to the
    solver's tolerance (IPOPT tol 1e-8: states to 1e-6 rad, cost to 1e-6 relative)."""
    preset_task = parse_task(TASK_PRESETS["head-headrest-2phase"])
    chain_task_ = parse_task(chain_task(one_dof_as_chain()))
    ref = solve_task(preset_task, aux_contact(preset_task.preset()))
    got = solve_task(chain_task_, chain_aux_contact(chain_task_.chain()))
    assert ref.converged and got.converged
    assert got.cost == pytest.approx(ref.cost, rel=1e-6)
    np.testing.assert_allclose(got.q, ref.q, atol=1e-6)
    np.testing.assert_allclose(got.controls, ref.controls, atol=1e-4 * np.abs(ref.controls).max())
    # and contact_from_spec picks the chain's aux model for a chain
    assert contact_from_spec("aux", chain_task_.chain()).n_in() == 2
    with pytest.raises(ValueError, match=r"^contact: model file 'x\.pt' does not exist"):  # surrogates too
        contact_from_spec("model:x.pt", chain_task_.chain())


@pytest.mark.parametrize("name", sorted(CHAIN_PRESETS))
def test_the_papers_task_on_a_chain_preset_solves_and_rests_on_the_headrest(name):
    """The paper's two-phase task on the n-DOF presets with the aux contact fed by the head's
    pose: IPOPT converges; the head is clear of the cushion at the start, penetrates it at the
    end (the aux contact point, 0.5-5 mm) and rests there in static equilibrium:
    tau + g(q) + J^T w(q, 0) = 0 at the last node to 1e-3 N m (a few hundred ms per solve)."""
    task = parse_task(chain_task({"preset": name}))
    chain = task.chain()
    aux = chain_aux_contact(chain)
    sol = solve_task(task, aux)
    assert sol.converged, sol.status
    kin = sol.head_pose()
    back = chain.profile.back_point()
    arm = kin.T_rel @ np.array([back[0], 0.0, back[1]])
    penetration = -(kin.r_rel[:, 0] + arm[:, 0])
    assert penetration[0] < 0
    assert 0.5e-3 < penetration[-1] < 5e-3, penetration[-1]
    np.testing.assert_allclose(sol.qd[-1], 0.0, atol=1e-9)
    q_end = sol.q[-1]
    wrench = np.asarray(aux(q_end, np.zeros(chain.ndof))).ravel()
    assert wrench[0] > 1.0  # the cushion pushes the head out
    balance = sol.controls[-1] + np.asarray(chain.gravity_force(q_end)).ravel()
    balance += chain.generalized_contact_force(q_end, wrench)[0]
    np.testing.assert_allclose(balance, 0.0, atol=1e-3)


def test_one_dof_defaults_sent_along_by_a_form_are_not_an_error_with_a_chain_preset():
    assert parse_task(chain_task({"preset": "head-neck-2dof", "mass": DEFAULT_PRESET.mass})).model.ndof == 2


@pytest.mark.parametrize(
    ("path", "value", "field"),
    [
        ("links.0.mass", -1.0, "spec.model.chain.links.0.mass"),
        ("links.1.inertia_com", -0.01, "spec.model.chain.links.1.inertia_com"),
        ("joints.1.q0", 0.5, "spec.model.chain.joints.1.q0"),
        ("headrest.touch_q", [0.1, 0.0], "spec.model.chain.joints"),
    ],
)
def test_the_api_reports_the_same_chain_field(path, value, field):
    """The API's field errors (alcove.errors) carry the same path, under 'spec'."""
    from pydantic import ValidationError

    from alcove.errors import field_errors_from_pydantic
    from alcove.science.ocp.task_spec import TaskSpec

    with pytest.raises(ValidationError) as info:
        TaskSpec.model_validate(chain_task(two_dof_with(path, value)))
    (first, *_) = field_errors_from_pydantic(info.value, base=("spec",))
    assert first.field == field
