"""The shared numba helpers: read-only views for one compile per kernel, and the prefetch
hint the shadow sweep uses."""

from __future__ import annotations

import numpy as np

from terrascape._numba import njit, prefetch, read_only


def test_read_only_is_a_view_that_cannot_be_written():
    a = np.arange(12, dtype=np.float32).reshape(3, 4)
    view = read_only(a)
    assert not view.flags.writeable and a.flags.writeable
    assert np.shares_memory(view, a)
    assert read_only(view) is view


@njit
def _sum_with_prefetch(values, ahead):
    total = 0.0
    for i in range(values.shape[0]):
        if i + ahead < values.shape[0]:
            prefetch(values, i + ahead)
        total += values[i]
    return total


def test_prefetch_compiles_for_any_element_type_and_changes_nothing():
    rng = np.random.default_rng(2)
    heights = rng.standard_normal(1000).astype(np.float32)
    mask = rng.random(999) < 0.3
    counts = rng.integers(0, 9, 77)
    for values in (heights, mask, counts, heights.astype(np.float64)):
        expected = values.astype(np.float64).sum()
        assert np.isclose(_sum_with_prefetch(values, 16), expected)
        assert np.isclose(_sum_with_prefetch(values, 0), expected)
