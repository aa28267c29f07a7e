"""Cubic B-spline resampling of a heightmap to a new size, corner to corner.

Output sample ``(i, j)`` of an ``R × C`` result reads the ``r × c`` input at
``(i·(r - 1)/(R - 1), j·(c - 1)/(C - 1))``: the first and last rows and columns of both
grids coincide, so the world extent is kept and the new spacing is ``extent / (R - 1)``.
The value there is the cubic B-spline that passes through every input sample (scipy's
order-3 spline: a recursive prefilter turns the samples into the spline's coefficients,
then each output sums the 4 × 4 coefficients around it), with the border continued by its
edge samples (scipy's ``"nearest"``, as ``ndimage.zoom`` pads it: 12 samples of the edge
value before the prefilter). Where the grids line up (a factor of 2, say) the output
repeats the input's samples exactly.

``scipy.ndimage.zoom`` computes the same spline, but sizes its output ``round(r·zoom)``:
asked for ``R`` rows with ``zoom = (R - 1)/(r - 1)``, it returns ``R + 1`` rows when
enlarging more than 1.5 times and ``R - 1`` when shrinking below half, and its grid is
then stretched by a sample. Here the size is the one asked for.

The prefilter runs a band of lines at a time (columns, then rows, each line on its own) and
the evaluation a band of output rows at a time, so that Ctrl-C stops a long resample
between two bands; on a large map they run on the worker thread of long calls, the bands
shared among the numba threads (scipy's loops release the GIL).

References
----------
.. [1] M. Unser, "Splines: a perfect fit for signal and image processing", IEEE Signal
   Processing Magazine 16(6), 1999 — B-spline interpolation by recursive prefiltering.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy import ndimage

from terrascape._stoppable import for_each_band, run_stoppable
from terrascape._validate import as_height_array, check_int
from terrascape.heightmap import Heightmap

# edge samples added on every side before the prefilter, as ``ndimage.zoom`` does for the
# "nearest" border: the recursive filter then starts far enough out
_PAD = 12
# lines (prefilter) or output rows (evaluation) per band
_BAND = 256
# more samples (input and output together) than this: on the worker thread, in parallel
_LONG_SAMPLES = 1 << 20


def resample_cubic(heights: Any, shape: tuple[int, int]) -> np.ndarray:
    """``heights`` resampled to ``shape`` (rows, cols) by the interpolating cubic B-spline,
    corner samples on corner samples (module docstring).

    Parameters
    ----------
    heights
        2-D array of at least 2 × 2 finite samples, or a
        :class:`~terrascape.heightmap.Heightmap` (its heights).
    shape
        Rows and columns of the result, each at least 2.

    Returns
    -------
    numpy.ndarray
        float32 ``shape`` array (computed in float64).
    """
    h = as_height_array(heights.heights if isinstance(heights, Heightmap) else heights)
    if not isinstance(shape, (tuple, list)) or len(shape) != 2:
        raise TypeError(f"shape must be (rows, cols), got {shape!r}")
    rows = check_int(shape[0], "rows of the resampled map", minimum=2)
    cols = check_int(shape[1], "columns of the resampled map", minimum=2)
    coefficients = np.empty((h.shape[0] + 2 * _PAD, h.shape[1] + 2 * _PAD))
    out = np.empty((rows, cols), np.float32)
    long = coefficients.size + out.size > _LONG_SAMPLES
    run_stoppable(long, _resample_in_bands, h, coefficients, out, long)
    return out


def _resample_in_bands(h: np.ndarray, coefficients: np.ndarray, out: np.ndarray,
                       parallel: bool, stop: np.ndarray) -> None:
    """``h`` padded by its edge samples into the float64 ``coefficients`` (``np.pad``'s
    "edge"), turned in place into the spline's coefficients, then evaluated into ``out``;
    each step a band at a time (shared among the numba threads when ``parallel``; none
    begins once ``stop[0]`` is set)."""
    def pad(start: int) -> None:
        rows = h[start:start + _BAND]
        band = coefficients[_PAD + start:_PAD + start + rows.shape[0]]
        band[:, _PAD:-_PAD] = rows
        band[:, :_PAD] = rows[:, :1]
        band[:, -_PAD:] = rows[:, -1:]

    for_each_band(pad, range(0, h.shape[0], _BAND), parallel, stop)
    coefficients[:_PAD] = coefficients[_PAD]
    coefficients[-_PAD:] = coefficients[-_PAD - 1]
    for axis in (0, 1):
        def prefilter(start: int, axis: int = axis) -> None:
            lines = slice(start, start + _BAND)
            part = (slice(None), lines) if axis == 0 else (lines, slice(None))
            # in place: scipy copies a line before it writes it back (its spline_filter
            # filters the second axis in place the same way)
            ndimage.spline_filter1d(coefficients[part], 3, axis, output=coefficients[part],
                                    mode="nearest")

        for_each_band(prefilter, range(0, coefficients.shape[1 - axis], _BAND), parallel,
                      stop)
    rows, cols = (n - 2 * _PAD for n in coefficients.shape)
    step = np.array([(rows - 1) / (out.shape[0] - 1), (cols - 1) / (out.shape[1] - 1)])

    def evaluate(start: int) -> None:
        band = out[start:start + _BAND]
        # output row start + k reads the padded coefficients at (start + k)·step + _PAD
        ndimage.affine_transform(coefficients, step, offset=(start * step[0] + _PAD, _PAD),
                                 output=band, order=3, mode="nearest", prefilter=False)

    for_each_band(evaluate, range(0, out.shape[0], _BAND), parallel, stop)


__all__ = ["resample_cubic"]
