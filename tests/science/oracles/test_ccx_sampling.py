"""Which outputs ``fe-headrest-3d-ccx`` computes and how the others are interpolated (no ccx needed)."""

from __future__ import annotations

import numpy as np
import pytest

from alcove.science.oracles.fe_headrest_3d import CcxHeadrestOracle, CcxHeadrestParams
from alcove.science.oracles.fe_headrest_3d.sampling import EVENT_HALF_WIDTH, computed_outputs, interpolate


def press(n: int = 241, dt: float = 0.0025, touch: float = 0.1, turn: float = 0.3):
    """A head pressed along x: clear until ``touch``, deepest at ``turn``, back out symmetrically."""
    t = dt * np.arange(n)
    depth = 0.01 * (1.0 - ((t - turn) / (turn - touch)) ** 2)  # a parabola in time, 0 at touch and 2 turn - touch
    pose = np.stack([-depth, np.zeros(n), np.zeros(n)], -1)
    return t, depth, pose


def test_every_output_is_computed_around_touch_turn_and_separation():
    """Within EVENT_HALF_WIDTH outputs of the first touch, the reversal and the separation every
    output in contact or next to it is computed; elsewhere the spacing is at most the stride; the
    ends are always computed."""
    t, depth, pose = press()
    stride = 8
    idx = computed_outputs(t, depth, pose, stride, 1e-3)
    assert idx[0] == 0 and idx[-1] == len(t) - 1
    assert np.all(np.diff(idx) <= stride)
    touching = depth > 0
    touch, separation = np.argmax(touching), len(t) - np.argmax(touching[::-1])
    turn = int(np.argmax(depth))
    for event in (touch, turn, separation):
        window = np.arange(event - EVENT_HALF_WIDTH, event + EVENT_HALF_WIDTH + 1)
        # outputs with the head clear have no force: only the one next to contact is needed
        window = window[touching[window] | touching[window + 1] | touching[window - 1]]
        assert np.isin(window, idx).all(), event
    assert touch - 1 in idx and separation in idx and touch - 2 not in idx
    assert len(idx) < len(t) / 3  # the point: far fewer outputs computed


def test_stride_one_computes_every_output():
    t, depth, pose = press()
    np.testing.assert_array_equal(computed_outputs(t, depth, pose, 1, 1e-3), np.arange(len(t)))


def test_the_refinement_meets_its_tolerance_on_the_proxy():
    """The error estimate: the indentation^1.5 proxy, interpolated from the computed outputs, is
    within the tolerance of its peak everywhere, and a tighter tolerance computes more outputs."""
    t, depth, pose = press()
    proxy = np.maximum(depth, 0.0) ** 1.5
    counts = []
    for tol in (1e-2, 1e-4):
        idx = computed_outputs(t, depth, pose, 16, tol)
        error = np.abs(interpolate(t[idx], proxy[idx], t) - proxy)
        assert error.max() <= tol * proxy.max()
        counts.append(len(idx))
    assert counts[1] > counts[0]


def test_interpolation_is_exact_at_the_knots_and_second_order_on_smooth_data():
    """Known solution: on a smooth curve the makima interpolant's error falls like h^2 (its slopes
    are second-order accurate; threshold: halving h cuts the error by at least 2^1.8); the knots
    are reproduced."""
    t = np.linspace(0.0, 1.0, 1001)
    f = np.stack([np.sin(3 * t), np.exp(t)], -1)
    errors = []
    for step in (40, 20, 10):
        knots = np.arange(0, len(t), step)
        g = interpolate(t[knots], f[knots], t)
        np.testing.assert_allclose(g[knots], f[knots], rtol=0, atol=1e-12)
        errors.append(np.abs(g - f).max())
    assert errors[0] / errors[1] >= 2**1.8 and errors[1] / errors[2] >= 2**1.8, errors


def test_the_deck_computes_a_subset_and_the_job_fills_in_the_rest():
    """The deck's *TIME POINTS are the computed outputs, the job lists every output; with
    solve_spacing = 0 every output is a time point (ccx computes them all)."""
    from alcove.science.oracles.fe_headrest import reference_motion

    coarse = {"element_size_contact": 0.012, "head_element_size": 0.012, "element_size_far": 0.04}
    counts = {}
    for stride in (1, 8):
        oracle = CcxHeadrestOracle(CcxHeadrestParams(**coarse, solve_spacing=0.0 if stride == 1 else 0.02))
        assert oracle.params.solve_stride == stride
        files, job = oracle.job_files(oracle._validated(reference_motion()))
        assert set(job["tau"]) <= set(job["tau_all"]) and job["tau"][-1] == job["tau_all"][-1]
        assert len(job["cog"]) == len(job["tau"]) and len(job["clear"]) == len(job["tau_all"])
        text = files["headrest.inp"]
        points = text.split("*TIME POINTS, NAME=OUT\n")[1].split("*")[0]
        assert len(points.replace("\n", ",").strip(",").split(",")) == len(job["tau"])
        counts[stride] = len(job["tau"]), len(job["tau_all"])
    assert counts[1][0] == counts[1][1]
    assert counts[8][0] < counts[8][1] / 3 and counts[8][1] == counts[1][1]


@pytest.mark.parametrize("spacing", [-0.01, 0.2])
def test_solve_spacing_is_validated(spacing):
    from pydantic import ValidationError

    with pytest.raises(ValidationError, match="solve_spacing"):
        CcxHeadrestParams(solve_spacing=spacing)


def test_the_spacing_in_outputs_follows_the_output_interval():
    """0.04 s is 16 outputs of 2.5 ms, 4 of 10 ms; below two output intervals every output is computed."""
    assert CcxHeadrestParams().solve_stride == 16
    assert CcxHeadrestParams(output_dt=0.01).solve_stride == 4
    assert CcxHeadrestParams(output_dt=0.025).solve_stride == 1
