"""The wrench layout every stored force array and metric uses: rows [fx fy fz mx my mz]."""

import numpy as np
import pytest

from alcove.science.series import FORCE_COLUMNS, ForceSeries, split_wrench, stack_wrench


def test_stack_and_split_are_inverse_and_follow_the_csv_columns() -> None:
    rng = np.random.default_rng(0)
    force, moment = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    wrench = stack_wrench(force, moment)
    assert wrench.shape == (5, 6)
    f, m = split_wrench(wrench)
    np.testing.assert_array_equal(f, force)
    np.testing.assert_array_equal(m, moment)
    series = ForceSeries(np.arange(5) * 0.01, force, moment)
    np.testing.assert_array_equal(series.wrench, wrench)
    # the forces CSV's columns after t are the wrench's, in FORCE_COLUMNS order
    header = series.to_csv().splitlines()[0].split(",")
    assert header == ["t", *FORCE_COLUMNS]
    np.testing.assert_array_equal(series.to_array()[:, 1:], wrench)
    again = ForceSeries.from_wrench(series.t, wrench)
    np.testing.assert_array_equal(again.force, force)
    np.testing.assert_array_equal(again.moment, moment)


@pytest.mark.parametrize("shape", [(4, 3), (4, 7), (6,)])
def test_split_refuses_arrays_that_are_not_wrench_rows(shape: tuple[int, ...]) -> None:
    with pytest.raises(ValueError, match="6 columns"):
        split_wrench(np.zeros(shape))
