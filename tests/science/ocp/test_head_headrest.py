"""The paper's head-headrest task with the auxiliary contact, and the solver's contract."""

import json

import casadi as ca
import numpy as np
import pytest

from alcove.science.ocp.contact import aux_contact
from alcove.science.ocp.solve import OcpSolution, get_transcription, solve_task
from alcove.science.ocp.task_spec import task_preset
from alcove.science.oracles.aux_penalty import AuxPenaltyParams, contact_point
from alcove.science.series import SeriesFormatError, Trajectory


@pytest.fixture(scope="module")
def task():
    return task_preset("head-headrest-2phase")


@pytest.fixture(scope="module")
def aux(task):
    return aux_contact(task.preset())


@pytest.fixture(scope="module")
def solution(task, aux) -> OcpSolution:
    return solve_task(task, aux)


def contact_point_gap(task, sol: OcpSolution) -> np.ndarray:
    """Signed distance of the aux contact point from the cushion surface along x_H (< 0: penetrating)."""
    kin = sol.head_pose()
    arm = kin.T_rel @ contact_point(task.preset(), AuxPenaltyParams())
    return kin.r_rel[:, 0] + arm[:, 0]


def test_head_reaches_the_headrest_and_rests_there(task, solution):
    sol, p = solution, task.preset()
    assert sol.converged and sol.status == "Solve_Succeeded"
    assert sol.constraint_violation < 1e-6
    t, q, qd, tau = sol.t, sol.q[:, 0], sol.qd[:, 0], sol.tau[:, 0]
    gap = contact_point_gap(task, sol)
    assert gap[0] > 0.005  # starts clear of the headrest
    first_contact = t[np.argmax(gap < 0)]
    assert 0 < first_contact < 1.0  # reaches the headrest within phase 1
    assert np.all(gap[t >= 1.0] < 0)  # and stays on it
    late = t >= 1.2
    assert np.abs(tau[late]).max() <= 0.05  # rests without actuation
    assert np.abs(qd[late]).max() < 1e-2
    assert abs(qd[-1]) < 1e-8 and abs(qd[0]) < 1e-8  # at rest at t = 0 and t = 2 s
    assert q[-1] > p.theta_contact
    assert np.abs(sol.controls).max() <= p.torque_limit
    assert np.abs(sol.controls).max() < 3.0  # within a few N m, as in the paper's figure
    assert p.theta_min - 1e-9 <= q.min() and q.max() <= p.theta_max + 1e-9
    assert np.abs(q - p.theta0).max() < 0.2  # like the paper: within about 0.15 rad of the start


def test_final_rest_is_a_static_equilibrium_on_the_cushion(task, aux, solution):
    """At t = 2 s with tau ~ 0 the contact carries the gravity moment m g d sin(theta)."""
    chain = solution.chain
    q_end = solution.q[-1]
    Qc = float(ca.mtimes(chain.contact_jacobian(q_end).T, aux(q_end, 0)))
    g = float(chain.gravity_force(q_end))
    p = task.preset()
    assert g == pytest.approx(p.mass * p.gravity * p.com_distance * np.sin(q_end[0]), rel=1e-9)  # toward the headrest
    assert q_end[0] > p.theta_contact  # resting on the compressed cushion, beyond first contact
    assert Qc == pytest.approx(-g, abs=0.01)


def test_resampling_for_the_oracle_and_head_pose(solution):
    t1 = np.linspace(0.0, 1.0, 401)  # dt = 0.0025 s over phase 1
    tr = solution.resample(t1)
    assert len(tr) == 401 and tr.tau is not None
    on_grid = np.isin(np.round(t1, 9), np.round(solution.t, 9))
    np.testing.assert_allclose(tr.q[on_grid], solution.q[:101], atol=1e-12)
    np.testing.assert_allclose(tr.qd[on_grid], solution.qd[:101], atol=1e-12)
    # between the nodes the Hermite interpolant tracks the discrete motion to O(h^2)
    mid = solution.resample(0.5 * (solution.t[:-1] + solution.t[1:]))
    assert np.abs(mid.q[:, 0] - 0.5 * (solution.q[:-1, 0] + solution.q[1:, 0])).max() < 1e-3
    pose = solution.head_pose(t1)
    assert pose.r_rel.shape == (401, 3) and pose.T_rel.shape == (401, 3, 3)
    with pytest.raises(SeriesFormatError, match=r"^t: "):
        solution.resample(np.array([0.0, 2.5]))
    json.dumps(solution.summary())


def test_the_cost_scaling_changes_the_path_not_the_optimum(task, aux, solution):
    """IPOPT's objective scaling (100 by default, DEFAULT_IPOPT_OPTIONS) changes the iterates, not the
    KKT point: the unscaled solve reaches the same optimum. Thresholds: the cost to 1e-6 relative
    (IPOPT's tol 1e-8 on residuals of order 1), the joint angles to 1e-4 rad."""
    unscaled = solve_task(task, aux, ipopt_options={"ipopt.obj_scaling_factor": 1.0})
    assert solution.converged and unscaled.converged
    assert abs(unscaled.cost - solution.cost) <= 1e-6 * abs(unscaled.cost)
    assert float(np.abs(unscaled.q - solution.q).max()) <= 1e-4


def test_warm_start_from_a_previous_solution(task, aux, solution):
    again = solve_task(task, aux, initial_guess=solution)
    assert again.converged and again.attempts[0]["guess"] == "previous"
    assert again.iterations <= solution.iterations
    assert again.cost == pytest.approx(solution.cost, rel=1e-4)
    # a previous solution on another grid is interpolated
    coarse = solve_task(task.with_intervals(50), aux, initial_guess=solution)
    assert coarse.converged and coarse.q.shape == (101, 1)


def test_failed_solve_is_reported_not_hidden(task, aux):
    sol = solve_task(task.with_intervals(40), aux, max_attempts=2, ipopt_options={"ipopt.max_iter": 2})
    assert not sol.converged
    assert sol.status == "Maximum_Iterations_Exceeded"
    assert [a["guess"] for a in sol.attempts] == ["passive", "ramp"]  # bounded retries
    assert sol.iterations == 4
    assert sol.summary()["converged"] is False


def test_slot_with_a_parametric_and_a_hand_made_contact(task, aux):
    """A contact with parameters reuses one transcription; an MX function is expanded."""
    small = task.with_intervals(50)
    q, qd, p = ca.SX.sym("q"), ca.SX.sym("qd"), ca.SX.sym("p")
    scaled = ca.Function("scaled", [q, qd, p], [p * aux(q, qd)])
    reference = solve_task(small, aux)
    same = solve_task(small, scaled, contact_params=np.array([1.0]))
    assert same.converged and same.cost == pytest.approx(reference.cost, rel=1e-6)
    stiffer = solve_task(small, scaled, contact_params=np.array([3.0]))
    assert stiffer.converged and stiffer.q.max() < same.q.max()  # a stiffer cushion stops the head earlier
    assert get_transcription(small, scaled) is get_transcription(small, scaled)
    with pytest.raises(ValueError, match=r"^contact_params"):
        solve_task(small, scaled)
    with pytest.raises(ValueError, match=r"^contact_params: the contact function takes 1 parameter"):
        solve_task(small, scaled, contact_params=np.array([1.0, 2.0]))
    with pytest.raises(ValueError, match=r"^contact_params: the contact function takes 0 parameter"):
        solve_task(small, aux, contact_params=np.array([1.0]))
    with pytest.raises(ValueError, match=r"^contact_params: values must be finite"):
        solve_task(small, scaled, contact_params=np.array([np.nan]))
    # a hand-made MX contact: a linear torsional cushion beyond theta = 0.31 acting as a normal force
    qm, qdm = ca.MX.sym("q"), ca.MX.sym("qd")
    push = 400.0 * ca.log1p(ca.exp((qm - 0.31) / 0.002)) * 0.002 + 5.0 * qdm * (qm > 0.31)
    hand = ca.Function("hand", [qm, qdm], [ca.vertcat(push, 0, 0, 0, 0, 0)])
    sol = solve_task(small, hand)
    assert sol.converged and sol.q.max() > 0.31


def test_warm_start_survives_json_and_accepts_a_stored_trajectory(task, aux, solution):
    """The campaign keeps solutions between jobs: to_dict/from_dict through JSON keep the
    primal-dual warm start; a bare trajectory (e.g. read from CSV) is a primal guess."""
    data = json.loads(json.dumps(solution.to_dict()))
    restored = OcpSolution.from_dict(data, task.chain())
    np.testing.assert_array_equal(restored.q, solution.q)
    again = solve_task(task, aux, initial_guess=restored)
    assert again.converged and again.attempts[0]["guess"] == "previous"
    assert again.iterations <= 3  # started at the optimum with its multipliers
    from_csv = solve_task(task, aux, initial_guess=solution.trajectory.window(0.0, 2.0))
    assert from_csv.converged and from_csv.attempts[0]["guess"] == "previous"
    assert from_csv.cost == pytest.approx(solution.cost, rel=1e-3)
    no_torques = Trajectory(solution.t, solution.q, solution.qd)  # e.g. an oracle-side file
    assert solve_task(task, aux, initial_guess=no_torques).converged


def test_resampling_stays_within_the_joint_range(task):
    """Without contact the head tips back onto the lower joint limit; between nodes on the
    limit the interpolant must not leave the range."""
    sol = solve_task(task.with_intervals(40), None)
    p = task.preset()
    assert sol.converged and np.isclose(sol.q.min(), p.theta_min, atol=1e-8)
    fine = sol.resample(np.linspace(0, 2, 2001))
    assert fine.q.min() >= p.theta_min and fine.q.max() <= p.theta_max


def test_task_level_targets_bounds_and_free_end(task, aux):
    """Phase target pose, tighter phase bounds and torque limit, free final velocity with an
    endpoint cost: all reach the NLP and hold in the solution."""
    data = task.model_dump()
    for ph in data["phases"]:
        ph["intervals"] = 30
    data["phases"][0].update(target_q=[0.30], tau_max=[2.0])
    data["phases"][1].update(q_max=[0.40])
    data["final"] = {"velocity": "free"}
    data["endpoint_cost"] = {"w_q": 10.0, "q_ref": [0.38], "w_qd": 0.1}
    from alcove.science.ocp.task_spec import parse_task

    sol = solve_task(parse_task(data), aux)
    data["endpoint_cost"] = None
    without = solve_task(parse_task(data), aux)
    assert sol.converged and without.converged
    assert sol.q[30, 0] == pytest.approx(0.30, abs=1e-9)  # target at the end of phase 1
    assert np.abs(sol.controls[:30]).max() <= 2.0
    assert sol.q[30:, 0].max() <= 0.40
    assert sol.q[-1, 0] > without.q[-1, 0] + 1e-3  # the endpoint cost pulls toward 0.38, into the cushion
