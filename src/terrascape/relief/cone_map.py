"""Cone maps for cone step mapping (Dummer 2006) — the "next improvement" the thesis names (§3).

For every texel the cone map stores the widest upward-opening cone, apex on the texel's
surface point, that contains no part of the height field: the ratio ``c`` = horizontal
distance / depth difference (UV units per unit of normalised depth). A tracer at depth
``s`` above a surface of depth ``d`` with cone ``c`` can advance the ray by
``Δs = c·(d − s)/(|ds| + c)`` without crossing the surface.

The brute-force definition ``c_i = min_j dist(i, j)/(d_i − d_j)`` over every higher texel
``j`` is O(N⁴). The kernel searches square rings of blocks (8×8 texels), then of groups of
8×8 blocks, of growing radius around each texel, and stops as soon as the ring's distance
divided by the largest possible depth difference can no longer beat the current minimum. A
block or group whose nearest cell divided by the depth difference to its lowest cell cannot
beat it either is passed over without reading its cells. The result is exact (the
definition's value bit for bit), and a 1024² texture takes about a second. Distances wrap
(tileable textures, ``GL_REPEAT``).

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
from terrascape.relief.reference import heights_to_depth

# Texels above which a cone map is made on a worker thread, so that Ctrl-C stops it at once
# (:func:`run_stoppable`): a 128² texture takes milliseconds, a 1024² one seconds.
_LONG_TEXELS = 128 * 128


# Cones are searched block by block (``_CONE_BLOCK`` texels a side): a block whose least
# possible ratio (its nearest offset ÷ the depth difference to its lowest cell) cannot beat
# the cone so far is passed over without reading its cells. The ``_NEAR_RINGS`` nearest
# rings of blocks come first, nearest first, then rings of groups of ``_CONE_GROUP``²
# blocks, each group passed over whole when its bound cannot beat the cone. A walk over
# single texels read every cell of every ring up to the cone's radius. Blocks of 8 were
# faster than 4 or 16 (docs/benchmarks.md); the other sizes were the first tried.
_CONE_BLOCK = 8
_CONE_GROUP = 8
_NEAR_RINGS = 4
# a bound must beat the cone by this factor before a block or a ring is skipped: the bound
# and a cell's ratio are rounded differently, and a cell whose ratio only ties the cone
# cannot change it
_BOUND_MARGIN = 1.0 + 1e-9


@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _axis_gap(lo, hi, n, footprint):
    """Least distance in UV along one axis of ``n`` texels from the texel to the cells at
    offsets ``lo..hi``: from its centre, or with ``footprint`` box to box (texel footprint
    ``[−½, ½]``, cell ``[o, o + 1]``)."""
    if footprint:
        if lo >= 0:
            f = lo + 0.5
        elif hi < 0:
            f = -hi - 0.5
        else:
            f = 0.5
        return max(0.0, f - 1.0) / n
    if lo > 0:
        return lo / n
    if hi < 0:
        return -hi / n
    return 0.0


@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _block_cones(values, low, jy, jx, r, c, a, best, origin, footprint):
    """``best`` lowered by the cells of block ``(jy, jx)`` (extended block indices), or
    unchanged without reading them when the block's bound cannot beat it."""
    rows, cols = values.shape
    block = _CONE_BLOCK
    block_diff = a - low[jy, jx]
    if block_diff <= 0.0:
        return best
    u0 = jy * block - origin
    v0 = jx * block - origin
    if _square_cannot_beat(u0 - r, v0 - c, block, rows, cols, best, block_diff, footprint):
        return best
    return _cell_cones(values, u0, v0, r, c, a, best, footprint)


@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _square_cannot_beat(oy, ox, size, rows, cols, best, diff, footprint):
    """Whether no cell of the square of ``size`` cells at offset ``(oy, ox)`` from the
    texel, none lower than ``diff`` below the apex, can narrow the cone ``best``: its
    nearest offset ÷ ``diff`` is no less (compared squared: no root or division for the
    squares passed over)."""
    near_y = _axis_gap(oy, oy + size - 1, rows, footprint)
    near_x = _axis_gap(ox, ox + size - 1, cols, footprint)
    limit = best * _BOUND_MARGIN * diff
    return near_x * near_x + near_y * near_y >= limit * limit


@njit(cache=CACHE, fastmath=FASTMATH)
def _cell_cones(values, u0, v0, r, c, a, best, footprint):
    """``best`` lowered by the cells of the block whose first cell is ``(u0, v0)`` (cell
    indices of the texture repeated around itself). Called, not inlined: one compiled
    copy for both call sites (the kernels' first compilation took 12 s instead of 16)."""
    rows, cols = values.shape
    block = _CONE_BLOCK
    du = 1.0 / cols
    dv = 1.0 / rows
    col0 = v0 % cols
    for u in range(u0, u0 + block):
        oy = u - r
        row = u % rows
        col = col0  # the block's columns wrapped by counting: a division a cell cost more
        for v in range(v0, v0 + block):
            ox = v - c
            diff = a - values[row, col]
            col += 1
            if col == cols:
                col = 0
            if diff > 0.0:
                if footprint:
                    gx = max(0.0, abs(ox + 0.5) - 1.0) / cols
                    gy = max(0.0, abs(oy + 0.5) - 1.0) / rows
                    d2 = gx * gx + gy * gy
                else:
                    d2 = (ox * du) ** 2 + (oy * dv) ** 2
                # the ratio itself (a root and a division) only for a cell that may beat
                # the cone
                limit = best * _BOUND_MARGIN * diff
                if d2 < limit * limit:
                    ratio = math.sqrt(d2) / diff
                    if ratio < best:
                        best = ratio
    return best


@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _ring_cannot_beat(q, size, rows, cols, span, best, footprint):
    """Whether no cell of ring ``q`` (≥ 1) of squares of ``size`` texels around the texel's
    own can narrow the cone ``best``, ``span`` being the deepest a cell can lie below the
    apex: the ring's least UV distance ÷ ``span`` is no less. Every cell of the ring lies
    at least (q − 1)·size + 1 texels off on one axis, the negative side being the nearer in
    box distance."""
    near = -((q - 1) * size + 1)
    gap = min(_axis_gap(near, near, cols, footprint), _axis_gap(near, near, rows, footprint))
    return gap / span >= best * _BOUND_MARGIN


@njit(cache=CACHE, fastmath=FASTMATH)
def _block_minima(values, origin, ngy, ngx):
    """The lowest value of every block and of every group of blocks, over the texture
    repeated around itself (cell ``u`` in block ``(u + origin) // _CONE_BLOCK``)."""
    rows, cols = values.shape
    block = _CONE_BLOCK
    group = _CONE_GROUP
    low = np.empty((ngy * group, ngx * group), values.dtype)
    for jy in range(ngy * group):
        for jx in range(ngx * group):
            m = values[(jy * block - origin) % rows, (jx * block - origin) % cols]
            for u in range(jy * block - origin, (jy + 1) * block - origin):
                for v in range(jx * block - origin, (jx + 1) * block - origin):
                    m = min(m, values[u % rows, v % cols])
            low[jy, jx] = m
    group_low = np.empty((ngy, ngx), values.dtype)
    for gy in range(ngy):
        for gx in range(ngx):
            m = low[gy * group, gx * group]
            for jy in range(gy * group, (gy + 1) * group):
                for jx in range(gx * group, (gx + 1) * group):
                    m = min(m, low[jy, jx])
            group_low[gy, gx] = m
    return low, group_low


@njit(cache=CACHE, fastmath=FASTMATH)
def _row_cones(values, apex, low, group_low, r, origin, p_max, d_min, footprint, c_max, out):
    """The cones of texel row ``r`` into ``out[r]`` (:func:`_cone_kernel`). A function of
    its own, called from the parallel loop, whose body is then small (about 1 s less to
    compile)."""
    rows, cols = values.shape
    block = _CONE_BLOCK
    group = _CONE_GROUP
    size = group * block
    by = (r + origin) // block
    for c in range(cols):
        a = apex[r, c]
        best = c_max
        span = a - d_min
        if span <= 0.0:
            out[r, c] = best
            continue
        bx = (c + origin) // block
        # the nearest rings block by block, nearest first
        done = False
        for q in range(_NEAR_RINGS + 1):
            # ring 0, the texel's own block, is always searched
            if q > 0 and _ring_cannot_beat(q, block, rows, cols, span, best, footprint):
                done = True
                break
            for jy in range(by - q, by + q + 1):
                step = 1 if jy == by - q or jy == by + q else 2 * q
                for jx in range(bx - q, bx + q + 1, step):
                    best = _block_cones(values, low, jy, jx, r, c, a, best, origin,
                                        footprint)
        if not done:
            # then rings of groups of blocks: a group whose bound cannot beat the cone
            # is passed over whole; the blocks searched above are not searched again
            hy = (r + origin) // size
            hx = (c + origin) // size
            for p in range(p_max + 1):
                if p > 0 and _ring_cannot_beat(p, size, rows, cols, span, best, footprint):
                    break
                for gy in range(hy - p, hy + p + 1):
                    step = 1 if gy == hy - p or gy == hy + p else 2 * p
                    u0 = gy * size - origin
                    for gx in range(hx - p, hx + p + 1, step):
                        group_diff = a - group_low[gy, gx]
                        if group_diff <= 0.0:
                            continue
                        if _square_cannot_beat(u0 - r, gx * size - origin - c, size, rows,
                                               cols, best, group_diff, footprint):
                            continue
                        for jy in range(gy * group, (gy + 1) * group):
                            for jx in range(gx * group, (gx + 1) * group):
                                if abs(jy - by) <= _NEAR_RINGS and abs(jx - bx) <= _NEAR_RINGS:
                                    continue
                                best = _block_cones(values, low, jy, jx, r, c, a, best,
                                                    origin, footprint)
        out[r, c] = best


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _cone_kernel(values, apex, footprint, c_max, out, stop):
    """Cone ratios into ``out``: for each texel, the least UV distance ÷ (apex − value) over
    every cell whose value lies below the texel's apex, distances wrapping around. With
    ``footprint``, box-to-box distances from the texel's footprint to each cell; otherwise
    from centre to centre. Rows not yet begun are left unwritten once ``stop[0]`` is set
    (:func:`run_stoppable`)."""
    rows, cols = values.shape
    d_min = values.min()
    block = _CONE_BLOCK
    group = _CONE_GROUP
    size = group * block
    # rings of groups far enough to reach every offset the cells can wrap to
    p_max = (max(rows, cols) // 2 + 1) // size + 2
    origin = (p_max + 1) * size  # cell u lies in block (u + origin) // block
    low, group_low = _block_minima(values, origin, (rows + 2 * origin + size - 1) // size,
                                   (cols + 2 * origin + size - 1) // size)
    for r in prange(rows):
        if stop_requested(stop):
            continue
        _row_cones(values, apex, low, group_low, r, origin, p_max, d_min, footprint, c_max,
                   out)


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
    out = np.empty_like(depth)
    run_stoppable(depth.size > _LONG_TEXELS, _cone_kernel, depth, depth, False, c_max, out)
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
    # Minima of two neighbours, then of two of those: the same values as the minimum of the
    # four corners (corner_depths), without its (rows, cols, 4) stack, whose reduction over
    # the short last axis took 2.9 s at 4096² (`scripts/cone_map_time.py --preparation`),
    # all before Ctrl-C can stop the call.
    pair_min = np.minimum(depth, np.roll(depth, -1, axis=1))
    cell_min = np.minimum(pair_min, np.roll(pair_min, -1, axis=0))
    # The four cells overlapping texel i's footprint are k ∈ {i − 1, i} on each axis.
    apex = np.minimum(cell_min, np.roll(cell_min, 1, axis=1))
    apex = np.minimum(apex, np.roll(apex, 1, axis=0))
    out = np.empty_like(depth)
    run_stoppable(depth.size > _LONG_TEXELS, _cone_kernel, cell_min, apex, True, c_max, out)
    return np.stack([apex, out], axis=-1).astype(np.float32)


__all__ = ["cone_map", "cone_map_bruteforce", "footprint_cone_map"]
