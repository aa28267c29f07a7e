"""Texture splatting alpha maps (Filipović 2008 §3.1.3, after Charles Bloom).

Input is a per-*cell* material map ``ids (rows-1, cols-1)`` (cell ``(a, b)`` is the quad
between vertices ``(a, b)`` and ``(a+1, b+1)``). Output alpha maps are per-*vertex*
``(L, rows, cols)``, the resolution of the heightmap, so a renderer can upload them as a
texture aligned with the mesh vertices.

The weight (Filipović 2008, formula 1) of a neighbouring cell at distance ``d`` (in cells, between
cell centres) is ``1 - d²/1.75²``: 1 for the cell itself, ``1 - 1/1.75² ≈ 0.673`` for the
4 edge neighbours, ``1 - 2/1.75² ≈ 0.347`` for the 4 diagonal ones, 0 from ``d = 1.75`` on.

Exact definition used here (the sample grid):

1. **cell alpha** — for every cell ``c`` and layer ``m``:
   ``A_m(c) = Σ_{n ∈ 3×3(c), n inside the map, id(n) = m} w(d(c, n)) / Σ_{n ∈ 3×3(c) inside} w``
   (the thesis's "accumulate, then normalise"; the sum over layers is 1).
2. **vertex alpha** — vertex ``(i, j)`` takes the mean of ``A_m`` over the 1, 2 or 4 cells
   that share it (cells ``(i-1..i, j-1..j)`` inside the map), i.e. the value bilinear
   filtering of the cell-centred map gives at the vertex. Sums stay 1.

The seed computes alpha maps block by block (32×32 cells, 33×33 vertices), using the
neighbouring blocks' materials at block edges. The kernel does exactly that — one block per
parallel task, cells of a one-cell apron read from the neighbours — so the block size changes
how work is split, never the values (tests compare against a naive per-block loop).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, prange
from terrascape._validate import check_int
from terrascape.errors import HeightmapSizeError, InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.texture.regions import (
    Region,
    SlopeRule,
    _check_regions,
    _region_arrays,
    _resolve_slope_rule,
    _texel_weights,
    _water_index,
    _water_level,
    default_regions,
)

#: Falloff radius of the thesis's formula 1.
SPLAT_RADIUS = 1.75


def splat_neighbour_weight(d2: float) -> float:
    """Filipović 2008 formula 1: ``max(0, 1 - d²/1.75²)`` for squared distance ``d2`` (cells²)."""
    return max(0.0, 1.0 - d2 / SPLAT_RADIUS**2)


def material_ids_from_rules(
    heightmap: Heightmap | Any,
    regions: list[Region] | None = None,
    *,
    slope_rule: SlopeRule | bool | None = True,
) -> np.ndarray:
    """Per-cell material ids from the height/slope region rules.

    Each cell gets the index (into ``regions``) of the region with the largest
    :func:`~terrascape.texture.regions.region_weights` weight at the cell centre (first one on
    ties): height = mean of the 4 corner heights, slope = mean of the 4 corner slopes
    (:meth:`Heightmap.slope`), no jitter.

    Returns
    -------
    numpy.ndarray
        ``uint8 (rows-1, cols-1)``.
    """
    hm = heightmap if isinstance(heightmap, Heightmap) else Heightmap(heightmap)
    regions = _check_regions(default_regions(hm) if regions is None else regions)
    rule, s0, s1 = _resolve_slope_rule(slope_rule, regions)
    slope = hm.slope() if rule >= 0 else np.zeros((2, 2), np.float32)
    maxs, ranges, amps, lat1, lat2 = _region_arrays(regions, 0.0, 0)
    out = np.empty((hm.rows - 1, hm.cols - 1), dtype=np.uint8)
    _ids_kernel(hm.heights, slope, rule >= 0, maxs, ranges, amps, lat1, lat2, rule,
                _water_index(regions), s0, s1, _water_level(regions, None), out)
    return out


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _ids_kernel(heights, slope, use_slope, maxs, ranges, amps, lat1, lat2, rule, water, s0, s1,
                water_level, out):
    nr, nc = out.shape
    n = maxs.shape[0]
    for i in prange(nr):
        w = np.empty(n)
        for j in range(nc):
            # Cell centre: mean of the 4 corners (= bilinear interpolation at the centre).
            h = 0.25 * (np.float64(heights[i, j]) + heights[i, j + 1] + heights[i + 1, j]
                        + heights[i + 1, j + 1])
            s = 0.0
            if use_slope:
                s = 0.25 * (np.float64(slope[i, j]) + slope[i, j + 1] + slope[i + 1, j]
                            + slope[i + 1, j + 1])
            _texel_weights(h, s, 0.0, 0.0, maxs, ranges, amps, lat1, lat2, rule, water, s0,
                           s1, w, water_level)
            best = 0
            for r in range(1, n):
                if w[r] > w[best]:  # first maximum wins ties, like numpy.argmax
                    best = r
            out[i, j] = best


def _check_ids(material_ids: Any, n_materials: int | None) -> tuple[np.ndarray, int]:
    ids = np.asarray(material_ids)
    if ids.ndim != 2 or ids.shape[0] < 1 or ids.shape[1] < 1:
        raise InvalidParameterError(
            f"material ids must be a 2-D per-cell array (rows-1, cols-1), got shape {ids.shape}"
        )
    if not np.issubdtype(ids.dtype, np.integer):
        if np.issubdtype(ids.dtype, np.floating) and np.isfinite(ids).all() and np.all(
            ids == np.round(ids)
        ):
            ids = ids.astype(np.int64)
        else:
            raise InvalidParameterError(
                f"material ids must be integers, got dtype {ids.dtype}"
            )
    lo, hi = int(ids.min()), int(ids.max())
    if lo < 0:
        raise InvalidParameterError(f"material ids must be >= 0, got minimum {lo}")
    if n_materials is None:
        n_materials = hi + 1
    n_materials = check_int(n_materials, "n_materials", minimum=1, maximum=256)
    if hi >= n_materials:
        raise InvalidParameterError(
            f"material id {hi} is out of range for n_materials={n_materials} "
            f"(ids 0..{n_materials - 1})"
        )
    return np.ascontiguousarray(ids, dtype=np.int64), n_materials


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _splat_kernel(ids, n_layers, block, w_edge, w_diag, out):
    nr, nc = ids.shape  # cells
    nby = (nr + block - 1) // block
    nbx = (nc + block - 1) // block
    for b in prange(nby * nbx):
        by = b // nbx
        bx = b - by * nbx
        r0 = by * block
        c0 = bx * block
        r1 = min(r0 + block, nr)
        c1 = min(c0 + block, nc)
        # Vertices owned by this block: [r0, r1) × [c0, c1), plus the far map edge for the
        # last block row/column. Shared block-edge vertices are written once (no races).
        vr1 = r1 + 1 if r1 == nr else r1
        vc1 = c1 + 1 if c1 == nc else c1
        # Cells touching those vertices: the block plus a one-cell apron above/left.
        cr0 = max(r0 - 1, 0)
        cc0 = max(c0 - 1, 0)
        cr1 = min(vr1, nr)
        cc1 = min(vc1, nc)
        alpha = np.zeros((cr1 - cr0, cc1 - cc0, n_layers))
        for ci in range(cr0, cr1):
            for cj in range(cc0, cc1):
                total = 0.0
                for di in range(-1, 2):
                    ni = ci + di
                    if ni < 0 or ni >= nr:
                        continue
                    for dj in range(-1, 2):
                        nj = cj + dj
                        if nj < 0 or nj >= nc:
                            continue
                        k = abs(di) + abs(dj)
                        wt = 1.0 if k == 0 else (w_edge if k == 1 else w_diag)
                        alpha[ci - cr0, cj - cc0, ids[ni, nj]] += wt
                        total += wt
                for m in range(n_layers):
                    alpha[ci - cr0, cj - cc0, m] /= total
        acc = np.empty(n_layers)
        for vi in range(r0, vr1):
            for vj in range(c0, vc1):
                for m in range(n_layers):
                    acc[m] = 0.0
                count = 0
                for ci in range(vi - 1, vi + 1):
                    if ci < 0 or ci >= nr:
                        continue
                    for cj in range(vj - 1, vj + 1):
                        if cj < 0 or cj >= nc:
                            continue
                        count += 1
                        for m in range(n_layers):
                            acc[m] += alpha[ci - cr0, cj - cc0, m]
                for m in range(n_layers):
                    out[m, vi, vj] = acc[m] / count


def splat_weights(
    material_ids: Any,
    n_materials: int | None = None,
    *,
    block: int = 32,
    grid: Heightmap | tuple[int, int] | None = None,
) -> np.ndarray:
    """Per-vertex splat alpha maps from a per-cell material map (Filipović 2008 §3.1.3).

    Parameters
    ----------
    material_ids
        Integer ``(rows-1, cols-1)`` array, one material (layer) index per cell.
    n_materials
        Number of layers ``L`` (default ``max(id) + 1``); ids must be ``< L``.
    block
        Block side in cells for the thesis's block-wise computation (32 in the seed). The values
        do not depend on it (see the module docstring).
    grid
        Optional heightmap (or its ``(rows, cols)``) the maps must align with: the ids must
        then be ``(rows-1, cols-1)``, else :class:`~terrascape.errors.HeightmapSizeError`.

    Returns
    -------
    numpy.ndarray
        ``float32 (L, rows, cols)`` at vertex resolution; each vertex's weights sum to 1.
    """
    ids, n = _check_ids(material_ids, n_materials)
    if grid is not None:
        check_material_map(grid, ids)
    block = check_int(block, "block", minimum=1, maximum=1 << 16)
    out = np.empty((n, ids.shape[0] + 1, ids.shape[1] + 1), dtype=np.float32)
    w_edge = splat_neighbour_weight(1.0)
    w_diag = splat_neighbour_weight(2.0)
    _splat_kernel(ids, n, block, w_edge, w_diag, out)
    return out


def check_material_map(grid: Heightmap | tuple[int, int], material_ids: Any) -> None:
    """Raise :class:`HeightmapSizeError` unless ids are per-cell ``(rows-1, cols-1)``."""
    if isinstance(grid, Heightmap):
        rows, cols = grid.shape
    else:
        rows, cols = (int(v) for v in grid)
    shape = np.shape(material_ids)
    if tuple(shape) != (rows - 1, cols - 1):
        raise HeightmapSizeError(
            f"material map must have one id per cell, {cols - 1}×{rows - 1} (cols×rows) for a "
            f"{cols}×{rows} heightmap, got {'×'.join(map(str, shape[::-1]))}"
        )


def block_layers(weights: Any, *, block: int = 32) -> np.ndarray:
    """Which layers touch each block: ``bool (n_blocks_z, n_blocks_x, L)``.

    The thesis's renderer draws, per 32×32-cell block, one pass per texture that affects the
    block; a layer affects a block when any of its 33×33 vertices has a weight > 0.
    """
    w = _check_weights(weights)
    block = check_int(block, "block", minimum=1, maximum=1 << 16)
    n, rows, cols = w.shape
    nby = -(-(rows - 1) // block)
    nbx = -(-(cols - 1) // block)
    out = np.zeros((nby, nbx, n), dtype=bool)
    positive = w > 0
    for by in range(nby):
        for bx in range(nbx):
            tile = positive[:, by * block : (by + 1) * block + 1, bx * block : (bx + 1) * block + 1]
            out[by, bx] = tile.any(axis=(1, 2))
    return out


def _check_weights(weights: Any) -> np.ndarray:
    w = np.asarray(weights)
    if w.ndim != 3 or w.shape[0] < 1:
        raise InvalidParameterError(f"weights must be (L, rows, cols), got shape {w.shape}")
    if w.shape[1] < 1 or w.shape[2] < 1:
        raise HeightmapSizeError(f"weights must have at least 1×1 samples, got {w.shape[1:]}")
    w = np.ascontiguousarray(w, dtype=np.float32)
    if not np.isfinite(w).all():
        raise InvalidParameterError("weights contain NaN/infinite values")
    return w


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _pack_kernel(w, out):
    n, rows, cols = w.shape
    for i in prange(rows):
        q = np.empty(n, dtype=np.int64)
        frac = np.empty(n)
        for j in range(cols):
            total = 0
            for m in range(n):
                x = w[m, i, j] * 255.0
                q[m] = int(np.floor(x))
                frac[m] = x - q[m]
                total += q[m]
            # Largest-remainder rounding: the channels of all images sum to exactly 255, so a
            # shader's weighted sum never brightens or darkens the terrain.
            deficit = 255 - total
            while deficit > 0:
                best = 0
                for m in range(1, n):
                    if frac[m] > frac[best]:
                        best = m
                q[best] += 1
                frac[best] = -1.0
                deficit -= 1
            for m in range(n):
                out[m // 4, i, j, m % 4] = q[m]


def pack_splat_maps(weights: Any) -> list[np.ndarray]:
    """Pack layer weights into RGBA8 images, 4 layers per image (Filipović 2008 §3.1.3, Slika 15).

    Layer ``k`` goes to image ``k // 4``, channel ``k % 4`` (R, G, B, A); unused channels of
    the last image are 0. Values are quantised with largest-remainder rounding so each
    vertex's channels over all images sum to exactly 255.

    Parameters
    ----------
    weights
        ``(L, rows, cols)`` weights in ``[0, 1]`` summing to 1 per vertex (e.g.
        :func:`splat_weights`).

    Returns
    -------
    list of numpy.ndarray
        ``ceil(L/4)`` arrays ``uint8 (rows, cols, 4)``.
    """
    w = _check_weights(weights)
    lo, hi = float(w.min()), float(w.max())
    if lo < 0.0 or hi > 1.0 + 1e-6:
        raise InvalidParameterError(f"weights must be in [0, 1], got [{lo:.4g}, {hi:.4g}]")
    sums = w.sum(axis=0, dtype=np.float64)
    worst = float(np.abs(sums - 1.0).max())
    if worst > 1e-3:
        raise InvalidParameterError(
            f"weights must sum to 1 per sample (normalise them first), worst sum is "
            f"off by {worst:.4g}"
        )
    n = w.shape[0]
    packed = np.zeros(((n + 3) // 4, w.shape[1], w.shape[2], 4), dtype=np.uint8)
    _pack_kernel(w, packed)
    return list(packed)


def unpack_splat_maps(images: list[np.ndarray], n_layers: int | None = None) -> np.ndarray:
    """Inverse of :func:`pack_splat_maps`: ``float32 (L, rows, cols)`` weights (value/255).

    ``n_layers`` defaults to ``4 × len(images)``.
    """
    imgs = [np.asarray(im) for im in images]
    if not imgs:
        raise InvalidParameterError("expected at least one splat image, got none")
    for k, im in enumerate(imgs):
        if im.ndim != 3 or im.shape[2] != 4 or im.dtype != np.uint8:
            raise InvalidParameterError(
                f"splat image {k} must be uint8 (rows, cols, 4) RGBA, got {im.dtype} {im.shape}"
            )
        if im.shape != imgs[0].shape:
            raise InvalidParameterError(
                f"splat images differ in size: {imgs[0].shape} vs {im.shape} (image {k})"
            )
    n = 4 * len(imgs) if n_layers is None else check_int(
        n_layers, "n_layers", minimum=1, maximum=4 * len(imgs)
    )
    stacked = np.concatenate([np.moveaxis(im, 2, 0) for im in imgs], axis=0)[:n]
    return stacked.astype(np.float32) / np.float32(255.0)


__all__ = [
    "SPLAT_RADIUS",
    "block_layers",
    "check_material_map",
    "material_ids_from_rules",
    "pack_splat_maps",
    "splat_neighbour_weight",
    "splat_weights",
    "unpack_splat_maps",
]
