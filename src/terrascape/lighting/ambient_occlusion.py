"""Sky-view factor — ambient occlusion of a heightfield (beyond the theses).

For each sample and each of ``D`` azimuths the horizon angle ``φ_d`` (elevation of the
highest terrain seen in that direction, clamped at 0) is found by marching over the
bilinearly interpolated heightmap. The sky-view factor is the visible share of the sky
hemisphere, ``SVF = 1 - (1/D)·Σ sin φ_d`` (Zakšek, Oštir & Kokalj 2011, "Sky-view factor as
a relief visualization technique", Remote Sensing 3(2)): 1 on a flat plane or a peak,
smaller in valleys and pits. It can stand in for the ``ambient`` term of the lightmap.

The march takes unit steps for the first 16 samples and then grows the step by 1/16 of the
distance (the usual sampling of relief-visualisation tools), and it stops as soon as even
the highest sample of the map could not raise the horizon any more.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, prange, stop_requested
from terrascape._stoppable import run_stoppable
from terrascape._validate import check_int, check_positive
from terrascape.lighting._common import as_heightmap

_UNIT_STEPS = 16.0
# Samples × directions above which the kernel waits on a worker thread, so that Ctrl-C stops
# it at once (:func:`run_stoppable`): some tens of milliseconds, against 0.1 ms for the
# hand-over.
_LONG_WORK = 1 << 16


@njit(cache=CACHE, fastmath=FASTMATH)
def _bilinear(h, x, z):
    """Height at fractional (col x, row z); caller guarantees 0 <= x <= cols-1, 0 <= z <= rows-1."""
    rows, cols = h.shape
    c0 = min(math.floor(x), cols - 2)
    r0 = min(math.floor(z), rows - 2)
    fx = x - c0
    fz = z - r0
    top = h[r0, c0] + fx * (h[r0, c0 + 1] - h[r0, c0])
    bot = h[r0 + 1, c0] + fx * (h[r0 + 1, c0 + 1] - h[r0 + 1, c0])
    return top + fz * (bot - top)


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _svf_kernel(h, dx, dz, dirs, max_dist, hmax, out, stop):
    """The sky-view factor of every sample into ``out``; rows not yet begun are left
    unwritten once ``stop[0]`` is set (:func:`run_stoppable`)."""
    rows, cols = h.shape
    step0 = min(dx, dz)
    nd = dirs.shape[0]
    for r in prange(rows):
        if stop_requested(stop):
            continue
        for c in range(cols):
            hv = float(h[r, c])
            total = 0.0
            for d in range(nd):
                gx = dirs[d, 0] / dx  # columns per world unit
                gz = dirs[d, 1] / dz  # rows per world unit
                best = 0.0  # tan of the horizon angle, clamped at the horizontal
                s = step0
                while s <= max_dist:
                    # The horizon can only rise if some sample is above hv + best·s.
                    if hmax - hv <= best * s:
                        break
                    x = c + s * gx
                    z = r + s * gz
                    if x < 0.0 or x > cols - 1 or z < 0.0 or z > rows - 1:
                        break
                    t = (_bilinear(h, x, z) - hv) / s
                    if t > best:
                        best = t
                    s += step0 * max(1.0, s / (step0 * _UNIT_STEPS))
                total += best / math.sqrt(1.0 + best * best)  # sin(atan(best))
            out[r, c] = 1.0 - total / nd


def sky_view_factor(
    heightmap: Any, *, directions: int = 16, max_distance: float | None = None
) -> np.ndarray:
    """Visible fraction of the sky hemisphere per sample, ``1 - mean_d sin φ_d``.

    Parameters
    ----------
    heightmap
        Heightmap (spacing used) or 2-D array (spacing 1).
    directions
        Number of azimuths ``D`` (4–360), evenly spaced from north clockwise.
    max_distance
        Search radius in world units (None = the whole map). Smaller radii are faster and
        give a more local occlusion.

    Returns
    -------
    numpy.ndarray
        float32 ``(rows, cols)`` in [0, 1].
    """
    hm = as_heightmap(heightmap)
    nd = check_int(directions, "directions", minimum=4, maximum=360)
    if max_distance is None:
        dist = math.hypot(*hm.extent)
    else:
        dist = check_positive(max_distance, "max_distance")
    az = np.radians(np.arange(nd, dtype=np.float64) * (360.0 / nd))
    # Same convention as sun_direction: azimuth clockwise from north (-Z), 90° = east (+X).
    dirs = np.stack([np.sin(az), -np.cos(az)], axis=1)
    out = np.empty(hm.shape, dtype=np.float32)
    h = hm.heights.astype(np.float64)
    run_stoppable(h.size * nd > _LONG_WORK, _svf_kernel, h, float(hm.spacing[0]),
                  float(hm.spacing[1]), dirs, dist, float(h.max()), out)
    return np.clip(out, 0.0, 1.0)


__all__ = ["sky_view_factor"]
