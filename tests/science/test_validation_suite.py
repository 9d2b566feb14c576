"""The held-out press motions: reproducible from the seed, inside the model's range, a Latin
hypercube over the ranges, and kinematically exact (rest at both ends, the stated peak angle
and top speed, the angular velocity the derivative of the angle)."""

from __future__ import annotations

import numpy as np
import pytest

from alcove.science.geometry import DEFAULT_PRESET
from alcove.science.validation_suite import (
    SuiteRanges,
    SuiteSpec,
    motion_parameters,
    press_trajectory,
    suite_trajectories,
)


def test_the_seed_fixes_the_motions_and_another_seed_changes_them() -> None:
    a = motion_parameters(SuiteSpec(seed=3), DEFAULT_PRESET)
    assert a == motion_parameters(SuiteSpec(seed=3), DEFAULT_PRESET)
    assert a != motion_parameters(SuiteSpec(seed=4), DEFAULT_PRESET)
    assert SuiteSpec(seed=3).digest(DEFAULT_PRESET) == SuiteSpec.from_dict(SuiteSpec(seed=3).to_dict()).digest(
        DEFAULT_PRESET
    )
    assert SuiteSpec(seed=3).digest(DEFAULT_PRESET) != SuiteSpec(seed=4).digest(DEFAULT_PRESET)


@pytest.mark.parametrize("m", [1, 8, 13])
def test_motions_are_a_latin_hypercube_inside_the_ranges(m: int) -> None:
    r = SuiteRanges()
    params = motion_parameters(SuiteSpec(motions=m, seed=1), DEFAULT_PRESET)
    assert len(params) == m
    for name in ("start", "depth", "speed", "dwell"):
        lo, hi = getattr(r, name)
        x = np.array([getattr(p, name) for p in params])
        assert np.all((x >= lo) & (x <= hi)), name
        strata = np.floor((x - lo) / (hi - lo) * m).clip(0, m - 1)
        assert sorted(strata) == list(range(m)), name  # each of the M strata holds one motion
    assert all(DEFAULT_PRESET.theta_min <= p.start < p.depth <= DEFAULT_PRESET.theta_max for p in params)


def test_a_press_motion_rests_at_both_ends_reaches_its_peak_angle_and_top_speed() -> None:
    for p in motion_parameters(SuiteSpec(), DEFAULT_PRESET):
        tr = press_trajectory(p, 0.0005)
        q, qd = tr.q[:, 0], tr.qd[:, 0]
        assert tr.t[-1] == pytest.approx(p.duration, abs=1e-12)
        assert q[0] == pytest.approx(p.start, abs=1e-12) and q[-1] == pytest.approx(p.start, abs=1e-12)
        assert qd[0] == pytest.approx(0, abs=1e-12) and qd[-1] == pytest.approx(0, abs=1e-9)
        assert q.max() == pytest.approx(p.depth, abs=1e-9)
        assert np.abs(qd).max() == pytest.approx(p.speed, rel=1e-4)  # 15/8 D / T at mid-blend
        # held at the peak for the dwell time; half way up at half the press time (the blend is symmetric)
        tp, t = p.press_time, tr.t
        assert np.allclose(q[(t >= tp) & (t <= tp + p.dwell)], p.depth, rtol=0, atol=1e-12)
        assert np.interp(tp / 2, t, q) == pytest.approx(0.5 * (p.start + p.depth), abs=1e-6)
        assert np.interp(tp + p.dwell + tp / 2, t, q) == pytest.approx(0.5 * (p.start + p.depth), abs=1e-6)


def test_the_angular_velocity_is_the_derivative_of_the_angle_second_order() -> None:
    p = motion_parameters(SuiteSpec(), DEFAULT_PRESET)[0]
    errors = []
    for dt in (2e-3, 1e-3, 5e-4):
        tr = press_trajectory(p, dt)
        central = (tr.q[2:, 0] - tr.q[:-2, 0]) / (tr.t[2:] - tr.t[:-2])
        errors.append(np.abs(central - tr.qd[1:-1, 0]).max())
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders > 1.8), (errors, orders)  # central differences converge at order 2 to qd


def test_bad_ranges_name_the_field() -> None:
    with pytest.raises(ValueError, match=r"depth.*joint range"):
        motion_parameters(SuiteSpec(ranges=SuiteRanges(depth=(0.34, 0.5))), DEFAULT_PRESET)
    with pytest.raises(ValueError, match="start angle"):
        motion_parameters(SuiteSpec(ranges=SuiteRanges(start=(0.15, 0.36))), DEFAULT_PRESET)
    with pytest.raises(ValueError, match="motions"):
        motion_parameters(SuiteSpec(motions=0), DEFAULT_PRESET)
    assert len(suite_trajectories(SuiteSpec(motions=2), DEFAULT_PRESET)) == 2


def test_a_suite_of_simple_presses_keeps_the_motions_and_digest_of_the_four_parameter_suite() -> None:
    """release (1, 1) and reload (0, 0) are the simple press: the stored spec (and so the digest and
    the shared suite) of a suite written before the family's parameters is the same suite."""
    import hashlib
    import json

    old = {"motions": 8, "seed": 0, "dt": 0.0025}
    old["ranges"] = {"start": [0.15, 0.28], "depth": [0.34, 0.43], "speed": [0.3, 1.5], "dwell": [0.0, 0.3]}
    digest = hashlib.sha256(
        json.dumps({"spec": old, "preset": DEFAULT_PRESET.to_dict()}, sort_keys=True).encode()
    ).hexdigest()
    assert SuiteSpec().digest(DEFAULT_PRESET) == digest
    assert SuiteSpec.from_dict(old) == SuiteSpec()
    assert all(type(m).__name__ == "PressMotion" for m in motion_parameters(SuiteSpec(), DEFAULT_PRESET))


def test_the_task_derived_box_spans_contact_to_the_joint_limit_and_adds_the_histories() -> None:
    from alcove.science.validation_suite import HISTORY_RELEASE, HISTORY_RELOAD, task_ranges

    p = DEFAULT_PRESET
    box = task_ranges(p, p.theta_contact)
    # the paper's preset: the default box (first contact 0.31 rad + 0.03, joint limit 0.432 - 0.002)
    assert box.depth == pytest.approx((p.theta_contact + 0.03, p.theta_max - 0.002), abs=1e-15)
    assert box.depth == pytest.approx(SuiteRanges().depth, abs=1e-12)
    assert (box.start, box.speed, box.dwell) == (SuiteRanges().start, SuiteRanges().speed, SuiteRanges().dwell)
    assert (box.release, box.reload) == (HISTORY_RELEASE, HISTORY_RELOAD) and not box.simple
    # a task that starts shallower and faster widens the box; a start past first contact - 0.03 is clipped
    wide = task_ranges(p, p.theta_contact, start_angles=(0.05, 0.30), top_speed=2.5)
    assert wide.start == pytest.approx((0.05, p.theta_contact - 0.03), abs=1e-15)
    assert wide.speed == (0.3, 2.5)
    assert task_ranges(p, p.theta_contact, start_angles=(0.0, 0.1)).start[0] == p.theta_min


def test_a_history_suite_is_a_six_parameter_latin_hypercube_and_its_stress_part_comes_after_the_core() -> None:
    from alcove.science.press_family import PARAMETERS
    from alcove.science.validation_suite import stress_ranges, task_ranges

    p, m = DEFAULT_PRESET, 8
    box = task_ranges(p, p.theta_contact)
    spec = SuiteSpec(motions=m, seed=2, ranges=box)
    core = motion_parameters(spec, p)
    for name in PARAMETERS:
        lo, hi = getattr(box, name)
        x = np.array([getattr(c, name) for c in core])
        assert sorted(np.floor((x - lo) / (hi - lo) * m).clip(0, m - 1)) == list(range(m)), name
    assert any(c.release < 1 for c in core)  # some motions unload part way and re-load
    stressed = SuiteSpec(motions=m, seed=2, ranges=box, stress_motions=3, stress=stress_ranges(box))
    both = motion_parameters(stressed, p)
    assert both[:m] == core  # the stress part leaves the core motions as they are
    assert [stressed.part(i) for i in range(len(both))] == ["core"] * m + ["stress"] * 3
    assert all(box.speed[1] <= s.speed <= 2 * box.speed[1] for s in both[m:])
    assert SuiteSpec.from_dict(stressed.to_dict()) == stressed
    assert stressed.digest(p) != spec.digest(p)
    for motion in both:  # rest at both ends; never beyond the peak angle or the start
        tr = motion.trajectory(0.0025)
        assert tr.qd[0, 0] == pytest.approx(0, abs=1e-12) and tr.qd[-1, 0] == pytest.approx(0, abs=1e-9)
        assert motion.start - 1e-12 <= tr.q[:, 0].min() and tr.q[:, 0].max() <= motion.depth + 1e-12
    with pytest.raises(ValueError, match="validation suite stress range speed"):
        motion_parameters(SuiteSpec(motions=2, ranges=box, stress_motions=1, stress=SuiteRanges(speed=(-1, 1))), p)


def test_stored_motion_parameters_give_back_the_motion() -> None:
    from dataclasses import asdict

    from alcove.science.press_family import HistoryPress
    from alcove.science.validation_suite import PressMotion, suite_motion

    press, history = PressMotion(0.2, 0.4, 1.0, 0.1), HistoryPress(0.2, 0.4, 1.0, 0.1, 0.5, 0.5)
    assert suite_motion(asdict(press)) == press
    assert suite_motion({**asdict(history), "part": "stress"}) == history
