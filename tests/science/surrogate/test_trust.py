"""Where a surrogate's OCP solution is trusted: the signed gap, the diagnostics, the trust region.

The ghost-force case (tests/ghost_case.py) is the issue's failure: an ensemble whose mean
holds the head at rest in mid-air. The unconstrained OCP finds that hovering rest and is
flagged; with the trust region (ensemble force std <= 2 N along the solution) the rest is no
longer held by a ghost force. The task starts the head at 0.06 rad, 17 mm clear, before the
band where the members disagree: the preset's start (theta0 = 0.232 rad, 5.4 mm clear) lies
inside that band, where no trust region below the start's own std is feasible (IPOPT says
so at 50 intervals per phase; at 20 the first interval's midpoint can jump out of the band).
"""

import math

import numpy as np
import pytest

from alcove.science.geometry import DEFAULT_PRESET as P
from alcove.science.geometry import head_pose_in_headrest, rot2, signed_gap, signed_gap_symbolic
from alcove.science.ocp.solve import solve_task
from alcove.science.ocp.task_spec import TASK_PRESETS, parse_task
from alcove.science.surrogate.casadi_contact import surrogate_contact, surrogate_contact_std
from alcove.science.surrogate.training import pool_features, preset_kinematics
from alcove.science.surrogate.trust import (
    TrustCurves,
    TrustThresholds,
    assess_curves,
    assess_solution,
    force_variance_function,
    trust_curves,
)


def test_signed_gap_is_the_smallest_normal_distance_of_the_profile():
    """Closed form against a dense sampling of the whole ellipse (error of the sampling <= 1e-7 m)."""
    for theta in np.linspace(P.theta_min, P.theta_max, 13):
        r, a = head_pose_in_headrest(P, theta)
        pts = P.profile.points(20000, (0.0, 2 * math.pi))
        x_h = r[0, 0] + (pts @ rot2(a[0]).T)[:, 0]
        assert abs(x_h.min() - signed_gap(P, theta)[0]) < 1e-7
    # first contact at theta_contact (tilt = theta_contact), clear before, penetrating after
    assert abs(signed_gap(P, P.theta_contact)[0]) < 1e-12
    assert signed_gap(P, P.theta_contact - 0.05)[0] > 0 > signed_gap(P, P.theta_contact + 0.05)[0]


def test_signed_gap_symbolic_matches_numpy():
    import casadi as ca

    th = ca.SX.sym("th")
    fn = ca.Function("gap", [th], [signed_gap_symbolic(P, th)])
    for theta in (0.05, 0.2, 0.31, 0.4):
        assert abs(float(fn(theta)) - signed_gap(P, theta)[0]) < 1e-15


def _curves(gap, force, std):
    n = len(gap)
    f = np.zeros((n, 3))
    f[:, 0] = force
    return TrustCurves(np.linspace(0, 1, n), np.zeros(n), np.asarray(gap, float), f, np.asarray(std, float), None)


def test_assessment_flags_ghost_force_and_disagreement_in_contact():
    th = TrustThresholds(gap_tolerance=0.002, open_gap_force_tolerance=1.0, contact_std_threshold=10.0)
    honest = assess_curves(_curves([0.01, 0.005, 0.0, -0.003], [0.0, 0.5, 20.0, 90.0], [0, 0, 1, 2]), 4, th)
    assert honest.trusted and honest.reasons == []
    assert honest.open_gap_max_force == 0.5 and honest.max_std_contact == 2.0
    ghost = assess_curves(_curves([0.016, 0.016, -0.001], [3.16, 3.0, 10.0], [0, 0, 0]), 4, th)
    assert not ghost.trusted and "ghost force" in ghost.reasons[0] and "16 mm" in ghost.reasons[0]
    assert ghost.open_gap_max_force == 3.16 and ghost.open_gap_at_gap == 0.016
    unsure = assess_curves(_curves([0.01, -0.001, -0.004], [0.0, 10.0, 50.0], [0.0, 3.0, 12.0]), 4, th)
    assert not unsure.trusted and "12 N" in unsure.reasons[0]
    # the integral over the contact phase: trapezoid-free sum of std * dt on the contact midpoints
    assert unsure.integral_std_contact == pytest.approx((3.0 + 12.0) * 0.5)


@pytest.fixture(scope="module")
def task():
    data = {**TASK_PRESETS["head-headrest-2phase"], "initial": {"q": [0.06], "qd": None}}
    return parse_task(data).with_intervals(20)


@pytest.mark.slow
def test_ghost_force_is_flagged_and_the_trust_region_removes_the_hovering_rest(ghost_case, task):
    model, pool = ghost_case
    th = TrustThresholds()
    fn, p = surrogate_contact(model, P)
    free = solve_task(task, fn, contact_params=p)
    assert free.converged
    x_pool = pool_features(pool, preset_kinematics(P))
    report = assess_solution(model, P, free.t, free.q, x_pool, th)
    rest = free.q[-task.phases[-1].intervals :, 0]
    # the hovering rest: held in mid-air, the head clearly clear of the cushion, by the ghost
    # force alone (|tau| < 5 % of the gravity moment m g d sin(theta) over the settled half)
    assert signed_gap(P, rest).min() > th.gap_tolerance
    half = task.phases[-1].intervals // 2
    settled_q = 0.5 * (free.q[-half - 1 : -1, 0] + free.q[-half:, 0])
    held = np.abs(free.controls[-half:, 0]) / (P.mass * P.gravity * P.com_distance * np.sin(settled_q))
    assert held.max() < 0.05
    assert not report.trusted and report.reasons[0].startswith("ghost force")
    assert report.open_gap_max_force > 10 * th.open_gap_force_tolerance
    assert report.max_std > 10.0  # the members disagree where the ghost force holds the head
    # the pool's preliminary data cover the range: every solution point is near data
    assert report.max_pool_distance is not None and report.max_pool_distance < 0.5

    std_fn, _ = surrogate_contact_std(model, P)
    bound = 2.0  # N
    bounded = solve_task(task, fn, contact_params=p, path=(force_variance_function(std_fn), bound**2))
    assert bounded.converged
    curves = trust_curves(model, P, bounded.t, bounded.q)
    assert curves.force_std.max() <= bound * (1 + 1e-6)
    n_rest = task.phases[-1].intervals
    rest_gap, rest_force = curves.gap[-n_rest:], np.linalg.norm(curves.force[-n_rest:], axis=1)
    # at rest the head lies on the cushion (per geometry), or no force is predicted with the gap open
    open_rest = rest_gap > th.gap_tolerance
    assert np.all(~open_rest | (rest_force < th.open_gap_force_tolerance))
    # in this case it rests clear of the cushion, held by the actuator: over the second half of
    # the rest phase (settled) the torque carries the gravity moment, |tau| >= 0.9 m g d sin(theta)
    assert np.all(open_rest)
    rest_q, rest_tau = curves.q[-n_rest // 2 :], bounded.controls[-n_rest // 2 :, 0]
    gravity = P.mass * P.gravity * P.com_distance * np.sin(rest_q)
    assert np.all(np.abs(rest_tau) >= 0.9 * gravity)
