"""The shared numba helpers: read-only views for one compile per kernel, the prefetch hint
the shadow sweep uses, and the stop flag a parallel kernel reads afresh."""

from __future__ import annotations

import math
import threading
import time

import numpy as np

from terrascape._numba import njit, prange, prefetch, read_only, stop_requested


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


@njit(parallel=True)
def _rows_until_stopped(out, work, stop):
    for r in prange(out.shape[0]):
        if stop_requested(stop):
            continue
        total = 0.0
        for k in range(work):
            total += math.sin(r + k * 1e-3)
        out[r] = total


def test_a_parallel_loop_sees_the_stop_flag_set_while_it_runs():
    """Set by another thread 0.2 s into a loop of about 3 s: the rows not yet begun are
    skipped. (Read as a plain ``stop[0]``, the loop ran every row: the read was made
    once.)"""
    out = np.full(600, np.nan)
    _rows_until_stopped(out[:2], 10, np.zeros(1, np.uint8))  # compiled
    start = time.perf_counter()
    _rows_until_stopped(out[:20], 200_000, np.zeros(1, np.uint8))
    per_row = (time.perf_counter() - start) / 20 * 2  # at worst one thread's pace
    work = int(200_000 * 0.01 / max(per_row, 1e-9))  # about 10 ms a row
    out[:] = np.nan
    stop = np.zeros(1, np.uint8)
    threading.Timer(0.2, stop.__setitem__, (0, 1)).start()
    _rows_until_stopped(out, work, stop)
    done = int(np.isfinite(out).sum())
    assert 0 < done < len(out) // 2, f"{done} of {len(out)} rows ran"
