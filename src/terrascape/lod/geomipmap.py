"""Geomipmapping (de Boer 2000): patches with level chains, per-frame level
selection from precomputed errors, neighbours at most one level apart, crack-free joins.

Patches have ``2**k + 1`` samples per side (17 in the original) and share their border
samples. Level ``l`` of a patch uses every ``2**l``-th sample; the coarsest level is the two
triangles of the patch square.

Index pattern. Every level ``l`` below the coarsest is made of 2×2-cell blocks, each a fan of
8 triangles around the block centre. A patch whose neighbour on one side is one level coarser
skips the odd vertices along that side: in each block touching
that side the two triangles meeting at the skipped edge midpoint merge into one, so the edge
has exactly the neighbour's vertices and no T-junction remains. The 16 neighbour masks
(bit 1 = north/−Z/row 0, 2 = east/+X, 4 = south/+Z, 8 = west/col 0; bit set = that
neighbour is coarser) times the levels give the index buffers, precomputed once in
patch-local form ``row·cols + col`` — adding the patch's first vertex index
(``base_vertex``) makes them grid-vertex indices, so one buffer serves every patch
(``glDrawElementsBaseVertex``).

Level selection (Formula 3). ``δ`` of a patch at a level is the maximum vertical error of the
level's triangles against EVERY full-resolution sample of the patch; the level may be used
from the distance ``D_n = |δ|·C``, ``C = A/T``, ``A = n/|t|``, ``T = 2τ/v_res`` (n = near
distance, t = top of the near plane, τ = tolerance in pixels, v_res = viewport height). The
camera distance is the (conservative) Euclidean distance from the eye to the patch's AABB,
not to its centre, so every sample of the patch is at least that far and its screen error
``δ·K/d`` (see :func:`terrascape.lod.mesh_checks.max_screen_error`) is at most τ. Because
the changed indexing on the finer side of a join adds error, the δ used for selection is the
larger of the plain and the stitched pattern's error, and ``D`` is made non-decreasing over
levels; levels are then lowered (never raised) until neighbours differ by at most one
(an exact city-block distance transform, iterated with the rule below to a fixed point). A
patch that even at level 0 is closer than its stitched-level-0 distance forces its
neighbours to level 0 too, so it is never stitched.

References
----------
- D. Filipović, "Generiranje i prikaz terena" (Terrain generation and display), BSc thesis 221,
  Faculty of Electrical Engineering and Computing, University of Zagreb, 2008, §4.2, Figure 24.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit
from terrascape._validate import check_int, check_positive, is_pow2_plus1
from terrascape.camera import Camera
from terrascape.errors import HeightmapSizeError, InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.lod.mesh_checks import _tri_max_error, _viewport
from terrascape.lod.quadtree import PatchQuadtree, patch_grid
from terrascape.lod.schemes import unsupported

__all__ = ["Geomipmap", "GeomipmapStats", "full_resolution_triangles", "patch_templates"]

NORTH, EAST, SOUTH, WEST = 1, 2, 4, 8


# --------------------------------------------------------------------------------------------
# no-LOD path
# --------------------------------------------------------------------------------------------
def full_resolution_triangles(shape) -> np.ndarray:
    """Every grid cell as two triangles: the no-LOD mesh, for comparison.

    Cell ``(r, c)`` with corners ``a = (r, c)``, ``b = (r, c+1)``, ``d = (r+1, c)``,
    ``e = (r+1, c+1)`` gives ``(a, d, b)`` and ``(b, d, e)`` — counter-clockwise from above.

    Returns
    -------
    numpy.ndarray
        ``uint32 (2·(rows−1)·(cols−1), 3)`` grid vertex indices, cells in row-major order.
    """
    try:
        rows, cols = (int(s) for s in shape)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"shape must be (rows, cols), got {shape!r}") from None
    if rows < 2 or cols < 2:
        raise HeightmapSizeError(f"a mesh needs at least 2×2 samples, got {cols}×{rows}")
    if rows * cols > 2**32:
        raise HeightmapSizeError(f"{cols}×{rows} samples do not fit uint32 indices")
    a = (np.arange(rows - 1, dtype=np.uint32)[:, None] * cols
         + np.arange(cols - 1, dtype=np.uint32)[None, :])
    out = np.empty((rows - 1, cols - 1, 2, 3), np.uint32)
    out[..., 0, 0] = a
    out[..., 0, 1] = a + cols
    out[..., 0, 2] = a + 1
    out[..., 1, 0] = a + 1
    out[..., 1, 1] = a + cols
    out[..., 1, 2] = a + cols + 1
    return out.reshape(-1, 3)


# --------------------------------------------------------------------------------------------
# index templates
# --------------------------------------------------------------------------------------------
def _level_triangles(p: int, level: int, mask: int) -> list[tuple[int, int, int, int, int, int]]:
    """Triangles of one patch level as local (row, col) triples, CCW from above."""
    s = 1 << level
    n = p // s
    if n == 1:  # coarsest level: the patch square, never stitched (no coarser neighbour)
        return [(0, 0, p, 0, 0, p), (0, p, p, 0, p, p)]
    out = []
    nb = n // 2
    for bi in range(nb):
        for bj in range(nb):
            r0, c0 = 2 * s * bi, 2 * s * bj
            cr, cc = r0 + s, c0 + s
            # ring in the order TL, T, TR, R, BR, B, BL, L (clockwise in (col,row) maths)
            ring = [
                (r0, c0), (r0, c0 + s), (r0, c0 + 2 * s), (r0 + s, c0 + 2 * s),
                (r0 + 2 * s, c0 + 2 * s), (r0 + 2 * s, c0 + s), (r0 + 2 * s, c0), (r0 + s, c0),
            ]
            skip = set()
            if mask & NORTH and bi == 0:
                skip.add(1)
            if mask & EAST and bj == nb - 1:
                skip.add(3)
            if mask & SOUTH and bi == nb - 1:
                skip.add(5)
            if mask & WEST and bj == 0:
                skip.add(7)
            kept = [v for k, v in enumerate(ring) if k not in skip]
            for k in range(len(kept)):
                v0, v1 = kept[k], kept[(k + 1) % len(kept)]
                # (centre, next, current) is CCW seen from above
                out.append((cr, cc, v1[0], v1[1], v0[0], v0[1]))
    return out


def patch_templates(patch_size: int) -> dict[tuple[int, int], np.ndarray]:
    """Local ``(row, col)`` triangle templates ``{(level, mask): int64 (T, 6)}`` of a patch.

    Exposed for inspection and tests; :class:`Geomipmap` turns them into index buffers.
    """
    p = patch_size - 1
    n_levels = p.bit_length()  # p = 2**L -> levels 0..L
    return {
        (lvl, m): np.array(_level_triangles(p, lvl, m), np.int64)
        for lvl in range(n_levels)
        for m in range(16)
    }


# --------------------------------------------------------------------------------------------
# kernels
# --------------------------------------------------------------------------------------------
@njit(cache=CACHE, fastmath=FASTMATH)
def _patch_errors(h, p, npr, npc, tris, starts, counts, out):
    """out[i, j, k] = max vertical error of template group k on patch (i, j)."""
    for i in range(npr):
        for j in range(npc):
            r0 = i * p
            c0 = j * p
            for k in range(starts.shape[0]):
                best = 0.0
                for t in range(starts[k], starts[k] + counts[k]):
                    e = _tri_max_error(
                        h,
                        r0 + tris[t, 0], c0 + tris[t, 1],
                        r0 + tris[t, 2], c0 + tris[t, 3],
                        r0 + tris[t, 4], c0 + tris[t, 5],
                    )
                    if e > best:
                        best = e
                out[i, j, k] = best


@njit(cache=CACHE, fastmath=FASTMATH)
def _select_levels(aabb, ex, ey, ez, scale, dstitch, q, lev, mask, tstart, tcount,
                   start, count, base, p, cols):
    """Per-frame level selection; returns the number of fixed-point rounds."""
    npr, npc, nlev = dstitch.shape
    # 1. coarsest level whose (stitched, monotone) minimum distance is met
    for i in range(npr):
        for j in range(npc):
            b = aabb[i, j]
            dx = max(b[0] - ex, 0.0, ex - b[1])
            dy = max(b[2] - ey, 0.0, ey - b[3])
            dz = max(b[4] - ez, 0.0, ez - b[5])
            d = math.sqrt(dx * dx + dy * dy + dz * dz)
            qq = d * scale  # the largest δ allowed at this distance
            q[i, j] = qq
            lv = nlev - 1
            while lv > 0 and dstitch[i, j, lv] > qq:
                lv -= 1
            lev[i, j] = lv
    # 2. neighbours at most one level apart: lower levels (exact city-block distance
    #    transform, two raster passes), then keep unstitchable level-0 patches unstitched
    rounds = 0
    while True:
        rounds += 1
        for i in range(npr):
            for j in range(npc):
                v = lev[i, j]
                if i > 0 and lev[i - 1, j] + 1 < v:
                    v = lev[i - 1, j] + 1
                if j > 0 and lev[i, j - 1] + 1 < v:
                    v = lev[i, j - 1] + 1
                lev[i, j] = v
        for i in range(npr - 1, -1, -1):
            for j in range(npc - 1, -1, -1):
                v = lev[i, j]
                if i < npr - 1 and lev[i + 1, j] + 1 < v:
                    v = lev[i + 1, j] + 1
                if j < npc - 1 and lev[i, j + 1] + 1 < v:
                    v = lev[i, j + 1] + 1
                lev[i, j] = v
        changed = False
        for i in range(npr):
            for j in range(npc):
                if lev[i, j] == 0 and dstitch[i, j, 0] > q[i, j]:
                    if i > 0 and lev[i - 1, j] > 0:
                        lev[i - 1, j] = 0
                        changed = True
                    if i < npr - 1 and lev[i + 1, j] > 0:
                        lev[i + 1, j] = 0
                        changed = True
                    if j > 0 and lev[i, j - 1] > 0:
                        lev[i, j - 1] = 0
                        changed = True
                    if j < npc - 1 and lev[i, j + 1] > 0:
                        lev[i, j + 1] = 0
                        changed = True
        if not changed:
            break
    # 3. neighbour masks and draw ranges
    for i in range(npr):
        for j in range(npc):
            lv = lev[i, j]
            m = 0
            if i > 0 and lev[i - 1, j] > lv:
                m |= 1
            if j < npc - 1 and lev[i, j + 1] > lv:
                m |= 2
            if i < npr - 1 and lev[i + 1, j] > lv:
                m |= 4
            if j > 0 and lev[i, j - 1] > lv:
                m |= 8
            mask[i, j] = m
            start[i, j] = tstart[lv, m]
            count[i, j] = tcount[lv, m]
            base[i, j] = (i * p) * cols + j * p
    return rounds


@njit(cache=CACHE, fastmath=FASTMATH)
def _gather(index, start, count, base, visible, use_visible, out):
    """Concatenate the template triangles of every (visible) patch, offset by base vertex."""
    npr, npc = start.shape
    n = 0
    for i in range(npr):
        for j in range(npc):
            if use_visible and not visible[i, j]:
                continue
            b = base[i, j]
            for t in range(start[i, j], start[i, j] + count[i, j]):
                out[n, 0] = index[t, 0] + b
                out[n, 1] = index[t, 1] + b
                out[n, 2] = index[t, 2] + b
                n += 1
    return n


# --------------------------------------------------------------------------------------------
# public class
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class GeomipmapStats:
    """What one :meth:`Geomipmap.update` did: triangles drawn (culled patches left out when
    culling), wall time, and the coarsest/finest level chosen (0 = full resolution)."""

    triangles: int
    update_ms: float
    min_level: int
    max_level: int
    settled: bool = True  # one update selects the levels for a view; nothing carries over

    @property
    def summary(self) -> str:
        return f"levels {self.min_level}–{self.max_level}"


class Geomipmap:
    """Geomipmapped terrain: precomputed level errors, per-frame level selection and indices.

    Parameters
    ----------
    heightmap
        :class:`~terrascape.Heightmap`; ``patch_size − 1`` must divide ``rows − 1`` and
        ``cols − 1`` (any ``2**k + 1`` patch on a ``2**n + 1`` map with k ≤ n).
    patch_size
        Samples per patch side, ``2**k + 1`` with k ≥ 1 (seed default 17).

    Attributes
    ----------
    patch_shape
        ``(patch_rows, patch_cols)``.
    n_levels
        Levels per patch (``k + 1``; level 0 is full resolution).
    delta
        float64 ``(patch_rows, patch_cols, n_levels)``: δ of each level with the plain
        (unstitched) indexing, measured on every sample of the patch.
    delta_stitched
        Same with the worst stitched indexing (max of plain and all-sides-stitched).
    index_buffer
        uint32 ``(T, 3)`` all templates, patch-local ``row·cols + col`` offsets.
    quadtree
        The :class:`~terrascape.lod.quadtree.PatchQuadtree` used for culling.
    """

    def __init__(self, heightmap: Heightmap, patch_size: int = 17) -> None:
        if not isinstance(heightmap, Heightmap):
            raise InvalidParameterError(f"expected a Heightmap, got {type(heightmap).__name__}")
        size = check_int(patch_size, "patch_size", minimum=3)
        if not is_pow2_plus1(size):
            raise HeightmapSizeError(
                f"patch_size must be 2**k + 1 (e.g. 9, 17, 33, 65), got {patch_size}"
            )
        npr, npc = patch_grid(heightmap.shape, size)
        if heightmap.rows * heightmap.cols > 2**32:
            raise HeightmapSizeError("heightmap too large for uint32 vertex indices")
        self.heightmap = heightmap
        self.patch_size = size
        self.patch_shape = (npr, npc)
        p = size - 1
        self._p = p
        cols = heightmap.cols
        self.n_levels = p.bit_length()
        templates = patch_templates(size)

        # index buffers per (level, mask)
        tstart = np.zeros((self.n_levels, 16), np.int64)
        tcount = np.zeros((self.n_levels, 16), np.int64)
        chunks = []
        n = 0
        for lvl in range(self.n_levels):
            for m in range(16):
                t = templates[(lvl, m)]
                tstart[lvl, m], tcount[lvl, m] = n, len(t)
                chunks.append(t)
                n += len(t)
        local = np.concatenate(chunks)
        self._tstart, self._tcount = tstart, tcount
        self._index = np.ascontiguousarray(
            local[:, [0, 2, 4]] * cols + local[:, [1, 3, 5]], dtype=np.int64
        )
        self.index_buffer = self._index.astype(np.uint32)

        # error groups: plain pattern of each level, and the merged (stitched) triangles
        groups, g_start, g_count = [], [], []
        n = 0
        for kind in ("plain", "stitched"):
            for lvl in range(self.n_levels):
                plain = templates[(lvl, 0)]
                if kind == "plain":
                    t = plain
                else:
                    all15 = templates[(lvl, 15)]
                    seen = {tuple(r) for r in plain.tolist()}
                    t = np.array([r for r in all15.tolist() if tuple(r) not in seen], np.int64)
                    t = t.reshape(-1, 6)
                g_start.append(n)
                g_count.append(len(t))
                groups.append(t)
                n += len(t)
        errs = np.zeros((npr, npc, 2 * self.n_levels))
        _patch_errors(
            heightmap.heights, p, npr, npc, np.concatenate(groups),
            np.array(g_start, np.int64), np.array(g_count, np.int64), errs,
        )
        self.delta = errs[..., : self.n_levels].copy()
        self.delta_stitched = np.maximum(self.delta, errs[..., self.n_levels:])
        # monotone over levels: a finer level is never allowed later than a coarser one
        self._dstitch_mono = np.ascontiguousarray(np.maximum.accumulate(self.delta_stitched, -1))

        self.quadtree = PatchQuadtree(heightmap, size)
        self._q = np.zeros((npr, npc))
        self._lev = np.zeros((npr, npc), np.int64)
        self._mask = np.zeros((npr, npc), np.int64)
        self._start = np.zeros((npr, npc), np.int64)
        self._count = np.zeros((npr, npc), np.int64)
        self._base = np.zeros((npr, npc), np.int64)
        self._visible = np.ones((npr, npc), np.bool_)
        self._culled = False
        # The last update's camera; its frustum is computed only when something culls with it
        # (computing the planes costs several times the level selection itself).
        self._view_camera: Camera | None = None
        self._visible_current = False  # self._visible holds the last update's frustum test
        self._updated = False
        self.last_rounds = 0

    # --- per frame ---------------------------------------------------------------------------
    def min_distances(self, camera: Camera, viewport, tolerance_px: float) -> np.ndarray:
        """``D_n = |δ|·C`` (the thesis's Formula 3) per patch and level, with the stitched δ.

        ``C = A/T``, ``A = n/|t|`` (near distance over the top of the near plane),
        ``T = 2τ/v_res``.
        """
        return self._dstitch_mono * self._c_factor(camera, viewport, tolerance_px)

    @staticmethod
    def _c_factor(camera, viewport, tolerance_px) -> float:
        if not isinstance(camera, Camera):
            raise InvalidParameterError(f"camera must be a terrascape Camera, got {type(camera)}")
        _, v_res = _viewport(viewport)
        tau = check_positive(tolerance_px, "tolerance_px (pixels)")
        n = camera.near
        t = n * math.tan(math.radians(camera.fov_y) / 2.0)
        a = n / abs(t)
        big_t = 2.0 * tau / v_res
        return a / big_t

    def update(self, camera: Camera, viewport, tolerance_px: float | None = 2.0, *,
               max_triangles: int | None = None, time_budget_ms: float | None = None,
               cull: bool = False) -> GeomipmapStats:
        """Select every patch's level for this view and its neighbour mask / index range.

        Parameters
        ----------
        camera
            :class:`~terrascape.camera.Camera` (position, fov_y and near are used).
        viewport
            ``(width, height)`` in pixels.
        tolerance_px
            τ, the largest allowed screen-space error in pixels (> 0).
        cull
            Also cull patches outside the view frustum with the quadtree; culled patches
            keep their level (neighbours still need it) but :meth:`triangles` and
            :meth:`draw_ranges` skip them.
        max_triangles, time_budget_ms
            Not taken (the tolerance alone sets the levels; ``bench lod_flight`` bisects it
            for a triangle count): anything but ``None`` raises
            :class:`~terrascape.errors.InvalidParameterError`.

        Returns
        -------
        GeomipmapStats
        """
        t0 = time.perf_counter()
        unsupported("geomipmapping", max_triangles=max_triangles, time_budget_ms=time_budget_ms)
        if tolerance_px is None:
            tolerance_px = 2.0
        c = self._c_factor(camera, viewport, tolerance_px)
        ex, ey, ez = (float(v) for v in camera.position)
        self.last_rounds = int(_select_levels(
            self.quadtree.patch_aabbs, ex, ey, ez, 1.0 / c, self._dstitch_mono, self._q,
            self._lev, self._mask, self._tstart, self._tcount, self._start, self._count,
            self._base, self._p, self.heightmap.cols,
        ))
        self._culled = bool(cull)
        self._view_camera = camera
        self._visible_current = False
        if cull:
            self._cull_to_last_view()
        self._updated = True
        return GeomipmapStats(
            triangles=self.triangle_count(),
            update_ms=(time.perf_counter() - t0) * 1000.0,
            min_level=int(self._lev.min()),
            max_level=int(self._lev.max()),
        )

    def _cull_to_last_view(self) -> None:
        if not self._visible_current:
            self.quadtree.visible(self._view_camera.frustum_planes(), out=self._visible)
            self._visible_current = True

    def _require_update(self) -> None:
        if not self._updated:
            raise InvalidParameterError("call Geomipmap.update(camera, viewport) first")

    @property
    def levels(self) -> np.ndarray:
        """Selected level per patch, int ``(patch_rows, patch_cols)`` (0 = full detail)."""
        self._require_update()
        return self._lev.copy()

    @property
    def masks(self) -> np.ndarray:
        """Neighbour mask per patch (bit 1 N, 2 E, 4 S, 8 W set = coarser neighbour)."""
        self._require_update()
        return self._mask.copy()

    @property
    def visible(self) -> np.ndarray:
        """Patches drawn this frame (all of them unless ``update(..., cull=True)``)."""
        self._require_update()
        return self._visible.copy() if self._culled else np.ones(self.patch_shape, np.bool_)

    def triangle_count(self) -> int:
        """Triangles :meth:`triangles` would return."""
        self._require_update()
        if self._culled:
            return int(self._count[self._visible].sum())
        return int(self._count.sum())

    def draw_ranges(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per drawn patch: ``(first_triangle, triangle_count, base_vertex)`` int64 arrays into
        :attr:`index_buffer` — the zero-copy path (``glDrawElementsBaseVertex`` with
        ``first = 3·first_triangle`` indices)."""
        self._require_update()
        sel = self._visible if self._culled else np.ones(self.patch_shape, np.bool_)
        return self._start[sel], self._count[sel], self._base[sel]

    def triangles(self, *, visible_only: bool = False) -> np.ndarray:
        """This frame's mesh as ``uint32 (M, 3)`` grid vertex indices, CCW from above.

        Patches culled by ``update(..., cull=True)`` are left out; ``visible_only`` culls
        with the last update's frustum also after an update without ``cull``.
        """
        self._require_update()
        culled = self._culled
        if visible_only and not culled:
            self._cull_to_last_view()
            culled = True
        count = int(self._count[self._visible].sum()) if culled else int(self._count.sum())
        out = np.empty((count, 3), np.uint32)
        _gather(self._index, self._start, self._count, self._base, self._visible,
                culled, out)
        return out
