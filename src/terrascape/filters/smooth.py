"""Smoothing filters on float heightmaps (Filipović 2008 §2.3 and §5.2).

The seed smooths generated terrain with a blur ("zamagljivanje slike") — in its image-based
pipeline on 8-bit values, which leaves visible terracing. Here the blur runs on the float32
heights (computed in float64 by :mod:`scipy.ndimage`, stored back as float32): no
quantisation step. Border handling follows scipy's ``mode``: ``reflect`` (edge sample
repeated: ``d c b a | a b c d``), ``mirror`` (``d c b | a b c d``), ``nearest``, ``wrap``
(periodic) and ``constant`` (``cval`` outside).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from terrascape._validate import check_finite, check_int, check_positive
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap

MODES = ("reflect", "nearest", "mirror", "wrap", "constant")


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
    out = ndimage.gaussian_filter(
        hm.heights.astype(np.float64), sigma=sig, mode=mode, cval=cval, truncate=truncate
    )
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
    out = ndimage.uniform_filter(hm.heights.astype(np.float64), size=win, mode=mode, cval=cval)
    return hm.with_heights(out.astype(np.float32))


__all__ = ["MODES", "box_blur", "gaussian_blur"]
