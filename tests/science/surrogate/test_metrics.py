"""The metric formulas of alcove.science.surrogate.metrics against hand-computed cases."""

import math

import numpy as np
import pytest

from alcove.science.surrogate.metrics import (
    MetricInputError,
    calibration,
    component_metrics,
    component_rmse,
    vector_rmse,
    wrench_metrics,
)


def planar(fx, fz, my):
    """Wrenches of the planar model: fy, mx, mz are structural zeros."""
    n = len(fx)
    return np.column_stack([fx, np.zeros(n), fz, np.zeros(n), my, np.zeros(n)])


def test_force_rmse_is_the_error_vector_norm_not_the_component_mean():
    # errors: sample 0 (3, 0, 4) -> |e|^2 = 25; sample 1 (0, 0, 0) -> 0; mean 12.5
    true = planar([10.0, 0.0], [20.0, 0.0], [1.0, 0.0])
    pred = planar([13.0, 0.0], [24.0, 0.0], [1.0, 0.0])
    m = wrench_metrics(pred, true)
    assert m["force_rmse"] == pytest.approx(math.sqrt(12.5), rel=1e-15)  # threshold: float rounding
    # the old definition (mean over fx, fy, fz) would be sqrt(25 / 6), sqrt(3) smaller
    assert m["force_rmse"] / math.sqrt(25 / 6) == pytest.approx(math.sqrt(3), rel=1e-15)
    assert m["moment_rmse"] == 0.0
    assert m["rmse_fx"] == pytest.approx(math.sqrt(9 / 2), rel=1e-15)
    assert m["rmse_fz"] == pytest.approx(math.sqrt(16 / 2), rel=1e-15)
    assert m["rmse_fy"] == m["rmse_mx"] == m["rmse_mz"] == 0.0
    # the force RMSE squared is the sum of the component RMSEs squared
    assert m["force_rmse"] ** 2 == pytest.approx(m["rmse_fx"] ** 2 + m["rmse_fy"] ** 2 + m["rmse_fz"] ** 2)


def test_contact_variants_use_only_samples_with_nonzero_oracle_force():
    # sample 0 in contact (error (3,0,4), moment error 2), sample 1 out of contact (ghost force 1, moment 1)
    true = planar([10.0, 0.0], [20.0, 0.0], [1.0, 0.0])
    pred = planar([13.0, 1.0], [24.0, 0.0], [3.0, 1.0])
    m = wrench_metrics(pred, true)
    assert m["n_contact_samples"] == 1 and m["n_samples"] == 2
    assert m["force_rmse_contact"] == pytest.approx(5.0, rel=1e-15)
    assert m["moment_rmse_contact"] == pytest.approx(2.0, rel=1e-15)
    assert m["force_rmse"] == pytest.approx(math.sqrt((25 + 1) / 2), rel=1e-15)
    assert m["moment_rmse"] == pytest.approx(math.sqrt((4 + 1) / 2), rel=1e-15)


def test_per_component_rmse_in_contact_against_a_hand_computed_case():
    """Three samples: two in contact (errors fx 3 and 1, fz 4 and -2, my 0.5 and 0), one clear of the
    headrest with a ghost force fx 2. Per component over all samples and over the two in contact."""
    true = planar([10.0, 30.0, 0.0], [5.0, -5.0, 0.0], [1.0, 2.0, 0.0])
    pred = planar([13.0, 31.0, 2.0], [9.0, -7.0, 0.0], [1.5, 2.0, 0.0])
    m = wrench_metrics(pred, true)
    assert m["rmse_fx"] == pytest.approx(math.sqrt((9 + 1 + 4) / 3), rel=1e-15)
    assert m["rmse_fx_contact"] == pytest.approx(math.sqrt((9 + 1) / 2), rel=1e-15)
    assert m["rmse_fz"] == pytest.approx(math.sqrt((16 + 4) / 3), rel=1e-15)
    assert m["rmse_fz_contact"] == pytest.approx(math.sqrt((16 + 4) / 2), rel=1e-15)
    assert m["rmse_my_contact"] == pytest.approx(math.sqrt(0.25 / 2), rel=1e-15)
    assert m["rmse_fy_contact"] == m["rmse_mx_contact"] == m["rmse_mz_contact"] == 0.0
    # the vector in contact from its components: |e|^2 = e_fx^2 + e_fy^2 + e_fz^2
    assert m["force_rmse_contact"] ** 2 == pytest.approx(m["rmse_fx_contact"] ** 2 + m["rmse_fz_contact"] ** 2)
    both = component_metrics(pred, true)
    assert both == {k.removeprefix("rmse_"): v for k, v in m.items() if k.startswith("rmse_")}
    clear = planar([0.0], [0.0], [0.0])
    assert component_metrics(clear + 1.0, clear)["fx_contact"] is None  # none in contact: None, not 0


def test_no_contact_gives_none_not_zero():
    true = planar([0.0, 0.0], [0.0, 0.0], [0.0, 0.0])
    m = wrench_metrics(true + 0.5, true)
    assert m["force_rmse_contact"] is None and m["moment_rmse_contact"] is None
    assert m["n_contact_samples"] == 0


def test_calibration_counts_values_inside_two_std_and_skips_structural_zeros():
    true = planar([1.0, 2.0, 3.0, 4.0], [1.0, 1.0, 1.0, 1.0], [0.0, 0.0, 0.0, 0.5])
    pred = true.copy()
    pred[:, 0] += [0.25, 0.75, -0.5, 0.0]  # fx errors (exact in binary): inside, outside, on the boundary, inside
    std = np.full_like(true, 0.25)
    # fx: |e| <= 2 * 0.25 -> 3 of 4; fz: exact -> 4 of 4; my: exact -> 4 of 4; fy, mx, mz excluded (zero everywhere)
    assert calibration(pred, true, std) == pytest.approx(11 / 12, rel=1e-15)
    assert wrench_metrics(pred, true)["calibration"] is None  # K = 1: no std, no calibration


def test_calibration_all_structural_zero_is_none():
    z = np.zeros((3, 6))
    assert calibration(z, z, z) is None


def test_vector_and_component_rmse_empty_sets():
    assert vector_rmse(np.zeros((0, 3)), np.zeros((0, 3))) is None
    assert component_rmse(np.zeros((0, 6)), np.zeros((0, 6)))["fx"] is None


@pytest.mark.parametrize(
    ("pred", "true", "field"),
    [
        (np.zeros((2, 5)), np.zeros((2, 5)), "pred"),
        (np.zeros((2, 6)), np.zeros((3, 6)), "true"),
        (np.full((2, 6), np.nan), np.zeros((2, 6)), "pred"),
    ],
)
def test_bad_shapes_name_the_array(pred, true, field):
    with pytest.raises(MetricInputError) as exc:
        wrench_metrics(pred, true)
    assert exc.value.field == field


def test_negative_std_is_rejected():
    z = np.ones((2, 6))
    with pytest.raises(MetricInputError, match="std"):
        calibration(z, z, -z)
