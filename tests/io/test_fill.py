"""Nodata filling: nearest valid sample (Euclidean distance transform)."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape import InvalidParameterError
from terrascape.io import fill_nodata


def test_holes_take_the_nearest_valid_value():
    h = np.array(
        [[1.0, 1.0, 1.0, 1.0, 9.0], [1.0, np.nan, np.nan, np.nan, 9.0], [1.0, 1.0, 1.0, 1.0, 9.0]]
    )
    filled, count = fill_nodata(h)
    assert count == 3
    assert filled.dtype == np.float32
    # (1,1) and (1,2) are 1 away from a 1.0; (1,3) is 1 away from both 1.0 and 9.0.
    assert filled[1, 1] == 1.0 and filled[1, 2] == 1.0 and filled[1, 3] in (1.0, 9.0)
    np.testing.assert_array_equal(filled[~np.isnan(h)], h[~np.isnan(h)])


def test_far_hole_uses_true_euclidean_nearest():
    h = np.full((9, 9), np.nan)
    h[0, 0] = 5.0
    h[8, 6] = 7.0
    filled, count = fill_nodata(h)
    assert count == 79
    assert filled[2, 2] == 5.0  # dist sqrt(8) vs sqrt(52)
    assert filled[6, 5] == 7.0  # dist sqrt(5) vs sqrt(61)
    assert set(np.unique(filled)) == {5.0, 7.0}


def test_explicit_mask_and_no_holes():
    h = np.arange(12, dtype=np.float32).reshape(3, 4)
    mask = np.zeros_like(h, dtype=bool)
    mask[0, 0] = True
    filled, count = fill_nodata(h, mask)
    assert count == 1 and filled[0, 0] in (1.0, 4.0)
    same, zero = fill_nodata(h)
    assert zero == 0
    np.testing.assert_array_equal(same, h)


def test_errors():
    with pytest.raises(InvalidParameterError, match="all 4 samples"):
        fill_nodata(np.full((2, 2), np.nan))
    with pytest.raises(InvalidParameterError, match="2-D"):
        fill_nodata(np.zeros(4))
    with pytest.raises(InvalidParameterError, match="mask shape"):
        fill_nodata(np.zeros((2, 2)), np.zeros((3, 3), bool))
