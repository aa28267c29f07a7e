"""Smoothing filters on float heightmaps (Filipović 2008 §2.3 and §5.2).

The seed smooths generated terrain with a blur ("zamagljivanje slike") — in its image-based
pipeline on 8-bit values, which leaves visible terracing. Here the blur runs on the float32
heights (computed in float64 by :mod:`scipy.ndimage`, stored back as float32): no
quantisation step. Border handling follows scipy's ``mode``: ``reflect`` (edge sample
repeated: ``d c b a | a b c d``), ``mirror`` (``d c b | a b c d``), ``nearest``, ``wrap``
(periodic) and ``constant`` (``cval`` outside).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from scipy import ndimage

from terrascape._stoppable import for_each_band, run_stoppable
from terrascape._validate import check_finite, check_int, check_positive
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap

MODES = ("reflect", "nearest", "mirror", "wrap", "constant")

# A blur runs a band of rows or columns at a time, so that Ctrl-C stops it between two
# bands: scipy filters a whole axis in one call, which a wide Gaussian on a large map makes
# a call of many seconds. Maps of more samples are blurred on a worker thread
# (:func:`run_stoppable`), their bands shared among the numba threads (scipy's filter
# releases the GIL)
_LONG_SAMPLES = 1 << 20
# rows or columns per band: with a wide Gaussian (σ = 50) on an 8193² map, Ctrl-C took
# 0.6–0.9 s to stop the blur (docs/reliability.md)
_BAND = 256


def _check_mode(mode: str) -> str:
    if not isinstance(mode, str) or mode not in MODES:
        raise InvalidParameterError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
    return mode


def _as_heightmap(heightmap: Heightmap) -> Heightmap:
    if isinstance(heightmap, Heightmap):
        return heightmap
    if isinstance(heightmap, np.ndarray):
        return Heightmap(heightmap)
    raise InvalidParameterError(
        f"expected a Heightmap or 2-D array, got {type(heightmap).__name__}"
    )


def gaussian_blur(
    heightmap: Heightmap,
    sigma: float | tuple[float, float],
    *,
    mode: str = "reflect",
    cval: float = 0.0,
    truncate: float = 4.0,
) -> Heightmap:
    """Gaussian blur of the heights.

    Parameters
    ----------
    heightmap
        Input (a :class:`~terrascape.heightmap.Heightmap` or a 2-D array).
    sigma
        Standard deviation in samples, one number or ``(sigma_rows, sigma_cols)``; ``>= 0``
        (0 along an axis leaves that axis untouched).
    mode
        Border mode, one of :data:`MODES`.
    cval
        Height outside the map for ``mode="constant"``.
    truncate
        Kernel radius in standard deviations (``> 0``).

    Returns
    -------
    Heightmap
        Same shape, spacing and metadata; float32 heights.
    """
    hm = _as_heightmap(heightmap)
    mode = _check_mode(mode)
    if np.isscalar(sigma):
        sig = (check_positive(sigma, "sigma", allow_zero=True),) * 2  # type: ignore[arg-type]
    else:
        vals = list(sigma)  # type: ignore[arg-type]
        if len(vals) != 2:
            raise InvalidParameterError(f"sigma must be a number or (rows, cols), got {sigma!r}")
        sig = tuple(check_positive(v, "sigma", allow_zero=True) for v in vals)
    truncate = check_positive(truncate, "truncate")
    cval = check_finite(cval, "cval")
    out = np.empty(hm.shape, np.float64)
    gaussian_filter_in_bands(hm.heights, sig, out, mode=mode, cval=cval, truncate=truncate)
    return hm.with_heights(out.astype(np.float32))


def box_blur(
    heightmap: Heightmap,
    size: int | tuple[int, int],
    *,
    mode: str = "reflect",
    cval: float = 0.0,
) -> Heightmap:
    """Box (moving-average) blur over a ``size × size`` window (odd or even, ``>= 1``).

    Parameters
    ----------
    heightmap
        Input (a :class:`~terrascape.heightmap.Heightmap` or a 2-D array).
    size
        Window side in samples, one integer or ``(rows, cols)``; 1 is the identity.
    mode, cval
        Border handling as in :func:`gaussian_blur`.

    Returns
    -------
    Heightmap
        Same shape, spacing and metadata; float32 heights.
    """
    hm = _as_heightmap(heightmap)
    mode = _check_mode(mode)
    if isinstance(size, (tuple, list)):
        if len(size) != 2:
            raise InvalidParameterError(f"size must be an integer or (rows, cols), got {size!r}")
        win = tuple(check_int(s, "box size", minimum=1) for s in size)
    else:
        win = (check_int(size, "box size", minimum=1),) * 2
    cval = check_finite(cval, "cval")
    passes = [(axis, {"size": win[axis], "mode": mode, "cval": cval})
              for axis in (0, 1) if win[axis] > 1]  # scipy skips the same axes
    out = np.empty(hm.shape, np.float64)
    _separable(ndimage.uniform_filter1d, hm.heights, passes, out)
    return hm.with_heights(out.astype(np.float32))


def gaussian_filter_in_bands(src: np.ndarray, sigma: float | tuple[float, float],
                             out: np.ndarray, *, mode: str = "reflect", cval: float = 0.0,
                             truncate: float = 4.0) -> None:
    """``scipy.ndimage.gaussian_filter(src, sigma, output=out, …)`` of a 2-D array into the
    float64 ``out`` (which may be ``src``), bit for bit, a band of lines at a time: Ctrl-C
    stops it between two bands, and a large array's bands are shared among the numba
    threads. Parameters as :func:`gaussian_blur`'s, checked by the caller."""
    sig = (sigma, sigma) if np.isscalar(sigma) else tuple(sigma)  # type: ignore[arg-type]
    passes = [(axis, {"sigma": sig[axis], "mode": mode, "cval": cval, "truncate": truncate})
              for axis in (0, 1) if sig[axis] > 1e-15]  # scipy skips the same axes
    _separable(ndimage.gaussian_filter1d, src, passes, out)


def _separable(filter1d: Callable[..., Any], src: np.ndarray, passes: list[tuple[int, dict]],
               out: np.ndarray) -> None:
    """``filter1d`` along each ``(axis, options)`` of ``passes`` in turn from ``src`` into
    the float64 ``out`` (which may be ``src``): what scipy's n-dimensional filter gives, bit
    for bit (it runs the same 1-D passes, axis 0 first; a line's result depends on that
    line alone, and scipy reads a line before it writes it)."""
    long = src.size > _LONG_SAMPLES
    if not passes:
        out[...] = src
    else:
        run_stoppable(long, _filter_in_bands, filter1d, src, passes, out, long)


def _filter_in_bands(filter1d: Callable[..., Any], src: np.ndarray,
                     passes: list[tuple[int, dict]], out: np.ndarray, parallel: bool,
                     stop: np.ndarray) -> None:
    """:func:`_separable`'s passes into ``out``, each in bands of ``_BAND`` lines (columns
    for axis 0, rows for axis 1), with ``parallel`` shared among the numba threads; no band
    begins once ``stop[0]`` is set. The first pass reads ``src`` (scipy filters in float64
    whatever the input's type), the next ones ``out`` in place (each band its own lines).
    Only a long blur is parallel: it runs off the main thread, where no signal can interrupt
    the start of the pool's threads (which would hang the interpreter's exit)."""
    for i, (axis, options) in enumerate(passes):
        first = src if i == 0 else out

        def band(start: int, axis: int = axis, options: dict = options,
                 first: np.ndarray = first) -> None:
            lines = slice(start, start + _BAND)
            part = (slice(None), lines) if axis == 0 else (lines, slice(None))
            filter1d(first[part], axis=axis, output=out[part], **options)

        for_each_band(band, range(0, out.shape[1 - axis], _BAND), parallel, stop)


__all__ = ["MODES", "box_blur", "gaussian_blur", "gaussian_filter_in_bands"]
