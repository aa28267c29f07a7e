"""Chunked level of detail over a world's pyramid: a quadtree of tiles, each a fixed-size grid
at the pyramid level its screen-space error allows, crack-free by skirts, culled by min/max.

A tile ``(level k, row i, col j)`` spans ``tile`` cells of pyramid level ``k`` per side
(``tile · 2**k`` full-resolution cells), so its mesh always has at most ``(tile + 1)²``
vertices — the level-k samples — whatever its size on the ground; its four children are the
level ``k − 1`` tiles of the same ground. The roots are the tiles of the top level ``L``
(one tile for a ``2**n + 1`` world whose side is at most ``tile · 2**L`` cells).

Error bound (de Boer's geomipmapping δ, made exact and hierarchical): the mesh of a tile is
the piecewise-linear interpolant of its level-k samples (two triangles per cell, the
anti-diagonal split of :func:`terrascape.mesh.terrain_mesh.grid_triangles`). With one
diagonal direction at every level a level-(k−1) triangle lies inside one level-k triangle,
so ``I_{k−1} − I_k`` is linear on level-(k−1) triangles and its largest value is at a
level-(k−1) vertex; by the triangle inequality

    e_k(tile) = max over the tile's level-(k−1) vertices |h_{k−1} − I_k| + max over children e_{k−1}

bounds ``|h_0 − I_k|`` everywhere in the tile (``e_0 = 0``). The bound sums every level's
error as if they all peaked at one point; they seldom do, and a bound above the real error
splits tiles the tolerance would keep. So the levels whose tiles span at most
:data:`EXACT_ROWS` full-resolution rows — the ones a view draws near the eye — store the exact
``max |h_0 − I_k|`` instead (also at a sample: ``I_0 − I_k`` is linear on level-0
triangles), measured in the same pass over level 0, and only the levels above use the sum,
over exact children. One pass over each pyramid level, in bands of rows, builds the table
(memory bounded by a band, not the map); it is cached next to the store.

Selection (Ulrich 2002's chunked LOD): starting from the roots, the tile whose projected
error ``e · K / d`` (``K`` = pixels per radian, ``d`` = distance from the eye to the tile's
box) is the largest is split, until every visible tile is within ``tolerance`` pixels or
the tile budget is reached; tiles outside the view frustum (their box: the stored min/max
height of their ground) are never split. The selection is then balanced (neighbouring leaves
differ by at most one level), which bounds the skirts below.

Simplified tiles (the viewer): a tile is drawn at the first level whose error projects
within the tolerance at its nearest point, so its own error often uses half the tolerance
or less. The table also bounds, per tile, the error of the *bintree* interpolant ``B_k`` of
its samples (cells split along alternating diagonals, as the finest level of a ``2**m + 1``
bintree splits them, :func:`bintree_cells`; the same hierarchy holds, a level-(k−1) bintree
triangle lying inside a level-k one). A drawn tile then takes the coarsest bintree mesh of
its samples within the error the view leaves it, ``tolerance·d/K − e_k(B)``
(:func:`tile_bintree_errors`, :func:`simplified_tile_triangles`, after RTIN's nested
errors, :mod:`terrascape.lod.rtin`): the mesh is within that of ``B_k`` and so within the
tolerance of ``h_0``. Its border keeps every sample, so its edges are the grid's edges and
the skirts below hold as they are.

Cracks: at an edge shared by tiles A and B, A's edge is the interpolant of samples on the
edge line and so is B's; B's value at any point of the edge lies between two of B's samples
at most one B cell away — within the ground of A's parent's 3×3 neighbourhood (B is at most
one level coarser). A vertical skirt hanging from every tile edge down to the lowest height
of that neighbourhood therefore closes every gap. Two tiles of one level have the same
samples on their shared edge, so no gap opens there: a frame draws the skirts of the other
edges only (:func:`skirt_edges`).

References
----------
.. [1] de Boer, W. H. (2000). Fast terrain rendering using geometrical mipmapping.
.. [2] Ulrich, T. (2002). Rendering massive terrains using chunked level of detail control.
   SIGGRAPH course notes, "Super-size it! Scaling up to massive virtual worlds".
.. [3] Strugar, F. (2010). Continuous distance-dependent level of detail for rendering
   heightmaps. Journal of Graphics, GPU, and Game Tools 14(4).
.. [4] Assarsson, U., Möller, T. (2000). Optimized view frustum culling algorithms for
   bounding boxes. Journal of Graphics Tools 5(1).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import heapq
import io
import math
import select
import threading
import time
from collections import OrderedDict
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from scipy.ndimage import minimum_filter

from terrascape._numba import CACHE, FASTMATH, njit
from terrascape._validate import check_int, check_positive
from terrascape.camera import Camera
from terrascape.errors import InvalidParameterError, MemoryLimitError
from terrascape.lod.rtin import _nest_errors, _triangles_of, _vertex_errors
from terrascape.mesh.tangent_space import heightfield_tangent_frames
from terrascape.mesh.terrain_mesh import grid_triangles

#: Cells per tile side (a tile mesh has at most (DEFAULT_TILE + 1)² vertices).
DEFAULT_TILE = 32
#: Bytes per tile vertex: position (3 f4), normal (3 f4), tangent + handedness (4 f4).
VERTEX_BYTES = 40
#: Full-resolution rows of the tiles whose errors the tile table holds exactly (levels
#: ``1 … log2(EXACT_ROWS / tile)``; the levels above hold the hierarchical bound).
EXACT_ROWS = 1024
# 3: the upper levels bounded through a finer one; 4: the bintree interpolants' bounds too
_CACHE_NAME = "terrascape_lod4_{tile}.npz"

#: Reads samples ``[a0:a1, b0:b1]`` of pyramid level ``level`` (0 = full resolution).
LevelReader = Callable[[int, int, int, int, int], np.ndarray]


class TileKey(NamedTuple):
    level: int
    row: int
    col: int


@dataclass(frozen=True)
class TileGrid:
    """The quadtree's geometry: which tiles exist and the ground each one covers."""

    shape: tuple[int, int]
    spacing: float
    tile: int
    top: int

    def __post_init__(self) -> None:
        counts = []
        for k in range(self.top + 1):
            cr, cc = (self.shape[0] - 1) >> k, (self.shape[1] - 1) >> k
            counts.append((-(-cr // self.tile), -(-cc // self.tile)))
        object.__setattr__(self, "_counts", tuple(counts))  # looked up per tile per frame

    def cells(self, level: int) -> tuple[int, int]:
        """Cells of pyramid ``level`` along rows and columns."""
        return (self.shape[0] - 1) >> level, (self.shape[1] - 1) >> level

    def count(self, level: int) -> tuple[int, int]:
        """Tiles of ``level`` along rows and columns."""
        return self._counts[level]

    def exists(self, key: TileKey) -> bool:
        k, i, j = key
        if not 0 <= k <= self.top:
            return False
        nr, nc = self._counts[k]
        return 0 <= i < nr and 0 <= j < nc

    def samples(self, key: TileKey) -> tuple[int, int, int, int]:
        """Level-``key.level`` sample range ``a0, a1, b0, b1`` (inclusive ends) of a tile."""
        cr, cc = self.cells(key.level)
        t = self.tile
        return (key.row * t, min((key.row + 1) * t, cr), key.col * t, min((key.col + 1) * t, cc))

    def span(self, key: TileKey) -> tuple[int, int, int, int]:
        """Full-resolution sample range ``r0, r1, c0, c1`` (inclusive ends) of a tile."""
        a0, a1, b0, b1 = self.samples(key)
        s = key.level
        return a0 << s, a1 << s, b0 << s, b1 << s

    def roots(self) -> list[TileKey]:
        nr, nc = self.count(self.top)
        return [TileKey(self.top, i, j) for i in range(nr) for j in range(nc)]

    def children(self, key: TileKey) -> list[TileKey]:
        k, i, j = key
        if k == 0:
            return []
        nr, nc = self._counts[k - 1]
        return [TileKey(k - 1, 2 * i + di, 2 * j + dj) for di in (0, 1) for dj in (0, 1)
                if 2 * i + di < nr and 2 * j + dj < nc]

    def parent(self, key: TileKey) -> TileKey | None:
        k, i, j = key
        return None if k >= self.top else TileKey(k + 1, i >> 1, j >> 1)

    def vertex_count(self, key: TileKey) -> int:
        a0, a1, b0, b1 = self.samples(key)
        n_r, n_c = a1 - a0 + 1, b1 - b0 + 1
        return n_r * n_c + 2 * (n_r + n_c - 2)

    def max_tile_bytes(self) -> int:
        """Bytes of the largest tile mesh (vertices; the index lists are shared)."""
        return _max_tile_bytes(self.tile)


def _max_tile_bytes(tile: int) -> int:
    """Bytes of a full tile of ``tile`` cells a side: the vertices of its grid and its
    skirt ring, and its grid vertices' bintree errors (float32)."""
    return ((tile + 1) ** 2 + 4 * tile) * VERTEX_BYTES + (tile + 1) ** 2 * 4


def tile_grid(shape: tuple[int, int], spacing: float, tile: int = DEFAULT_TILE) -> TileGrid:
    """The quadtree over a map of ``shape`` samples: the top level is the coarsest pyramid
    level that keeps the map's last row and column (``(side − 1)`` divisible by ``2**L``)
    and still needs more than one level-``L − 1`` tile."""
    rows, cols = (check_int(v, "map side", minimum=2) for v in shape)
    tile = check_int(tile, "tile (cells per side)", minimum=2, maximum=4096)
    check_positive(spacing, "spacing")
    top = 0
    while (((rows - 1) >> top) % 2 == 0 and ((cols - 1) >> top) % 2 == 0
           and max(rows - 1, cols - 1) > tile << top):
        top += 1
    return TileGrid((rows, cols), float(spacing), tile, top)


@dataclass
class TilePyramid:
    """A :class:`TileGrid` with each tile's error bound and height range.

    ``error[k]`` (world height units, before exaggeration): the bound ``e_k`` of the module
    docstring for every tile of level ``k``; ``low[k]``, ``high[k]``: the lowest and highest
    full-resolution height of its ground; ``skirt[k]``: where its skirts end (the lowest
    height of its parent's 3×3 neighbourhood).
    """

    grid: TileGrid
    error: list[np.ndarray]
    low: list[np.ndarray]
    high: list[np.ndarray]
    #: The same bound against the bintree interpolant ``B_k`` of the tile's samples
    #: (:func:`bintree_cells`), which the simplified tile meshes refine (None: not known).
    error_bintree: list[np.ndarray] | None = None
    skirt: list[np.ndarray] = field(init=False)

    def __post_init__(self) -> None:
        g = self.grid
        relief = float(self.high[g.top].max() - self.low[g.top].min())
        margin = 1e-3 * max(relief, g.spacing)  # float rounding of the interpolants
        self.skirt = []
        for k in range(g.top + 1):
            k1 = min(k + 1, g.top)
            around = minimum_filter(self.low[k1], size=3, mode="nearest")
            nr, nc = g.count(k)
            if k1 == k:
                self.skirt.append(around - margin)
            else:
                i, j = np.arange(nr) >> 1, np.arange(nc) >> 1
                self.skirt.append(around[np.ix_(i, j)] - margin)

    def boxes(self, level: int, exaggeration: float = 1.0) -> np.ndarray:
        """``(rows, cols, 6)`` boxes of every tile of ``level`` (as :meth:`box`)."""
        g = self.grid
        cr, cc = g.cells(level)
        nr, nc = g.count(level)
        t, s = g.tile, level
        r0 = (np.arange(nr) * t) << s
        r1 = np.minimum((np.arange(nr) + 1) * t, cr) << s
        c0 = (np.arange(nc) * t) << s
        c1 = np.minimum((np.arange(nc) + 1) * t, cc) << s
        sp = g.spacing
        out = np.empty((nr, nc, 6))
        out[..., 0] = (c0 * sp)[None, :]
        out[..., 1] = self.skirt[level] * exaggeration
        out[..., 2] = (r0 * sp)[:, None]
        out[..., 3] = (c1 * sp)[None, :]
        out[..., 4] = self.high[level] * exaggeration
        out[..., 5] = (r1 * sp)[:, None]
        return out

    def box(self, key: TileKey, exaggeration: float = 1.0) -> np.ndarray:
        """``x0, y0, z0, x1, y1, z1`` of the tile with its skirts."""
        r0, r1, c0, c1 = self.grid.span(key)
        sp = self.grid.spacing
        k, i, j = key
        return np.array([c0 * sp, float(self.skirt[k][i, j]) * exaggeration, r0 * sp,
                         c1 * sp, float(self.high[k][i, j]) * exaggeration, r1 * sp])


# --- the error table ---------------------------------------------------------------------

def _midpoint_error(fine: np.ndarray, *, bintree: bool = False,
                    row0: int = 0) -> np.ndarray:
    """``|h_{k−1} − I_k|`` at every sample of a level-(k−1) block whose even samples are
    level k (rows and columns both odd in number): 0 at the coarse vertices, the edge
    midpoints against their edge's mean, the cell centres against their diagonal's.

    ``bintree``: ``I_k`` is the bintree interpolant :math:`B_k` (cell ``(a, b)`` split along
    ``(a, b)–(a+1, b+1)`` where ``a + b`` is even, :func:`bintree_cells`), the block's
    first coarse row being row ``row0`` of level k (its columns start at 0)."""
    f = fine.astype(np.float64)
    c = f[::2, ::2]
    err = np.zeros_like(f)
    err[::2, 1::2] = np.abs(f[::2, 1::2] - 0.5 * (c[:, :-1] + c[:, 1:]))
    err[1::2, ::2] = np.abs(f[1::2, ::2] - 0.5 * (c[:-1, :] + c[1:, :]))
    # cell (a, b) is split along (a+1, b)–(a, b+1): its centre is that diagonal's midpoint
    anti = 0.5 * (c[1:, :-1] + c[:-1, 1:])
    if bintree:
        a = np.arange(row0, row0 + c.shape[0] - 1)[:, None]
        b = np.arange(c.shape[1] - 1)[None, :]
        anti = np.where((a + b) % 2 == 0, 0.5 * (c[:-1, :-1] + c[1:, 1:]), anti)
    err[1::2, 1::2] = np.abs(f[1::2, 1::2] - anti)
    return err


def _tile_reduce(values: np.ndarray, cells: int, n_c: int, reduce) -> np.ndarray:
    """Per tile of ``cells`` cells (closed: a tile's last row/column is its neighbour's
    first), ``reduce`` (np.max/np.min) of a block whose rows are one row of tiles."""
    out = np.empty(n_c, dtype=np.float64)
    for j in range(n_c):
        out[j] = reduce(values[:, j * cells:(j + 1) * cells + 1])
    return out


def _band_rows(grid: TileGrid, level: int, block: int) -> int:
    """Tile rows of ``level`` per band of the error pass (about ``block`` samples high)."""
    cells = grid.tile << 1 if level > 0 else grid.tile  # level-(k−1) cells per level-k tile
    return max(1, block // cells)


@njit(cache=CACHE, fastmath=FASTMATH)
def _exact_error_kernel(band, r0, level, tile, rows, cols, out,
                        out_b):  # pragma: no cover - jitted
    """``out[i, j]`` = max ``|h_0 − I_level|`` over the full-resolution samples of the
    level-``level`` tile ``(i_first + i, j)`` (closed ranges), ``band`` holding full-
    resolution rows ``r0 …`` of the whole width; ``rows``, ``cols``: the map's cells;
    ``out_b`` the same against the bintree interpolant ``B_level``.

    Cell by cell of the level's grid: each sample belongs to the cell it starts (a tile's
    last row and column to its last cell), whose four corners are read once."""
    s = 1 << level
    span = tile * s
    inv = 1.0 / s
    i_first = r0 // span
    for ti in range(out.shape[0]):
        ga0 = (i_first + ti) * span
        ga1 = min(ga0 + span, rows)
        a_first, a_last = ga0 // s, ga1 // s - 1
        for tj in range(out.shape[1]):
            gb0 = tj * span
            gb1 = min(gb0 + span, cols)
            b_first, b_last = gb0 // s, gb1 // s - 1
            worst = 0.0
            worst_b = 0.0
            for a in range(a_first, a_last + 1):
                ra = a * s - r0
                r_end = s if a < a_last else ga1 - a * s + 1
                for b in range(b_first, b_last + 1):
                    cb = b * s
                    c_end = s if b < b_last else gb1 - cb + 1
                    h00 = np.float64(band[ra, cb])
                    h01 = np.float64(band[ra, cb + s])
                    h10 = np.float64(band[ra + s, cb])
                    h11 = np.float64(band[ra + s, cb + s])
                    # the bintree splits this cell the other way when a + b is even
                    even = (a + b) % 2 == 0
                    for dr in range(r_end):
                        v = dr * inv
                        row = band[ra + dr]
                        for dc in range(c_end):
                            u = dc * inv
                            # the cell is split along (a+1, b)–(a, b+1), as grid_triangles
                            if u + v <= 1.0:
                                interp = h00 + u * (h01 - h00) + v * (h10 - h00)
                            else:
                                interp = h11 + (1.0 - u) * (h10 - h11) + (1.0 - v) * (h01 - h11)
                            z = np.float64(row[cb + dc])
                            e = abs(z - interp)
                            if e > worst:
                                worst = e
                            if even:  # split along (a, b)–(a+1, b+1)
                                if u >= v:
                                    interp = h00 + u * (h01 - h00) + v * (h11 - h01)
                                else:
                                    interp = h00 + v * (h10 - h00) + u * (h11 - h10)
                                e = abs(z - interp)
                            if e > worst_b:
                                worst_b = e
            out[ti, tj] = worst
            out_b[ti, tj] = worst_b


@njit(cache=CACHE)
def _tile_range_kernel(band, tile, low, high):  # pragma: no cover - jitted
    """``low[i, j]``, ``high[i, j]``: the least and greatest sample of tile ``(i, j)`` of a
    band whose rows are ``low.shape[0]`` rows of tiles (closed: a tile's last row and
    column are its neighbours' first)."""
    n_r, n_c = band.shape
    for i in range(low.shape[0]):
        for j in range(low.shape[1]):
            lo, hi = np.inf, -np.inf
            for r in range(i * tile, min((i + 1) * tile + 1, n_r)):
                for c in range(j * tile, min((j + 1) * tile + 1, n_c)):
                    x = np.float64(band[r, c])
                    lo = min(lo, x)
                    hi = max(hi, x)
            low[i, j] = lo
            high[i, j] = hi


def build_pyramid(reader: LevelReader, shape: tuple[int, int], spacing: float, *,
                  tile: int = DEFAULT_TILE, block: int = 1024,
                  exact_rows: int | None = None) -> TilePyramid:
    """The error bounds and height ranges of every tile, reading each pyramid level at most
    once in bands of about ``block`` rows (memory: a band, never the whole map).

    A level whose tiles fit in the level-0 bands gets its exact error, max ``|h_0 − I_k|``
    over the full-resolution samples of the tile (the interpolant of the level-0 samples,
    ``I_0``, differs from ``I_k`` by a function linear on level-0 triangles, so its largest
    value is at a sample); the levels above add their own midpoint error to their children's
    (the hierarchical bound of the module docstring, over exact children). ``exact_rows``:
    that span (default :data:`EXACT_ROWS`; 0: only level 1, where the sum is exact too)."""
    grid = tile_grid(shape, spacing, tile)
    t, top = grid.tile, grid.top
    error: list[np.ndarray] = [np.zeros(grid.count(0))]
    error_b: list[np.ndarray] = [np.zeros(grid.count(0))]  # against the bintree B_k
    # level 0: each finest tile's height range; the levels whose tiles fit a band: exact
    nr0, nc0 = grid.count(0)
    low0, high0 = np.empty((nr0, nc0)), np.empty((nr0, nc0))
    rows, cols = grid.shape[0] - 1, grid.shape[1] - 1
    # a level-k tile is 2**k level-0 tile rows: bands of 2**m of them hold levels 1 … m
    rows_exact = EXACT_ROWS if exact_rows is None else int(exact_rows)
    exact_top = min(top, max(1, (rows_exact // t).bit_length() - 1))
    per = max(1 << exact_top, 1 << (_band_rows(grid, 0, block).bit_length() - 1))
    exact = [np.zeros(grid.count(k)) for k in range(1, exact_top + 1)]
    exact_b = [np.zeros(grid.count(k)) for k in range(1, exact_top + 1)]
    for i0 in range(0, nr0, per):
        i1 = min(nr0, i0 + per)
        a0, a1 = i0 * t, min(i1 * t, rows)
        band = np.ascontiguousarray(reader(0, a0, a1 + 1, 0, cols + 1), dtype=np.float32)
        _tile_range_kernel(band, t, low0[i0:i1], high0[i0:i1])
        for k in range(1, exact_top + 1):
            k0, k1 = i0 >> k, -(-i1 // (1 << k))
            _exact_error_kernel(band, a0, k, t, rows, cols, exact[k - 1][k0:k1],
                                exact_b[k - 1][k0:k1])
    low, high = [low0], [high0]
    for k in range(1, top + 1):
        nr, nc = grid.count(k)
        child_err = np.zeros((nr, nc))
        child_err_b = np.zeros((nr, nc))
        lo_k, hi_k = np.full((nr, nc), np.inf), np.full((nr, nc), -np.inf)
        for di in (0, 1):
            for dj in (0, 1):
                e = error[k - 1][di::2, dj::2]
                sl = (slice(0, e.shape[0]), slice(0, e.shape[1]))
                child_err[sl] = np.maximum(child_err[sl], e)
                child_err_b[sl] = np.maximum(child_err_b[sl], error_b[k - 1][di::2, dj::2])
                lo_k[sl] = np.minimum(lo_k[sl], low[k - 1][di::2, dj::2])
                hi_k[sl] = np.maximum(hi_k[sl], high[k - 1][di::2, dj::2])
        low.append(lo_k)
        high.append(hi_k)
        if k <= exact_top:
            error.append(exact[k - 1])
            error_b.append(exact_b[k - 1])
            continue
        # e_k: the level-(k−1) samples of each level-k tile against the level-k interpolant
        own = np.empty((nr, nc))
        own_b = np.empty((nr, nc))
        fr, fc = grid.cells(k - 1)
        per_k = _band_rows(grid, k, block)
        for i0 in range(0, nr, per_k):
            i1 = min(nr, i0 + per_k)
            a0, a1 = i0 * 2 * t, min(i1 * 2 * t, fr)
            fine = reader(k - 1, a0, a1 + 1, 0, fc + 1)
            err = _midpoint_error(fine)
            err_b = _midpoint_error(fine, bintree=True, row0=a0 // 2)
            for i in range(i0, i1):
                rows_i = slice((i - i0) * 2 * t, (i - i0 + 1) * 2 * t + 1)
                own[i] = _tile_reduce(err[rows_i], 2 * t, nc, np.max)
                own_b[i] = _tile_reduce(err_b[rows_i], 2 * t, nc, np.max)
        bound = own + child_err
        bound_b = own_b + child_err_b
        # a second bound through a finer level j = k − exact_top, exact there:
        # |h_0 − I_k| ≤ |h_0 − I_j| + |I_j − I_k|, the last linear on level-j triangles, so
        # its largest value is at a level-j sample (the exact kernel on level j, in bands as
        # tall as the level-0 ones). Two terms instead of one per level: the sum's terms
        # seldom peak at one point, and a 32769² world's mid-distance tiles (levels 6–10)
        # were split for an error they did not have.
        j = k - exact_top
        if j >= 1:
            relayed, relayed_b = _relayed_error(reader, grid, error[j], error_b[j], j, k,
                                                block)
            bound = np.minimum(bound, relayed)
            bound_b = np.minimum(bound_b, relayed_b)
        error.append(bound)
        error_b.append(bound_b)
    return TilePyramid(grid, error, low, high, error_b)


def _relayed_error(reader: LevelReader, grid: TileGrid, fine_error: np.ndarray,
                   fine_error_b: np.ndarray, j: int, k: int,
                   block: int) -> tuple[np.ndarray, np.ndarray]:
    """Per level-``k`` tile: the largest bound ``fine_error`` of its level-``j`` tiles
    plus max ``|h_j − I_k|`` over its level-``j`` samples; and the same for the bintree
    interpolants (``fine_error_b``, ``B_k``)."""
    t, d = grid.tile, k - j
    nr, nc = grid.count(k)
    fr, fc = grid.cells(j)

    def inner(fine: np.ndarray) -> np.ndarray:
        # the level-j tiles inside each level-k tile (2**d a side; the last may be fewer)
        pad = np.zeros((nr << d, nc << d))
        pad[:fine.shape[0], :fine.shape[1]] = fine
        return pad.reshape(nr, 1 << d, nc, 1 << d).max(axis=(1, 3))

    span = t << d  # level-j rows of a level-k tile
    per = max(1, block // span)
    rel = np.zeros((nr, nc))
    rel_b = np.zeros((nr, nc))
    for i0 in range(0, nr, per):
        i1 = min(nr, i0 + per)
        a0, a1 = i0 * span, min(i1 * span, fr)
        band = np.ascontiguousarray(reader(j, a0, a1 + 1, 0, fc + 1), dtype=np.float32)
        _exact_error_kernel(band, a0, d, t, fr, fc, rel[i0:i1], rel_b[i0:i1])
    return inner(fine_error) + rel, inner(fine_error_b) + rel_b


def array_reader(heights: np.ndarray) -> LevelReader:
    """A :data:`LevelReader` over an in-memory map (level k = every ``2**k``-th sample)."""
    h = np.asarray(heights)

    def read(level: int, a0: int, a1: int, b0: int, b1: int) -> np.ndarray:
        s = 1 << level
        return h[a0 * s:(a1 - 1) * s + 1:s, b0 * s:(b1 - 1) * s + 1:s]

    return read


class StoreReader:
    """A thread-safe :data:`LevelReader` over a world store that keeps the last few
    decompressed zarr chunks (``cache_bytes``): neighbouring tiles share chunks, and a
    tile read decompresses whole chunks."""

    def __init__(self, path, *, cache_bytes: int = 64 << 20) -> None:
        from terrascape.world.store import open_world

        self.path = Path(path)
        self.group, self.recipe = open_world(path)
        self.stored = int(self.group.attrs.get("levels", 0))
        self.chunk = int(self.recipe.chunk)
        self.cache_bytes = int(cache_bytes)
        self._blocks: OrderedDict[tuple[int, int, int], np.ndarray] = OrderedDict()
        self._bytes = 0
        self._lock = threading.Lock()
        self._arrays: dict[int, Any] = {}

    def _array(self, level: int):
        arr = self._arrays.get(level)
        if arr is None:
            name = "height" if level == 0 else f"levels/{level}"
            arr = self._arrays[level] = self.group[name]
        return arr

    def _block(self, level: int, bi: int, bj: int) -> np.ndarray:
        key = (level, bi, bj)
        blk = self._blocks.get(key)
        if blk is not None:
            self._blocks.move_to_end(key)
            return blk
        c = self.chunk
        blk = np.asarray(self._array(level)[bi * c:(bi + 1) * c, bj * c:(bj + 1) * c])
        self._blocks[key] = blk
        self._bytes += blk.nbytes
        while self._bytes > self.cache_bytes and len(self._blocks) > 1:
            _, old = self._blocks.popitem(last=False)
            self._bytes -= old.nbytes
        return blk

    def __call__(self, level: int, a0: int, a1: int, b0: int, b1: int) -> np.ndarray:
        if level > self.stored:
            from terrascape.world.window import read_level

            return read_level(self.group, level, a0, a1, b0, b1)
        c = self.chunk
        out = np.empty((a1 - a0, b1 - b0), dtype=np.float32)
        with self._lock:
            for bi in range(a0 // c, (a1 - 1) // c + 1):
                for bj in range(b0 // c, (b1 - 1) // c + 1):
                    blk = self._block(level, bi, bj)
                    r0, r1 = max(a0, bi * c), min(a1, bi * c + blk.shape[0])
                    s0, s1 = max(b0, bj * c), min(b1, bj * c + blk.shape[1])
                    out[r0 - a0:r1 - a0, s0 - b0:s1 - b0] = blk[r0 - bi * c:r1 - bi * c,
                                                                s0 - bj * c:s1 - bj * c]
        return out


def world_pyramid(path, *, tile: int = DEFAULT_TILE, reader: StoreReader | None = None,
                  cache: bool = True) -> TilePyramid:
    """The :class:`TilePyramid` of a world store, built once and cached in the store
    (``terrascape_lod4_<tile>.npz``, keyed by the recipe's hash)."""
    from terrascape.io.atomic import atomic_output

    reader = reader or StoreReader(path)
    recipe = reader.recipe
    shape = (int(recipe.rows), int(recipe.cols))
    cache_path = Path(path) / _CACHE_NAME.format(tile=tile)
    digest = hashlib.sha256(f"{recipe.digest()}:{tile}:4".encode()).hexdigest()
    if cache_path.is_file():
        try:
            with np.load(cache_path) as z:
                if str(z["digest"]) == digest:
                    grid = tile_grid(shape, recipe.spacing, tile)
                    n = grid.top + 1
                    return TilePyramid(grid, [z[f"error_{k}"] for k in range(n)],
                                       [z[f"low_{k}"] for k in range(n)],
                                       [z[f"high_{k}"] for k in range(n)],
                                       [z[f"errorb_{k}"] for k in range(n)])
        except (OSError, KeyError, ValueError):
            pass  # rebuilt below
    pyr = build_pyramid(reader, shape, recipe.spacing, tile=tile, block=reader.chunk)
    if cache:
        arrays = {"digest": np.array(digest)}
        for k in range(pyr.grid.top + 1):
            arrays.update({f"error_{k}": pyr.error[k], f"low_{k}": pyr.low[k],
                           f"high_{k}": pyr.high[k], f"errorb_{k}": pyr.error_bintree[k]})
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        try:
            with atomic_output(cache_path, force=True) as tmp:
                Path(tmp).write_bytes(buf.getvalue())
        except OSError:
            pass  # a read-only store: the table is rebuilt next time
    return pyr


# --- selection ---------------------------------------------------------------------------

@dataclass
class TileSelection:
    """The tiles one view draws: ``visible`` (front to back) and ``culled`` together cover
    the map exactly once."""

    visible: list[TileKey]
    culled: list[TileKey]
    #: Projected error (pixels) of each visible tile.
    pixels: dict[TileKey, float]
    #: Largest projected error of a visible tile (pixels).
    max_pixels: float
    #: True when the tile budget stopped the refinement before the tolerance was met.
    budget_bound: bool

    @property
    def leaves(self) -> list[TileKey]:
        return [*self.visible, *self.culled]

    def levels(self) -> dict[int, int]:
        out: dict[int, int] = {}
        for k in self.visible:
            out[k.level] = out.get(k.level, 0) + 1
        return dict(sorted(out.items()))


def _in_frustum(planes: np.ndarray, box: np.ndarray) -> bool:
    p = np.where(planes[:, :3] >= 0, box[3:], box[:3])
    return bool(np.all(np.einsum("ij,ij->i", planes[:, :3], p) + planes[:, 3] >= 0))


def _covering(leaves: dict[TileKey, Any], grid: TileGrid, key: TileKey) -> TileKey | None:
    """The leaf whose ground contains tile ``key``'s (``key`` or an ancestor), if any."""
    k = key
    while k is not None:
        if k in leaves:
            return k
        k = grid.parent(k)
    return None


def _refine(grid: TileGrid, measure, tol: float, cap: float):
    """Split the largest projected error first until within ``tol`` or ``cap`` visible
    tiles, then balance; ``(leaves, visible count, stopped by the cap)``."""
    leaves: dict[TileKey, tuple[bool, float]] = {k: measure(k) for k in grid.roots()}
    n_visible = sum(v for v, _ in leaves.values())
    if n_visible > cap:
        raise MemoryLimitError(
            f"the view needs {n_visible} tiles even at the coarsest level, over the "
            f"budget of {int(cap)}; raise --max-memory")
    heap = [(-p, k) for k, (v, p) in leaves.items() if v and p > tol]
    heapq.heapify(heap)
    bound = False

    def split(key: TileKey) -> int:
        """Replace a leaf by its children; the change in visible tiles."""
        vis, _ = leaves.pop(key)
        added = 0
        for ch in grid.children(key):
            m = leaves[ch] = measure(ch)
            added += m[0]
            if m[0] and m[1] > tol:
                heapq.heappush(heap, (-m[1], ch))
        return added - vis

    while heap:
        _, key = heap[0]
        if key not in leaves:
            heapq.heappop(heap)
            continue
        extra = sum(measure(ch)[0] for ch in grid.children(key)) - 1
        if n_visible + extra > cap:
            bound = True
            break
        heapq.heappop(heap)
        n_visible += split(key)
    # balance: neighbouring leaves differ by at most one level (the skirts' bound)
    work = list(leaves)
    while work:
        key = work.pop()
        if key not in leaves:
            continue
        for di, dj in ((-1, 0), (1, 0), (0, -1), (0, 1)):
            nb = TileKey(key.level, key.row + di, key.col + dj)
            if not grid.exists(nb):
                continue
            cover = _covering(leaves, grid, nb)
            while cover is not None and cover.level >= key.level + 2:
                n_visible += split(cover)
                kids = grid.children(cover)
                work.extend(kids)  # the new leaves' own neighbours may now be too coarse
                cover = _covering(leaves, grid, nb)
    return leaves, n_visible, bound


def select_tiles(pyramid: TilePyramid, camera: Camera, viewport: tuple[int, int], *,
                 tolerance: float = 1.0, max_tiles: int | None = None,
                 exaggeration: float = 1.0) -> TileSelection:
    """The tiles to draw ``camera``'s view with at most ``tolerance`` pixels of error.

    Parameters
    ----------
    viewport
        ``(width, height)`` in pixels.
    tolerance
        Largest screen-space error of a tile (pixels).
    max_tiles
        Visible tiles at most (the memory bound: each tile mesh is at most
        :meth:`TileGrid.max_tile_bytes`); the largest errors are refined first, so a budget
        too small for the tolerance gives the best view it allows.
    exaggeration
        Vertical scale of the drawn terrain (errors and boxes scale with it).

    Raises
    ------
    MemoryLimitError
        When even the roots that are in view exceed ``max_tiles``.
    """
    tol = check_positive(tolerance, "tolerance (pixels)")
    grid = pyramid.grid
    kpx = camera.pixels_per_radian(int(viewport[1]))

    # a tile's visibility, projected error and distance when the refinement first reaches
    # it: the cost follows the tiles the view splits, not the world's size (a 32769² world
    # has 1.4 M tiles of 32², a view looks at a few hundred)
    planes = [tuple(float(v) for v in p) for p in camera.frustum_planes()]
    ex, ey, ez = (float(v) for v in camera.eye)
    sp = grid.spacing
    scale = float(exaggeration)
    error, skirt, high = pyramid.error, pyramid.skirt, pyramid.high
    seen: dict[TileKey, tuple[bool, float, float]] = {}

    def look(key: TileKey) -> tuple[bool, float, float]:
        got = seen.get(key)
        if got is not None:
            return got
        k, i, j = key
        r0, r1, c0, c1 = grid.span(key)
        x0, x1, z0, z1 = c0 * sp, c1 * sp, r0 * sp, r1 * sp
        y0, y1 = float(skirt[k][i, j]) * scale, float(high[k][i, j]) * scale
        inside = True
        for a, b, c, d in planes:  # the box's corner furthest along each inward normal
            if (a * (x1 if a >= 0 else x0) + b * (y1 if b >= 0 else y0)
                    + c * (z1 if c >= 0 else z0) + d) < 0:
                inside = False
                break
        dx = ex - min(max(ex, x0), x1)
        dy = ey - min(max(ey, y0), y1)
        dz = ez - min(max(ez, z0), z1)
        dist = math.sqrt(dx * dx + dy * dy + dz * dz)
        err = float(error[k][i, j]) * scale
        px = 0.0
        if inside and k and err > 0:
            px = err * kpx / dist if dist > 0 else math.inf
        got = seen[key] = (inside, px, dist)
        return got

    def measure(key: TileKey) -> tuple[bool, float]:
        return look(key)[:2]

    cap = math.inf if max_tiles is None else check_int(max_tiles, "max tiles", minimum=1)
    while True:
        leaves, n_visible, bound = _refine(grid, measure, tol, cap)
        if n_visible <= cap:
            break
        cap -= max(1, int(n_visible - cap))  # balancing overshot: refine less, retry
    visible = [k for k, (v, _) in leaves.items() if v]
    visible.sort(key=lambda k: look(k)[2])
    pixels = {k: leaves[k][1] for k in visible}
    return TileSelection(visible=visible, culled=[k for k, (v, _) in leaves.items() if not v],
                         pixels=pixels, max_pixels=max(pixels.values(), default=0.0),
                         budget_bound=bound)


def draw_set(grid: TileGrid, selection: Iterable[TileKey],
             loaded: Callable[[TileKey], bool]) -> list[TileKey]:
    """What to draw while some selected tiles are still loading: a selected tile when it is
    loaded, else — for the whole group of selected tiles under it — the finest loaded
    ancestor whose every selected descendant cannot be drawn; never two overlapping tiles.
    Selected tiles with no loaded ancestor are left out (the roots are loaded first)."""
    selected = set(selection)
    below: dict[TileKey, list[TileKey]] = {}
    for key in selected:
        k, p = key, grid.parent(key)
        while p is not None:
            kids = below.setdefault(p, [])
            if k in kids:
                break
            kids.append(k)
            k, p = p, grid.parent(p)

    def solve(key: TileKey) -> list[TileKey] | None:
        if key in selected:
            return [key] if loaded(key) else None
        parts: list[TileKey] = []
        for ch in below.get(key, []):
            got = solve(ch)
            if got is None:
                return [key] if loaded(key) else None
            parts += got
        return parts

    out: list[TileKey] = []
    for root in grid.roots():
        if root in selected or root in below:
            out += solve(root) or []
    return out


# --- tile meshes -------------------------------------------------------------------------

@dataclass
class TileMesh:
    """One tile's vertices: the ``n_r × n_c`` grid, then the skirt's bottom ring."""

    key: TileKey
    positions: np.ndarray  # (n, 3) float32
    normals: np.ndarray  # (n, 3) float32
    tangents: np.ndarray  # (n, 4) float32
    shape: tuple[int, int]
    #: (n_r·n_c,) float32: tile_bintree_errors of the drawn heights, rounded up (None: not
    #: made, or the tile has no bintree)
    bintree_errors: np.ndarray | None = None

    @property
    def nbytes(self) -> int:
        extra = 0 if self.bintree_errors is None else self.bintree_errors.nbytes
        return self.positions.nbytes + self.normals.nbytes + self.tangents.nbytes + extra


def _ring(n_r: int, n_c: int) -> np.ndarray:
    """Grid vertex indices around the border, in order (each corner once)."""
    top = np.arange(n_c)
    right = np.arange(1, n_r) * n_c + n_c - 1
    bottom = (n_r - 1) * n_c + np.arange(n_c - 2, -1, -1)
    left = np.arange(n_r - 2, 0, -1) * n_c
    return np.concatenate([top, right, bottom, left])


def tile_indices(shape: tuple[int, int]) -> np.ndarray:
    """uint32 triangles of a tile mesh of ``shape`` grid vertices: the grid's (as
    :func:`~terrascape.mesh.terrain_mesh.grid_triangles`) and the skirts, facing out of
    the tile (counter-clockwise seen from outside; each edge's: :func:`skirt_edges`).

    One winding is enough: a gap between two tiles' edges opens below the higher edge, and
    from the higher tile's side it is hidden by that tile's own surface, so it is only ever
    seen from outside the higher tile — where its skirt faces the eye. The inward faces
    would be culled after their vertices were shaded (on a software rasteriser a twelfth
    of a tile's triangles)."""
    n_r, n_c = shape
    grid = grid_triangles(n_r, n_c)
    ring = _ring(n_r, n_c)
    n = len(ring)
    a = ring
    b = np.roll(ring, -1)
    lo_a = n_r * n_c + np.arange(n)
    lo_b = np.roll(lo_a, -1)
    quads = np.stack([b, lo_a, a, lo_b, lo_a, b], axis=1)
    return np.concatenate([grid.reshape(-1), quads.reshape(-1)]).astype(np.uint32)


def bintree_cells(n_r: int, n_c: int) -> np.ndarray:
    """uint32 ``(2·cells, 3)`` triangles of an ``n_r × n_c`` grid split as the bintree of a
    ``2**m + 1`` square splits it at its finest level: cell ``(a, b)`` along
    ``(a, b)–(a+1, b+1)`` where ``a + b`` is even, along ``(a+1, b)–(a, b+1)`` (as
    :func:`~terrascape.mesh.terrain_mesh.grid_triangles`) where it is odd — the surface
    ``B_k`` that :attr:`TilePyramid.error_bintree` bounds and the simplified tile meshes
    coarsen. Counter-clockwise seen from above, like the grid's."""
    a = np.arange(n_r - 1)[:, None]
    b = np.arange(n_c - 1)[None, :]
    i00 = (a * n_c + b).ravel()
    i01, i10 = i00 + 1, i00 + n_c
    i11 = i10 + 1
    even = ((a + b) % 2 == 0).ravel()
    first = np.where(even[:, None], np.stack([i00, i10, i11], 1), np.stack([i00, i10, i01], 1))
    second = np.where(even[:, None], np.stack([i00, i11, i01], 1),
                      np.stack([i01, i10, i11], 1))
    return np.stack([first, second], 1).reshape(-1, 3).astype(np.uint32)


def simplifiable(shape: tuple[int, int]) -> bool:
    """Whether a tile of ``shape`` grid vertices has a bintree (square, ``2**m + 1``)."""
    n_r, n_c = shape
    return n_r == n_c and n_r >= 3 and ((n_r - 1) & (n_r - 2)) == 0


@functools.lru_cache(maxsize=8)
def _border_closure(size: int) -> np.ndarray:
    """The bintree vertices a mesh with every border vertex needs (the border's and their
    ancestors'), flat bool: the set the nesting closes."""
    err = np.zeros((size, size))
    err[0, :] = err[-1, :] = err[:, 0] = err[:, -1] = 1.0
    err[0, 0] = err[0, -1] = err[-1, 0] = err[-1, -1] = 0.0  # corners never split
    flat = err.reshape(-1)
    _nest_errors(size, (size - 1).bit_length() - 1, flat)
    return flat > 0.0


def tile_bintree_errors(heights: np.ndarray) -> np.ndarray:
    """Per grid vertex of a square ``2**m + 1`` tile (flat, float64): the exact error, at
    the tile's samples, of the bintree mesh that leaves that vertex out, nested so the
    vertices above any error form a conforming mesh (:mod:`terrascape.lod.rtin`); the border
    and the vertices it needs are never left out (infinite error), so the tile's edges
    keep every sample and meet their neighbours' without a crack.

    A bintree mesh refines the tile's bintree interpolant ``B_k`` (:func:`bintree_cells`):
    on each finest triangle both are linear, so their largest difference is at a sample,
    and a mesh of the vertices above ``e`` is within ``e`` of ``B_k`` everywhere."""
    h = np.ascontiguousarray(heights, dtype=np.float64)
    size = h.shape[0]
    if not simplifiable(h.shape):
        raise InvalidParameterError(f"a tile bintree needs a square 2**m + 1 grid, got {h.shape}")
    err = np.zeros(size * size)
    lev = np.full(size * size, -1, np.int64)
    _vertex_errors(h, (size - 1).bit_length() - 1, err, lev)
    err[_border_closure(size)] = np.inf
    return err


def simplified_tile_triangles(errors: np.ndarray, size: int, max_error: float) -> np.ndarray:
    """uint32 ``(m, 3)`` triangles (grid vertex indices, counter-clockwise seen from above)
    of the coarsest bintree mesh of a tile within ``max_error`` of its ``B_k`` (``errors``
    from :func:`tile_bintree_errors`, float64 or float32 rounded up), every border sample
    kept. The threshold is taken in the errors' own type, rounded down, so no vertex whose
    error exceeds ``max_error`` is left out."""
    threshold = errors.dtype.type(max_error)
    if float(threshold) > max_error:  # (a float32 compared with a float rounds it first)
        threshold = np.nextafter(threshold, errors.dtype.type(-np.inf))
    return _triangles_of(size, errors > threshold)


#: The neighbour across each edge of :func:`skirt_edges` (row and column steps).
EDGE_STEPS = ((-1, 0), (0, 1), (1, 0), (0, -1))


def skirt_edges(shape: tuple[int, int]) -> list[tuple[int, int]]:
    """``(first, count)`` of the skirt indices of each tile edge — row 0, the last column,
    the last row, column 0 (the neighbours of :data:`EDGE_STEPS`) — in :func:`tile_indices`
    after the grid's. Two tiles of one level share their edge's samples exactly, so an edge
    between them needs no skirt; only edges to another level or to nothing drawn do."""
    n_r, n_c = shape
    out, at = [], 0
    for quads in (n_c - 1, n_r - 1, n_c - 1, n_r - 1):  # the order of _ring
        out.append((6 * at, 6 * quads))
        at += quads
    return out


def tile_mesh(reader: LevelReader, pyramid: TilePyramid, key: TileKey, *,
              exaggeration: float = 1.0, bintree: bool = False) -> TileMesh:
    """The mesh of one tile, read at its level with a one-sample halo for the normals
    (central differences inside the map, one-sided at its border: at level 0 the normals
    and positions of :func:`~terrascape.mesh.terrain_mesh.terrain_mesh` bit for bit).
    ``bintree``: with its vertices' bintree errors (:func:`tile_bintree_errors` of the drawn
    heights, for the viewer's simplified tiles) when its grid has a bintree."""
    grid = pyramid.grid
    if not grid.exists(key):
        raise InvalidParameterError(f"no tile {tuple(key)} in this world")
    k = key.level
    a0, a1, b0, b1 = grid.samples(key)
    cr, cc = grid.cells(k)
    h0, h1 = max(a0 - 1, 0), min(a1 + 1, cr)
    w0, w1 = max(b0 - 1, 0), min(b1 + 1, cc)
    window = np.asarray(reader(k, h0, h1 + 1, w0, w1 + 1), dtype=np.float32)
    sp = grid.spacing * (1 << k)
    block = window.astype(np.float64) * exaggeration
    gz, gx = np.gradient(block, sp, sp)
    crop = (slice(a0 - h0, a1 - h0 + 1), slice(b0 - w0, b1 - w0 + 1))
    normals, tangents, _ = heightfield_tangent_frames(gx[crop], gz[crop])
    heights = window[crop]
    n_r, n_c = heights.shape
    pos = np.empty((n_r, n_c, 3), dtype=np.float32)
    pos[..., 0] = (np.arange(b0, b1 + 1, dtype=np.float64) * sp).astype(np.float32)[None, :]
    pos[..., 1] = heights * np.float32(exaggeration)
    pos[..., 2] = (np.arange(a0, a1 + 1, dtype=np.float64) * sp).astype(np.float32)[:, None]
    pos = pos.reshape(-1, 3)
    ring = _ring(n_r, n_c)
    bottom = pos[ring].copy()
    bottom[:, 1] = np.float32(float(pyramid.skirt[k][key.row, key.col]) * exaggeration)
    errors = None
    if bintree and simplifiable((n_r, n_c)):
        errors = _rounded_up_f32(tile_bintree_errors(pos[:, 1].reshape(n_r, n_c)))
    return TileMesh(key, np.concatenate([pos, bottom]),
                    np.concatenate([normals, normals[ring]]),
                    np.concatenate([tangents, tangents[ring]]), (n_r, n_c), errors)


def _rounded_up_f32(values: np.ndarray) -> np.ndarray:
    """float32 values never below ``values`` (an error bound stays a bound)."""
    out = values.astype(np.float32)
    low = out.astype(np.float64) < values
    out[low] = np.nextafter(out[low], np.float32(np.inf))
    return out


# --- streaming ---------------------------------------------------------------------------

class TileCache:
    """A least-recently-used map of tiles bounded in bytes; ``release(value)`` is called on
    every value it drops. Entries in ``pinned`` (the frame's draw set) are never dropped."""

    def __init__(self, max_bytes: int, *, size_of: Callable[[Any], int],
                 release: Callable[[Any], None] | None = None) -> None:
        self.max_bytes = int(max_bytes)
        self._size_of = size_of
        self._release = release or (lambda value: None)
        self._items: OrderedDict[TileKey, Any] = OrderedDict()
        self._sizes: dict[TileKey, int] = {}
        self.bytes = 0
        self.peak_bytes = 0
        self.evicted = 0

    def __contains__(self, key) -> bool:
        return key in self._items

    def __len__(self) -> int:
        return len(self._items)

    def values(self) -> list:
        return list(self._items.values())

    def get(self, key: TileKey):
        value = self._items.get(key)
        if value is not None:
            self._items.move_to_end(key)
        return value

    def peek(self, key: TileKey):
        """The value of ``key`` (or None) without making it the most recently used."""
        return self._items.get(key)

    def put(self, key: TileKey, value, *, pinned: frozenset | set = frozenset()) -> bool:
        """Insert ``value``; False (and ``value`` released) when the pinned entries leave no
        room for it."""
        if key in self._items:  # already here (loaded twice): keep the one in use
            self._items.move_to_end(key)
            self._release(value)
            return True
        size = self._size_of(value)
        for old in list(self._items):
            if self.bytes + size <= self.max_bytes:
                break
            if old in pinned:
                continue
            self._release(self._items.pop(old))
            self.bytes -= self._sizes.pop(old)
            self.evicted += 1
        if self.bytes + size > self.max_bytes:
            self._release(value)
            return False
        self._items[key] = value
        self._sizes[key] = size
        self.bytes += size
        self.peak_bytes = max(self.peak_bytes, self.bytes)
        return True

    def clear(self) -> None:
        for value in self._items.values():
            self._release(value)
        self._items.clear()
        self._sizes.clear()
        self.bytes = 0


class TileLoader:
    """Builds tile meshes on a background thread: :meth:`request` replaces the queue (in
    priority order), :meth:`finished` hands over the meshes made since the last call.
    ``max_pending`` finished meshes wait at most (the loader pauses when they are not
    collected), so its memory is bounded too."""

    def __init__(self, build: Callable[[TileKey], TileMesh], *, max_pending: int = 16) -> None:
        self._build = build
        self._queue: list[TileKey] = []
        self._done: list[TileMesh] = []
        self._busy: TileKey | None = None
        self._cond = threading.Condition()
        self._stop = False
        self.max_pending = max_pending
        self.loaded = 0
        self.error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="terrascape-tiles", daemon=True)
        self._thread.start()

    def request(self, keys: Iterable[TileKey]) -> None:
        with self._cond:
            made = {m.key for m in self._done}
            self._queue = [k for k in dict.fromkeys(keys) if k != self._busy and k not in made]
            self._cond.notify_all()

    def pending(self) -> int:
        with self._cond:
            return len(self._queue) + (self._busy is not None) + len(self._done)

    def finished(self, limit: int | None = None) -> list[TileMesh]:
        """The meshes made since the last call, oldest first (at most ``limit``; the rest
        wait for the next call)."""
        with self._cond:
            n = len(self._done) if limit is None else max(0, int(limit))
            out, self._done = self._done[:n], self._done[n:]
            self._cond.notify_all()
        if self.error is not None:
            err, self.error = self.error, None
            raise err
        return out

    def _run(self) -> None:
        while True:
            with self._cond:
                while not self._stop and (not self._queue or len(self._done) >= self.max_pending):
                    self._cond.wait()
                if self._stop:
                    return
                key = self._busy = self._queue.pop(0)
            try:
                mesh = self._build(key)
            except BaseException as exc:  # handed to the frame that collects
                with self._cond:
                    self.error, self._busy = exc, None
                continue
            with self._cond:
                self._busy = None
                self._done.append(mesh)
                self.loaded += 1

    def close(self) -> None:
        with self._cond:
            self._stop = True
            self._cond.notify_all()
        self._thread.join(timeout=5.0)


#: Meshes the loader process may have made and the viewer not yet taken (shared slots).
LOADER_SLOTS = 32
#: Tiles a request to the loader process names at most (its queue, in priority order).
LOADER_QUEUE = 4 * LOADER_SLOTS


def _slot_layout(n_vertices: int, n_errors: int = 0) -> tuple[int, int, int, int, int]:
    """Byte offsets of positions, normals, tangents and ``n_errors`` bintree errors of an
    ``n_vertices`` mesh in a slot, and the bytes it takes."""
    pos = n_vertices * 12
    tan = 2 * pos + n_vertices * 16
    return 0, pos, 2 * pos, tan, tan + 4 * n_errors


def _loader_process(conn, path: str, tile: int, exaggeration: float, reader_bytes: int,
                    slots, slot_bytes: int) -> None:
    """The tile loader process: builds the meshes it is asked for, newest request first,
    each into a free slot of the shared ``slots`` buffer; the pipe carries only which tile
    is in which slot (and, back, which slots the viewer has emptied)."""
    try:
        reader = StoreReader(path, cache_bytes=reader_bytes)
        pyramid = world_pyramid(path, tile=tile, reader=reader, cache=False)
    except Exception as exc:  # reported to the viewer, which stops with it
        conn.send(("error", f"{type(exc).__name__}: {exc}"))
        return
    memory = np.frombuffer(slots, dtype=np.uint8)
    free = list(range(len(memory) // slot_bytes))
    queue: list[TileKey] = []
    while True:
        # wait for work only when there is nothing to build or nowhere to put it
        while conn.poll(0 if queue and free else None):
            msg = conn.recv()
            if msg[0] == "stop":
                return
            if msg[0] == "free":
                free.extend(msg[1])
            else:
                queue = list(msg[1])
        key = queue.pop(0)
        try:
            mesh = tile_mesh(reader, pyramid, key, exaggeration=exaggeration, bintree=True)
        except Exception as exc:
            conn.send(("error", f"tile {tuple(key)}: {type(exc).__name__}: {exc}"))
            continue
        slot = free.pop()
        n = len(mesh.positions)
        errors = mesh.bintree_errors
        n_err = 0 if errors is None else errors.size
        base = slot * slot_bytes
        arrays = [mesh.positions, mesh.normals, mesh.tangents]
        if errors is not None:
            arrays.append(errors)
        for arr, off in zip(arrays, _slot_layout(n, n_err), strict=False):
            raw = np.ascontiguousarray(arr, dtype=np.float32).view(np.uint8).reshape(-1)
            memory[base + off:base + off + raw.size] = raw
        conn.send(("tile", key, slot, n, mesh.shape, n_err))


class ProcessTileLoader:
    """:class:`TileLoader`'s interface over a separate process that reads the world store
    and builds the meshes. A thread is not enough while the frame draws: moderngl keeps
    Python's global interpreter lock during GL calls (measured: a spinning thread got 4 % of
    its idle rate during a frame), so a loader thread would barely run.

    The meshes travel through ``slots`` shared buffers of one largest mesh each, not the
    pipe: a pipe holds about one mesh, so a process sending meshes through it waits for the
    viewer's next frame after each one (measured: two tiles a frame whatever the frame's
    length, the view never finished loading in a flight). The process fills free slots
    ahead of the viewer and names them in short messages; :meth:`finished` copies a mesh
    out and hands its slot back. Its memory is its reader's chunk cache, one mesh and the
    slots (``slots`` × :meth:`TileGrid.max_tile_bytes`, 1.5 MB for 32² tiles)."""

    def __init__(self, path, *, tile: int = DEFAULT_TILE, exaggeration: float = 1.0,
                 reader_bytes: int = 64 << 20, slots: int = LOADER_SLOTS) -> None:
        import multiprocessing

        tile = check_int(tile, "tile (cells per side)", minimum=2, maximum=4096)
        slots = check_int(slots, "loader slots", minimum=1)
        self.slot_bytes = _max_tile_bytes(tile)
        ctx = multiprocessing.get_context("spawn")  # no fork of a process holding GL state
        self._slots = ctx.RawArray("B", slots * self.slot_bytes)
        self._memory = np.frombuffer(self._slots, dtype=np.uint8)
        self._conn, child = ctx.Pipe()
        self._proc = ctx.Process(target=_loader_process, name="terrascape-tiles", daemon=True,
                                 args=(child, str(path), int(tile), float(exaggeration),
                                       int(reader_bytes), self._slots, self.slot_bytes))
        self._proc.start()
        child.close()
        self._asked: set[TileKey] = set()
        self._last: list[TileKey] = []
        self._unsent_free: list[int] = []
        self.loaded = 0

    def request(self, keys: Iterable[TileKey]) -> None:
        """Replace the process's queue by the first :data:`LOADER_QUEUE` of ``keys`` (a
        moving view asks anew each frame, the rest again later): a long list each frame
        would fill the pipe while the process builds a tile, and the frame would wait."""
        keys = list(dict.fromkeys(keys))[:LOADER_QUEUE]
        if keys != self._last and self._room():
            self._conn.send(("want", keys))
            self._last = keys
        self._asked.update(keys)

    def _room(self) -> bool:
        """Whether the pipe to the process takes a message now. A process busy for long
        reads no messages (on a first run it compiles its kernels for seconds): a view that
        moves asks anew each frame, the pipe fills, and a blocking send would hold the frame
        until the process reads again. The request waits for a later frame instead."""
        return bool(select.select([], [self._conn], [], 0)[1])

    def pending(self) -> int:
        return len(self._asked)

    def _take(self, key: TileKey, slot: int, n: int, shape, n_err: int = 0) -> TileMesh:
        base = slot * self.slot_bytes
        size = _slot_layout(n, n_err)[4]
        raw = self._memory[base:base + size].copy().view(np.float32)  # the slot is reused
        pos = raw[:n * 3].reshape(n, 3)  # the order of _slot_layout
        nor = raw[n * 3:n * 6].reshape(n, 3)
        tan = raw[n * 6:n * 10].reshape(n, 4)
        errors = raw[n * 10:n * 10 + n_err] if n_err else None
        return TileMesh(TileKey(*key), pos, nor, tan, tuple(shape), errors)

    def finished(self, limit: int | None = None) -> list[TileMesh]:
        out: list[TileMesh] = []
        emptied: list[int] = []
        try:
            while (limit is None or len(out) < limit) and self._conn.poll(0):
                msg = self._conn.recv()
                if msg[0] == "error":
                    raise InvalidParameterError(f"loading the world's tiles failed: {msg[1]}")
                _, key, slot, n, shape, n_err = msg
                mesh = self._take(key, slot, n, shape, n_err)
                emptied.append(slot)
                self._asked.discard(mesh.key)
                self.loaded += 1
                out.append(mesh)
        finally:
            # the emptied slots go back when the pipe takes them (kept until then: the
            # process needs every one of them back)
            self._unsent_free.extend(emptied)
            if self._unsent_free and self._room():
                self._conn.send(("free", self._unsent_free))
                self._unsent_free = []
        if not out and not self._proc.is_alive():
            raise InvalidParameterError("the tile loader process ended unexpectedly")
        return out

    def peak_rss(self) -> int:
        """The loader process's peak resident memory (bytes; 0 where /proc is missing)."""
        try:
            with open(f"/proc/{self._proc.pid}/status", encoding="ascii") as fh:
                for line in fh:
                    if line.startswith("VmHWM:"):
                        return int(line.split()[1]) * 1024
        except OSError:
            pass
        return 0

    def close(self) -> None:
        with contextlib.suppress(OSError):
            self._conn.send(("stop",))
        deadline = time.monotonic() + 5.0
        while self._proc.is_alive() and time.monotonic() < deadline:
            with contextlib.suppress(OSError, EOFError):
                while self._conn.poll(0.05):
                    self._conn.recv()
            self._proc.join(timeout=0.05)
        if self._proc.is_alive():
            self._proc.terminate()
            self._proc.join(timeout=5.0)
        self._conn.close()


__all__ = ["DEFAULT_TILE", "EDGE_STEPS", "LOADER_QUEUE", "LOADER_SLOTS", "VERTEX_BYTES",
           "LevelReader", "ProcessTileLoader", "StoreReader", "TileCache", "TileGrid", "TileKey",
           "TileLoader", "TileMesh", "TilePyramid", "TileSelection", "array_reader",
           "bintree_cells", "build_pyramid", "draw_set", "select_tiles", "simplifiable",
           "simplified_tile_triangles", "skirt_edges", "tile_bintree_errors", "tile_grid",
           "tile_indices", "tile_mesh", "world_pyramid"]
