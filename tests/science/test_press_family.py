"""The press family with history (alcove.science.press_family) against hand-computed motions."""

import re

import numpy as np
import pytest

from alcove.science.geometry import DEFAULT_PRESET as P
from alcove.science.press_family import PARAMETERS, HistoryPress, PressFamily, family_motions
from alcove.science.validation_suite import PressMotion, press_trajectory

THETA = (P.theta_min, P.theta_max)


def test_a_full_release_is_the_suites_simple_press():
    """release 1 (no re-load): the validation suite's press of the same four numbers, to float rounding."""
    m = HistoryPress(start=0.2, depth=0.4, speed=0.9, dwell=0.13)
    assert m.waypoints() == [0.2, 0.4, 0.2]
    ours, suite = m.trajectory(0.0025), press_trajectory(PressMotion(0.2, 0.4, 0.9, 0.13), 0.0025)
    np.testing.assert_array_equal(ours.t, suite.t)
    np.testing.assert_allclose(ours.q, suite.q, rtol=0, atol=1e-15)  # threshold: float rounding of 0.4 rad
    np.testing.assert_allclose(ours.qd, suite.qd, rtol=0, atol=1e-15)


def test_a_history_passes_its_waypoints_at_rest_and_holds_each_dwell():
    """start 0.2, depth 0.4; release 0.5 gives back 0.1 rad to 0.3; reload 0.5 goes half way back to 0.35;
    then home. Segment times 15 D / (8 speed) with speed 0.5 rad/s: 0.75, 0.375, 0.1875, 0.5625 s."""
    m = HistoryPress(start=0.2, depth=0.4, speed=0.5, dwell=0.1, release=0.5, reload=0.5)
    assert m.waypoints() == pytest.approx([0.2, 0.4, 0.3, 0.35, 0.2], abs=1e-15)
    assert m.segment_times() == pytest.approx([0.75, 0.375, 0.1875, 0.5625], rel=1e-14)
    assert m.duration == pytest.approx(0.75 + 0.375 + 0.1875 + 0.5625 + 3 * 0.1, rel=1e-14)
    tr = m.trajectory(1 / 8000)  # every turning point on the grid
    ends = np.cumsum([0.75, 0.1 + 0.375, 0.1 + 0.1875, 0.1 + 0.5625])
    for end, angle in zip(ends, [0.4, 0.3, 0.35, 0.2], strict=True):
        i = np.argmin(np.abs(tr.t - end))
        assert abs(tr.t[i] - end) < 1e-9
        assert tr.q[i, 0] == pytest.approx(angle, abs=1e-12) and abs(tr.qd[i, 0]) < 1e-12
    # the holds: the angle stays at the turning point for dwell seconds
    hold = (tr.t > 0.75 + 1e-9) & (tr.t < 0.85 - 1e-9)
    assert np.all(np.abs(tr.q[hold, 0] - 0.4) < 1e-12) and np.all(tr.qd[hold, 0] == 0)
    assert tr.q[0, 0] == 0.2 and tr.q[-1, 0] == pytest.approx(0.2, abs=1e-15) and tr.t[-1] == pytest.approx(m.duration)


def test_speed_is_the_largest_angular_velocity_and_qd_is_the_derivative_of_q():
    """Every segment peaks at ``speed`` at its middle; qd against a central difference of q converges
    at second order (the error falls 4x when dt halves, within 10 %)."""
    m = HistoryPress(start=0.18, depth=0.42, speed=1.2, dwell=0.05, release=0.7, reload=0.8)
    tr = m.trajectory(1e-4)
    assert np.max(np.abs(tr.qd)) == pytest.approx(1.2, rel=1e-6)  # threshold: sampling at dt = 1e-4 s
    errors = []
    for dt in (2e-3, 1e-3):
        fine = m.trajectory(dt)
        fd = (fine.q[2:, 0] - fine.q[:-2, 0]) / (fine.t[2:] - fine.t[:-2])
        errors.append(np.max(np.abs(fd - fine.qd[1:-1, 0])))
    assert 3.6 < errors[0] / errors[1] < 4.4


def test_the_family_is_a_seeded_latin_hypercube_over_its_box():
    family = PressFamily()
    motions = family_motions(family, 12, seed=3, theta_range=THETA)
    assert family_motions(family, 12, seed=3, theta_range=THETA) == motions  # reproducible from the seed
    assert family_motions(family, 12, seed=4, theta_range=THETA) != motions
    for name in PARAMETERS:
        lo, hi = getattr(family, name)
        values = np.array([getattr(m, name) for m in motions])
        strata = np.floor((values - lo) / (hi - lo) * 12).astype(int)
        assert sorted(strata.tolist()) == list(range(12)), name  # one motion in each of the 12 strata
    fixed = PressFamily(release=(1.0, 1.0), reload=(0.0, 0.0))
    assert all(m.waypoints()[1:] == [m.depth, m.start] for m in family_motions(fixed, 5, 0, THETA))


@pytest.mark.parametrize(
    ("family", "message"),
    [
        (PressFamily(depth=(0.34, 0.6)), "press family range depth: (0.34, 0.6) rad leaves the joint range"),
        (PressFamily(release=(0.5, 1.5)), "press family range release: (0.5, 1.5) leaves [0, 1]"),
        (PressFamily(speed=(2.0, 1.0)), "press family range speed: need finite lo <= hi"),
        (PressFamily(start=(0.15, 0.36)), "every start angle must lie below every peak angle"),
        (PressFamily(dwell=(float("nan"), 0.3)), "press family range dwell: need finite lo <= hi"),
    ],
)
def test_a_bad_box_names_its_range(family, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        family_motions(family, 4, seed=0, theta_range=THETA)


def test_a_bad_motion_names_its_parameter():
    with pytest.raises(ValueError, match="release must lie in"):
        HistoryPress(0.2, 0.4, 1.0, 0.0, release=1.2)
    with pytest.raises(ValueError, match=re.escape("depth 0.1 rad must lie beyond start 0.2 rad")):
        HistoryPress(0.2, 0.1, 1.0, 0.0)
    with pytest.raises(ValueError, match="dt must be a positive number"):
        HistoryPress(0.2, 0.4, 1.0, 0.0).trajectory(0.0)


@pytest.mark.parametrize("m", [2, 3, 4])
def test_every_power_of_two_prefix_of_the_sequence_holds_one_motion_per_stratum(m):
    """The first 2^m motions of the scrambled Sobol sequence: each parameter's range cut into 2^m
    equal strata holds exactly one of them (a (0, m, 1)-net in every coordinate)."""
    from alcove.science.press_family import PARAMETERS, sequence_motion

    family, n = PressFamily(), 2**m
    motions = [sequence_motion(family, 11, i, THETA) for i in range(n)]
    for name in PARAMETERS:
        lo, hi = getattr(family, name)
        x = np.array([getattr(mo, name) for mo in motions])
        assert sorted(np.floor((x - lo) / (hi - lo) * n).astype(int)) == list(range(n)), name
    # one motion at a time is the same sequence; another seed another one
    assert sequence_motion(family, 11, n - 1, THETA) == motions[-1]
    assert sequence_motion(family, 12, 0, THETA) != motions[0]


def test_a_campaign_continues_the_sequence_after_the_last_motion_it_used():
    from alcove.science.ocp.acquisition import family_motion_index

    assert [family_motion_index([], j) for j in range(3)] == [0, 1, 2]
    assert family_motion_index([0, 1, 2, 3], 0) == 4  # after a batch of 4, whatever the batch is now
    assert family_motion_index([0, 1], 2) == 4
