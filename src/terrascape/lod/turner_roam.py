"""Turner's ROAM (Bryan Turner 2000, "Real-Time Dynamic Level of Detail Terrain Rendering
with ROAM") — the implementation the thesis chose.

Differences from Duchaineau's ROAM (:mod:`terrascape.lod.roam`), as the thesis describes them:

* the map is cut into square patches of ``patch_size = 2**k + 1`` samples (shared borders),
  each with two root triangles and its own *variance tree*;
* there is only a split queue — or rather none: every frame the links are reset and the
  visible patches are tessellated again top-down, split-only (no merge queue, no frame
  coherence); splits still force the base neighbour to split, across patch borders too, so
  the mesh has no cracks;
* invisible patches are skipped using the quadtree of AABBs
  (:class:`terrascape.lod.quadtree.PatchQuadtree`);
* the split threshold ("frame variance") is adjusted every frame by feedback so the triangle
  count holds near a target (the thesis's 80,000).

Variance tree (Turner): for a triangle with hypotenuse ``v0–v1`` and midpoint ``v_c``

    var(T) = max(|z(v_c) − (z(v0) + z(v1)) / 2|, var(T0), var(T1)),

stored in an implicit heap array per patch for the first ``variance_depth`` levels (ids
``2 … 2**(variance_depth+1) − 1``); like Turner, a triangle deeper than the stored tree is
always split. Unlike Duchaineau's wedgie thickness this is a maximum, not a sum: a
heuristic, not a bound. A triangle splits when ``var(T)·K / d > threshold``, ``d`` the 3-D
distance from the eye to ``v_c`` (the thesis's fix for Turner's 2-D distance, which assumed a
camera hovering just above the ground) and ``K`` pixels per radian, so the threshold is in
pixels.

The tessellation is Turner's pointer bintree made flat: a node pool of int arrays
(children, base/left/right neighbours, patch, local heap id, level, corner coordinates),
reset every frame. Output as everywhere in :mod:`terrascape.lod`: ``uint32 (M, 3)`` grid
vertex indices ``row·cols + col``, counter-clockwise seen from above (+Y).

References
----------
- D. Filipović, "Generiranje i prikaz terena" (Terrain generation and display), BSc thesis 221,
  Faculty of Electrical Engineering and Computing, University of Zagreb, 2008, §4.1.1,
  §5.1–5.2, §5.3.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit
from terrascape._validate import check_int, check_positive, is_pow2_plus1
from terrascape.errors import HeightmapSizeError, InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.lod.quadtree import PatchQuadtree
from terrascape.lod.roam import _check_camera, _check_viewport
from terrascape.lod.schemes import unsupported

__all__ = ["TurnerRoam", "TurnerStats", "turner_variance"]

# coords columns
_AR, _AC, _R0, _C0, _R1, _C1 = 0, 1, 2, 3, 4, 5


# --------------------------------------------------------------------------------------------
# variance trees
# --------------------------------------------------------------------------------------------
@njit(cache=CACHE, fastmath=FASTMATH)
def _turner_variance(h, psize, npatch, depth, out):
    """Fill ``out[patch, id]`` (ids < 2**(depth+1)) with Turner's variance.

    Per patch: corners top-down over the whole tree, then maxima bottom-up (scratch arrays
    of the full depth, reused for every patch).
    """
    lp = 0
    s = psize
    while s > 1:
        s >>= 1
        lp += 2
    top = 1 << lp  # ids with a midpoint: levels 0 .. lp-1 → ids < 2**(lp+1)
    nid = 2 * top
    co = np.zeros((nid, 6), np.int64)
    var = np.zeros(nid, np.float64)
    for pr in range(npatch):
        for pc in range(npatch):
            r_org = pr * psize
            c_org = pc * psize
            co[2, 0], co[2, 1], co[2, 2] = r_org + psize, c_org, r_org + psize
            co[2, 3], co[2, 4], co[2, 5] = c_org + psize, r_org, c_org
            co[3, 0], co[3, 1], co[3, 2] = r_org, c_org + psize, r_org
            co[3, 3], co[3, 4], co[3, 5] = c_org, r_org + psize, c_org + psize
            for t in range(2, top):  # parents with grid-vertex children midpoints
                ar, ac, r0, c0, r1, c1 = co[t, 0], co[t, 1], co[t, 2], co[t, 3], co[t, 4], co[t, 5]
                mr = (r0 + r1) >> 1
                mc = (c0 + c1) >> 1
                u = 2 * t
                co[u, 0], co[u, 1], co[u, 2], co[u, 3], co[u, 4], co[u, 5] = mr, mc, ar, ac, r0, c0
                u += 1
                co[u, 0], co[u, 1], co[u, 2], co[u, 3], co[u, 4], co[u, 5] = mr, mc, r1, c1, ar, ac
            for t in range(nid - 1, 1, -1):
                r0, c0, r1, c1 = co[t, 2], co[t, 3], co[t, 4], co[t, 5]
                v = abs(
                    np.float64(h[(r0 + r1) >> 1, (c0 + c1) >> 1])
                    - 0.5 * (np.float64(h[r0, c0]) + np.float64(h[r1, c1]))
                )
                if t < top:
                    v = max(v, var[2 * t], var[2 * t + 1])
                var[t] = v
            p = pr * npatch + pc
            lim = min(nid, out.shape[1])
            for t in range(2, lim):
                out[p, t] = var[t]


def turner_variance(heightmap: Heightmap, patch_size: int, variance_depth: int | None = None):
    """Turner's per-patch variance trees, float32 ``(patches, 2**(variance_depth + 1))``.

    Row ``pr·P + pc`` is patch ``(pr, pc)``; column ``t`` is the heap id of a triangle in
    that patch (roots 2, 3; children ``2t``, ``2t + 1``). Default depth: the full patch
    (``2k`` levels for ``patch_size = 2**k + 1``).
    """
    _, psize, npatch, full = _check_layout(heightmap, patch_size)
    depth = _check_depth(variance_depth, full)
    out = np.zeros((npatch * npatch, 1 << (depth + 1)), np.float32)
    _turner_variance(heightmap.heights, np.int64(psize - 1), np.int64(npatch), depth, out)
    return out


# --------------------------------------------------------------------------------------------
# per-frame tessellation (Turner's Reset / Tessellate / Split on a flat node pool)
# --------------------------------------------------------------------------------------------
@njit(cache=CACHE, fastmath=FASTMATH)
def _reset(npatch, psize, lc, base, left, right, patch, tid, lvl, co):
    """Two root triangles per patch, linked to each other and to the neighbouring patches."""
    for pr in range(npatch):
        for pc in range(npatch):
            p = pr * npatch + pc
            a = 2 * p
            b = a + 1
            r_org = pr * psize
            c_org = pc * psize
            # A: apex SW, v0 SE, v1 NW  (left edge = south, right edge = west)
            co[a, 0], co[a, 1], co[a, 2] = r_org + psize, c_org, r_org + psize
            co[a, 3], co[a, 4], co[a, 5] = c_org + psize, r_org, c_org
            # B: apex NE, v0 NW, v1 SE  (left edge = north, right edge = east)
            co[b, 0], co[b, 1], co[b, 2] = r_org, c_org + psize, r_org
            co[b, 3], co[b, 4], co[b, 5] = c_org, r_org + psize, c_org + psize
            for x in (a, b):
                lc[x] = -1
                patch[x] = p
                lvl[x] = 0
            tid[a] = 2
            tid[b] = 3
            base[a] = b
            base[b] = a
            left[a] = 2 * ((pr + 1) * npatch + pc) + 1 if pr + 1 < npatch else -1
            right[a] = 2 * (pr * npatch + pc - 1) + 1 if pc > 0 else -1
            left[b] = 2 * ((pr - 1) * npatch + pc) if pr > 0 else -1
            right[b] = 2 * (pr * npatch + pc + 1) if pc + 1 < npatch else -1
    return 2 * npatch * npatch


@njit(cache=CACHE, fastmath=FASTMATH)
def _relink(nb, old, new, base, left, right):
    """Make neighbour ``nb`` point to ``new`` wherever it pointed to ``old``."""
    if nb < 0:
        return
    if base[nb] == old:
        base[nb] = new
    elif left[nb] == old:
        left[nb] = new
    elif right[nb] == old:
        right[nb] = new


@njit(cache=CACHE, fastmath=FASTMATH)
def _split(t, n, lc, base, left, right, patch, tid, lvl, co, stack):
    """Turner's Split with forced splits, iteratively; the caller guarantees pool room for
    the whole chain. Returns the new pool size."""
    stack[0] = t
    sp = 1
    while sp > 0:
        y = stack[sp - 1]
        if lc[y] >= 0:
            sp -= 1
            continue
        b = base[y]
        if b >= 0 and base[b] != y:  # base neighbour is coarser: split it first
            stack[sp] = b
            sp += 1
            continue
        c0 = n
        c1 = n + 1
        n += 2
        lc[y] = c0
        ar, ac, r0, cc0, r1, cc1 = co[y, 0], co[y, 1], co[y, 2], co[y, 3], co[y, 4], co[y, 5]
        mr = (r0 + r1) >> 1
        mc = (cc0 + cc1) >> 1
        # T0 = (v_c, v_a, v_0), T1 = (v_c, v_1, v_a)
        co[c0, 0], co[c0, 1], co[c0, 2], co[c0, 3], co[c0, 4], co[c0, 5] = mr, mc, ar, ac, r0, cc0
        co[c1, 0], co[c1, 1], co[c1, 2], co[c1, 3], co[c1, 4], co[c1, 5] = mr, mc, r1, cc1, ar, ac
        for x in (c0, c1):
            lc[x] = -1
            patch[x] = patch[y]
            lvl[x] = lvl[y] + 1
        tid[c0] = 2 * tid[y]
        tid[c1] = 2 * tid[y] + 1
        base[c0] = left[y]
        left[c0] = c1
        right[c0] = -1
        base[c1] = right[y]
        right[c1] = c0
        left[c1] = -1
        _relink(left[y], y, c0, base, left, right)
        _relink(right[y], y, c1, base, left, right)
        sp -= 1
        if b >= 0:
            if lc[b] >= 0:  # the partner is already split: link the four children
                bl = lc[b]
                br = bl + 1
                right[bl] = c1
                left[br] = c0
                right[c0] = br
                left[c1] = bl
            else:  # split the partner too (it will link to our children)
                stack[sp] = b
                sp += 1
    return n


@njit(cache=CACHE, fastmath=FASTMATH)
def _tessellate(h, var, depth, lp, npatch, psize, vis, cam, thr,
                lc, base, left, right, patch, tid, lvl, co, stack, split_stack, ivars):  # fmt: skip
    """Reset, then tessellate every visible patch top-down. ``cam`` = [ex, ey, ez, K, near,
    dx, dz]. ``ivars`` receives [nodes, leaves, exhausted]."""
    n = _reset(npatch, psize, lc, base, left, right, patch, tid, lvl, co)
    cap = lc.shape[0]
    reserve = 4 * (lp + 2)
    leaves = n
    exhausted = 0
    ex, ey, ez, k, near, dx, dz = cam[0], cam[1], cam[2], cam[3], cam[4], cam[5], cam[6]
    for p in range(npatch * npatch):
        if not vis[p] or exhausted:
            continue
        sp = 0
        stack[0] = 2 * p
        stack[1] = 2 * p + 1
        sp = 2
        while sp > 0:
            sp -= 1
            x = stack[sp]
            lv = lvl[x]
            if lv >= lp:
                continue
            if lc[x] < 0:
                split = True
                if lv < depth:
                    v = var[patch[x], tid[x]]
                    if v <= 0.0:
                        split = False
                    else:
                        mr = (co[x, 2] + co[x, 4]) >> 1
                        mc = (co[x, 3] + co[x, 5]) >> 1
                        wx = mc * dx - ex
                        wy = np.float64(h[mr, mc]) - ey
                        wz = mr * dz - ez
                        d = math.sqrt(wx * wx + wy * wy + wz * wz)
                        if d < near:
                            d = near
                        split = v * k / d > thr
                if not split:
                    continue
                if n + reserve > cap:
                    exhausted = 1
                    break
                before = n
                n = _split(x, n, lc, base, left, right, patch, tid, lvl, co, split_stack)
                leaves += (n - before) // 2
            if lv + 1 < lp:
                stack[sp] = lc[x]
                stack[sp + 1] = lc[x] + 1
                sp += 2
    ivars[0] = n
    ivars[1] = leaves
    ivars[2] = exhausted


@njit(cache=CACHE, fastmath=FASTMATH)
def _collect(n, lc, patch, co, vis, visible_only, cols, out):
    m = 0
    for x in range(n):
        if lc[x] >= 0:
            continue
        if visible_only and not vis[patch[x]]:
            continue
        out[m, 0] = co[x, 0] * cols + co[x, 1]
        out[m, 1] = co[x, 2] * cols + co[x, 3]
        out[m, 2] = co[x, 4] * cols + co[x, 5]
        m += 1
    return m


# --------------------------------------------------------------------------------------------
# public API
# --------------------------------------------------------------------------------------------
def _check_layout(heightmap, patch_size):
    if not isinstance(heightmap, Heightmap):
        raise InvalidParameterError(f"expected a Heightmap, got {type(heightmap).__name__}")
    n = heightmap.require_pow2_plus1("Turner's ROAM")
    psize = check_int(patch_size, "patch_size (samples)", minimum=3)
    if not is_pow2_plus1(psize) or psize > n:
        raise HeightmapSizeError(
            f"patch_size must be 2**k + 1 and at most the map size {n} (e.g. 17, 33, 65), "
            f"got {psize}"
        )
    npatch = (n - 1) // (psize - 1)
    full = 2 * ((psize - 1).bit_length() - 1)
    return n - 1, psize, npatch, full


def _check_depth(variance_depth, full: int) -> int:
    if variance_depth is None:
        return full
    return check_int(variance_depth, "variance_depth (levels)", minimum=1, maximum=full)


@dataclass(frozen=True)
class TurnerStats:
    """What one :meth:`TurnerRoam.update` did.

    Attributes
    ----------
    frame
        Frame number (1 for the first update).
    triangles
        Leaf triangles over the whole map (culled patches contribute their two roots unless
        a forced split reached them).
    visible_patches
        Patches that passed the quadtree frustum test and were tessellated.
    threshold_px
        Split threshold used this frame (pixels); the next frame's is adjusted by feedback.
    update_ms
        Wall time: culling + reset + tessellation + feedback, milliseconds.
    pool_exhausted
        True when the node pool ran out and tessellation stopped early (the mesh is still
        conforming; the feedback raises the threshold).
    passes
        Tessellation passes this frame: 1, or more when the count missed the target by more
        than 5 % and ``correction_passes`` allowed an immediate re-tessellation.
    """

    frame: int
    triangles: int
    visible_patches: int
    threshold_px: float
    update_ms: float
    pool_exhausted: bool
    passes: int = 1
    settled: bool = True

    @property
    def summary(self) -> str:
        return f"threshold {self.threshold_px:.3g} px"


class TurnerRoam:
    """Turner's split-only ROAM over patches, rebuilt every frame, with a triangle target.

    Parameters
    ----------
    heightmap
        Square ``(2**n + 1)²`` :class:`~terrascape.Heightmap` (pad others with
        ``Heightmap.to_pow2_plus1()`` / ``--pad``).
    patch_size
        Samples per patch side, ``2**k + 1`` (shared borders); default 65.
    target_triangles
        Triangle count the feedback holds (default 80,000, the thesis's figure).
    variance_depth
        Levels stored in each patch's variance tree (default: all ``2k``); deeper
        triangles always split, as in Turner's code.
    threshold_px
        Initial split threshold in pixels (default 1).
    pool_factor
        Node pool size as a multiple of ``2·target_triangles`` (>= 1.5; default 4).
    correction_passes
        Extra tessellation passes allowed in one frame when the count misses the target by
        more than 5 % (default 2; 0 is Turner's pure frame-to-frame feedback). Each pass
        uses the threshold the feedback just corrected, so a sudden view change (patches
        entering or leaving the frustum) does not show as a frame far off the target.
    """

    def __init__(
        self,
        heightmap: Heightmap,
        patch_size: int = 65,
        target_triangles: int = 80_000,
        *,
        variance_depth: int | None = None,
        threshold_px: float = 1.0,
        pool_factor: float = 4.0,
        correction_passes: int = 2,
    ) -> None:
        size, psize, npatch, full = _check_layout(heightmap, patch_size)
        self.heightmap = heightmap
        self.size = size
        self.patch_size = psize
        self.patches = npatch
        self.max_level = full
        self.variance_depth = _check_depth(variance_depth, full)
        self.target_triangles = check_int(target_triangles, "target_triangles", minimum=2)
        self.threshold_px = check_positive(threshold_px, "threshold_px (pixels)")
        self.correction_passes = check_int(correction_passes, "correction_passes", minimum=0)
        pool_factor = check_positive(pool_factor, "pool_factor")
        if pool_factor < 1.5:
            raise InvalidParameterError(f"pool_factor must be >= 1.5, got {pool_factor}")
        self._pool_factor = pool_factor
        self._initial_threshold = self.threshold_px
        self._variance = turner_variance(heightmap, psize, self.variance_depth)
        self.quadtree = PatchQuadtree(heightmap, psize)
        self._stack = np.zeros(2 * (full + 4), np.int64)
        self._split_stack = np.zeros(2 * (full + 4), np.int64)
        self._vis = np.zeros((npatch, npatch), np.bool_)
        self._ivars = np.zeros(3, np.int64)
        self.frame = 0
        self._allocate()

    def _allocate(self) -> None:
        """Node pool for the current target, base tessellation, fresh feedback state."""
        npatch, full = self.patches, self.max_level
        roots = 2 * npatch * npatch
        cap = int(2 * self._pool_factor * self.target_triangles) + roots + 4 * (full + 2) + 8
        self._lc = np.full(cap, -1, np.int32)
        self._base = np.full(cap, -1, np.int32)
        self._left = np.full(cap, -1, np.int32)
        self._right = np.full(cap, -1, np.int32)
        self._patch = np.zeros(cap, np.int32)
        self._tid = np.zeros(cap, np.int32)
        self._lvl = np.zeros(cap, np.int32)
        self._co = np.zeros((cap, 6), np.int32)
        self.threshold_px = self._initial_threshold
        # feedback state (log-space secant on count(threshold))
        self._prev: tuple[float, float] | None = None
        self._slope = 1.0
        _reset_arrays = _reset(
            np.int64(npatch), np.int64(self.patch_size - 1), self._lc, self._base, self._left,
            self._right, self._patch, self._tid, self._lvl, self._co,
        )  # fmt: skip
        self._nodes = self._leaves = int(_reset_arrays)

    def retarget(self, target_triangles: int) -> None:
        """Hold ``target_triangles`` from the next update on: the node pool is re-sized and
        the threshold feedback starts again (as a new instance would), the patch variances
        are kept."""
        target = check_int(target_triangles, "target_triangles", minimum=2)
        if target != self.target_triangles:
            self.target_triangles = target
            self._allocate()

    @property
    def triangle_count(self) -> int:
        return self._leaves

    def visible_patches(self) -> np.ndarray:
        """bool ``(P, P)`` patches tessellated in the last update."""
        return self._vis.copy()

    def update(self, camera, viewport: tuple[int, int], *, tolerance_px: float | None = None,
               max_triangles: int | None = None,
               time_budget_ms: float | None = None) -> TurnerStats:
        """Cull patches, rebuild the tessellation for ``camera``, adjust the threshold.

        Parameters
        ----------
        camera
            :class:`~terrascape.camera.Camera`.
        viewport
            ``(width, height)`` in pixels.
        max_triangles
            New triangle target (:meth:`retarget`); default: keep the current one.
        tolerance_px, time_budget_ms
            Not taken (the threshold is set by the feedback, the rebuild is not
            interruptible): anything but ``None`` raises
            :class:`~terrascape.errors.InvalidParameterError`.
        """
        t0 = time.perf_counter()
        unsupported("Turner's ROAM", tolerance_px=tolerance_px, time_budget_ms=time_budget_ms)
        if max_triangles is not None:
            self.retarget(max_triangles)
        camera = _check_camera(camera)
        _, height = _check_viewport(viewport)
        planes = camera.frustum_planes()
        if not np.isfinite(planes).all():
            raise InvalidParameterError("camera frustum planes are not finite (check the camera)")
        self.quadtree.visible(planes, out=self._vis)
        dx, dz = self.heightmap.spacing
        cam = np.array(
            [*camera.eye, camera.pixels_per_radian(height), camera.near, dx, dz], np.float64
        )
        passes = 0
        while True:
            thr = self.threshold_px
            _tessellate(
                self.heightmap.heights, self._variance, np.int64(self.variance_depth),
                np.int64(self.max_level), np.int64(self.patches), np.int64(self.patch_size - 1),
                self._vis.reshape(-1), cam, float(thr), self._lc, self._base, self._left,
                self._right, self._patch, self._tid, self._lvl, self._co, self._stack,
                self._split_stack, self._ivars,
            )  # fmt: skip
            passes += 1
            self._nodes, self._leaves = int(self._ivars[0]), int(self._ivars[1])
            exhausted = bool(self._ivars[2])
            self._feedback(thr, exhausted)
            off = abs(self._leaves / self.target_triangles - 1.0)
            if passes > self.correction_passes or (off <= 0.05 and not exhausted):
                break
            if self.threshold_px == thr:  # the feedback cannot move (e.g. nothing visible)
                break
        self.frame += 1
        return TurnerStats(
            frame=self.frame,
            triangles=self._leaves,
            visible_patches=int(self._vis.sum()),
            threshold_px=thr,
            update_ms=(time.perf_counter() - t0) * 1000.0,
            pool_exhausted=exhausted,
            passes=passes,
            # the feedback converges over frames: not settled while off target (unless the
            # whole map at full resolution is already drawn)
            settled=abs(self._leaves / self.target_triangles - 1.0) <= 0.05
            or self._leaves >= 2 * self.size * self.size,
        )

    def _feedback(self, thr: float, exhausted: bool) -> None:
        """Turner's "frame variance" feedback, in log space: a secant step on
        log(count) vs log(threshold) so the count converges in a few frames instead of
        Turner's fixed additive step."""
        count = self._leaves
        target = self.target_triangles
        if exhausted:
            self.threshold_px = thr * 4.0
            self._prev = None
            return
        roots = 2 * self.patches * self.patches
        visible = int(self._vis.sum())
        if visible == 0 or (count <= roots and target <= roots):
            return
        lt, lc = math.log(thr), math.log(max(count, 1))
        if self._prev is not None:
            dlt = lt - self._prev[0]
            dlc = lc - self._prev[1]
            if abs(dlt) > 1e-6 and dlc != 0.0:
                slope = min(max(-dlc / dlt, 0.2), 5.0)
                self._slope = 0.5 * self._slope + 0.5 * slope
        self._prev = (lt, lc)
        err = lc - math.log(target)
        if abs(err) < 0.01:  # within 1 %: hold still (no jitter)
            return
        step = max(min(err / self._slope, math.log(4.0)), -math.log(4.0))
        self.threshold_px = min(max(thr * math.exp(step), 1e-9), 1e12)

    def triangles(self, *, visible_only: bool = False) -> np.ndarray:
        """The last tessellation: uint32 ``(M, 3)`` grid vertex indices ``row·cols + col``,
        counter-clockwise seen from above (+Y). By default the whole map (conforming, tiles
        the grid); ``visible_only`` keeps the triangles of visible patches only (what Turner
        draws)."""
        out = np.empty((self._leaves, 3), np.uint32)
        m = _collect(
            np.int64(self._nodes), self._lc, self._patch, self._co, self._vis.reshape(-1),
            bool(visible_only), np.int64(self.size + 1), out,
        )  # fmt: skip
        return out[:m]
