"""Where a surrogate's OCP solution is trusted: the signed gap, the diagnostics, the trust region.

The ghost-force case (tests/ghost_case.py) is the issue's failure: an ensemble whose mean
holds the head at rest in mid-air. The unconstrained OCP finds that hovering rest and is
flagged; with the trust region (ensemble force std <= 5 N along the solution) the rest is in
contact per geometry.
"""

import math

import numpy as np
import pytest

from alcove.science.geometry import DEFAULT_PRESET as P
from alcove.science.geometry import head_pose_in_headrest, rot2, signed_gap, signed_gap_symbolic
from alcove.science.ocp.solve import solve_task
from alcove.science.ocp.task_spec import task_preset
from alcove.science.surrogate.export import surrogate_contact, surrogate_contact_std
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
    return task_preset("head-headrest-2phase").with_intervals(20)


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
    # the hovering rest: held in mid-air, the head clearly clear of the cushion
    assert signed_gap(P, rest).min() > th.gap_tolerance
    assert not report.trusted and report.reasons[0].startswith("ghost force")
    assert report.open_gap_max_force > 10 * th.open_gap_force_tolerance
    assert report.max_std > 10.0  # the members disagree where the ghost force holds the head
    # the pool's preliminary data cover the range: every solution point is near data
    assert report.max_pool_distance is not None and report.max_pool_distance < 0.5

    std_fn, _ = surrogate_contact_std(model, P)
    bound = 5.0  # N
    bounded = solve_task(task, fn, contact_params=p, path=(force_variance_function(std_fn), bound**2))
    assert bounded.converged
    curves = trust_curves(model, P, bounded.t, bounded.q)
    assert curves.force_std.max() <= bound * (1 + 1e-6)
    rest = bounded.q[-task.phases[-1].intervals :, 0]
    # at rest the head lies on the cushion (per geometry), or no force is predicted with the gap open
    rest_mid = curves.gap[-task.phases[-1].intervals :]
    open_force = np.linalg.norm(curves.force[-task.phases[-1].intervals :], axis=1)[rest_mid > th.gap_tolerance]
    assert signed_gap(P, rest).max() <= 0.0 or (open_force.size == 0 or open_force.max() < th.open_gap_force_tolerance)
    assert signed_gap(P, rest).max() <= 0.0  # in this case: in contact
