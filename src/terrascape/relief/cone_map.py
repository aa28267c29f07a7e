"""Cone maps for cone step mapping (Dummer 2006) — the "next improvement" the thesis names (§3).

For every texel the cone map stores the widest upward-opening cone, apex on the texel's
surface point, that contains no part of the height field: the ratio ``c`` = horizontal
distance / depth difference (UV units per unit of normalised depth). A tracer at depth
``s`` above a surface of depth ``d`` with cone ``c`` can advance the ray by
``Δs = c·(d − s)/(|ds| + c)`` without crossing the surface.

The brute-force definition ``c_i = min_j dist(i, j)/(d_i − d_j)`` over every higher texel
``j`` is O(N⁴); the kernel searches square rings of growing radius around each texel and
stops as soon as the ring distance divided by the largest possible depth difference can no
longer beat the current minimum — exact, and fast for both city and natural fields.
Distances wrap (tileable textures, ``GL_REPEAT``).

Cone step mapping is an approximate method here: the cones are exact for the texel-centre
samples but not conservative for the bilinear surface between them, and the tracer has no
minimum step, so rays pass through the surface near silhouettes and stall short of it at
grazing angles — `terrascape bench relief` measures 1–40 % of pixels more than a texel off
depending on field and angle. Use the min/max tracer (``minmax``) where exact hits matter;
Bán et al. (2024) describe cones that are conservative under bilinear interpolation.

References
----------
.. [1] Dummer, J. (2006). Cone Step Mapping: An Iterative Ray-Heightfield Intersection
   Algorithm.
.. [2] Bán, R., Valasek, G., Bálint, Cs., Vad, V. A. (2024). Robust Cone Step Mapping.
   Eurographics Symposium on Rendering.
- D. Janković, "Reljefne tehnike teksturiranja u prikazu terena" (Relief texturing techniques
  in terrain rendering), MSc thesis 62, Faculty of Electrical Engineering and Computing,
  University of Zagreb, 2010, §3.
"""

from __future__ import annotations

import math

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, prange, stop_requested
from terrascape._stoppable import run_stoppable
from terrascape._validate import check_positive
from terrascape.relief.minmax_mip import corner_depths
from terrascape.relief.reference import heights_to_depth

# Texels above which a cone map is made on a worker thread, so that Ctrl-C stops it at once
# (:func:`run_stoppable`): a 128² texture takes tens of milliseconds, a 1024² one a minute.
_LONG_TEXELS = 128 * 128


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _cone_kernel(depth, du, dv, c_max, out, stop):
    """Cone ratios into ``out``; rows not yet begun are left unwritten once ``stop[0]`` is
    set (:func:`run_stoppable`)."""
    rows, cols = depth.shape
    d_min = depth.min()
    for r in prange(rows):
        if stop_requested(stop):
            continue
        for c in range(cols):
            d_i = depth[r, c]
            best = c_max
            span = d_i - d_min
            if span <= 0.0:
                out[r, c] = best
                continue
            max_ring = max(rows, cols) // 2
            for ring in range(1, max_ring + 1):
                # Every texel of this ring is at least `ring` texels away on one axis.
                if ring * min(du, dv) / span >= best:
                    break
                for oy in range(-ring, ring + 1):
                    edge_row = oy == -ring or oy == ring
                    step = 1 if edge_row else 2 * ring
                    for ox in range(-ring, ring + 1, step):
                        d_j = depth[(r + oy) % rows, (c + ox) % cols]
                        diff = d_i - d_j
                        if diff > 0.0:
                            dist = math.sqrt((ox * du) ** 2 + (oy * dv) ** 2)
                            ratio = dist / diff
                            if ratio < best:
                                best = ratio
            out[r, c] = best


def cone_map(heights, *, c_max: float = 1.0) -> np.ndarray:
    """Cone ratios of a height texture (exact, conservative cones; wraps around).

    Parameters
    ----------
    heights
        ``(rows, cols)`` heights in [0, 1] (depth = 1 − h).
    c_max
        Cap on the ratio in UV per unit depth (texels with nothing above them).

    Returns
    -------
    numpy.ndarray
        float32 ``(rows, cols)`` cone ratios in UV units per unit depth, in ``[0, c_max]``.
    """
    depth = heights_to_depth(heights)
    c_max = check_positive(c_max, "c_max")
    rows, cols = depth.shape
    out = np.empty_like(depth)
    run_stoppable(depth.size > _LONG_TEXELS, _cone_kernel, depth, 1.0 / cols, 1.0 / rows,
                  c_max, out)
    return out.astype(np.float32)


def cone_map_bruteforce(heights, *, c_max: float = 1.0) -> np.ndarray:
    """O(N⁴) numpy definition of :func:`cone_map` (for tests on tiny textures)."""
    depth = heights_to_depth(heights)
    rows, cols = depth.shape
    out = np.full(depth.shape, float(c_max))
    oy, ox = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    for r in range(rows):
        for c in range(cols):
            dy = np.minimum(np.abs(oy - r), rows - np.abs(oy - r)) / rows
            dx = np.minimum(np.abs(ox - c), cols - np.abs(ox - c)) / cols
            diff = depth[r, c] - depth
            mask = diff > 0
            if mask.any():
                out[r, c] = min(c_max, float((np.hypot(dx, dy)[mask] / diff[mask]).min()))
    return out.astype(np.float32)


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _footprint_cone_kernel(cell_min, apex, c_max, out, stop):
    # Texel i's footprint F_i = [i − ½, i + ½]²; cell k spans [k, k + 1]² with minimum
    # depth cell_min[k]. Box distance per axis: max(0, |i − (k + ½)| − 1) texels. Rows not
    # yet begun are left unwritten once stop[0] is set (run_stoppable).
    rows, cols = cell_min.shape
    d_min = cell_min.min()
    for r in prange(rows):
        if stop_requested(stop):
            continue
        for c in range(cols):
            a = apex[r, c]
            best = c_max
            span = a - d_min
            if span <= 0.0:
                out[r, c] = best
                continue
            for ring in range(1, max(rows, cols) // 2 + 1):
                # Cells on ring `ring` (offset k − i ∈ {−ring − 1, ring}) are ≥ ring − ½ away.
                if (ring - 0.5) / (span * max(rows, cols)) >= best:
                    break
                for oy in range(-ring - 1, ring + 1):
                    # the ring's cells only: all of its first and last row, the two ends of
                    # the others (2·ring + 1 apart)
                    edge = oy == -ring - 1 or oy == ring
                    step = 1 if edge else 2 * ring + 1
                    for ox in range(-ring - 1, ring + 1, step):
                        m = cell_min[(r + oy) % rows, (c + ox) % cols]
                        diff = a - m
                        if diff > 0.0:
                            gx = max(0.0, abs(ox + 0.5) - 1.0) / cols
                            gy = max(0.0, abs(oy + 0.5) - 1.0) / rows
                            ratio = math.sqrt(gx * gx + gy * gy) / diff
                            if ratio < best:
                                best = ratio
            out[r, c] = best


def footprint_cone_map(heights, *, c_max: float = 1.0) -> np.ndarray:
    """Conservative cone map for *nearest* lookups of a *bilinear* surface.

    A GPU tracer fetching texel ``i`` may stand anywhere in its footprint
    ``[i − ½, i + ½]²``, and the filtered surface between texel centres dips below the
    texel values. So channel 0 is the apex depth ``A_i`` = the minimum depth of the four
    bilinear cells overlapping the footprint (min of the 3×3 neighbourhood), and channel 1
    the cone ratio against every other cell's minimum depth, using box-to-box distances.
    A ray point in the footprint above ``A_i`` can then advance
    ``c·(A_i − s)/(|ds| + c)`` in depth without touching the surface — the "safe" cone step.

    Returns
    -------
    numpy.ndarray
        float32 ``(rows, cols, 2)``: (apex depth, cone ratio in UV per unit depth).
    """
    depth = heights_to_depth(heights)
    c_max = check_positive(c_max, "c_max")
    cell_min = corner_depths(depth).min(axis=-1)
    # The four cells overlapping texel i's footprint are k ∈ {i − 1, i} on each axis.
    apex = np.minimum(
        np.minimum(cell_min, np.roll(cell_min, 1, axis=1)),
        np.minimum(np.roll(cell_min, 1, axis=0), np.roll(np.roll(cell_min, 1, axis=0), 1, 1)),
    )
    out = np.empty_like(depth)
    run_stoppable(depth.size > _LONG_TEXELS, _footprint_cone_kernel, cell_min, apex, c_max,
                  out)
    return np.stack([apex, out], axis=-1).astype(np.float32)


__all__ = ["cone_map", "cone_map_bruteforce", "footprint_cone_map"]
