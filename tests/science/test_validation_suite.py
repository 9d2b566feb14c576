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
