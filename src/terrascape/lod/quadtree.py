"""Quadtree of axis-aligned bounding boxes over terrain patches, with view-frustum culling.

As in the thesis (§4.2, §5.2), the terrain is cut into patches; a quadtree of AABBs (min/max
height per node) is built once, and each frame the tree is walked from the root: a node
whose box is entirely outside one frustum plane is rejected with its whole subtree, a node
entirely inside every plane is accepted with its whole subtree, and only boxes straddling a
plane are opened further, down to single patches.

The box-vs-plane test is the usual conservative "p-vertex / n-vertex" test (the box corner
farthest along / against the plane normal), so a patch is never culled while any part of
its box is inside the frustum; a box near a frustum corner may be kept although it is
outside (as in any AABB culler).

References
----------
- D. Filipović, "Generiranje i prikaz terena" (Terrain generation and display), BSc thesis 221,
  Faculty of Electrical Engineering and Computing, University of Zagreb, 2008, §4.2, §5.2.
"""

from __future__ import annotations

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit
from terrascape._validate import check_int
from terrascape.errors import HeightmapSizeError, InvalidParameterError
from terrascape.heightmap import Heightmap

__all__ = ["PatchQuadtree", "patch_grid"]


def patch_grid(shape: tuple[int, int], patch_size: int) -> tuple[int, int]:
    """Number of patches ``(patch_rows, patch_cols)`` of ``patch_size`` samples (sharing
    their border samples) tiling a grid of ``shape``; raises if the patches do not fit."""
    size = check_int(patch_size, "patch_size", minimum=2)
    rows, cols = int(shape[0]), int(shape[1])
    p = size - 1
    if (rows - 1) % p or (cols - 1) % p:
        raise HeightmapSizeError(
            f"patch size {size} must tile the heightmap: (rows − 1) and (cols − 1) must be "
            f"multiples of {p}, got a {cols}×{rows} heightmap; use a patch size of 2**k + 1 "
            "on a 2**n + 1 map (e.g. 17 on 257, 513, 1025)"
        )
    return (rows - 1) // p, (cols - 1) // p


@njit(cache=CACHE, fastmath=FASTMATH)
def _patch_minmax(h, p, npr, npc, out_min, out_max):
    for i in range(npr):
        for j in range(npc):
            lo = np.float32(np.inf)
            hi = np.float32(-np.inf)
            for r in range(i * p, i * p + p + 1):
                for c in range(j * p, j * p + p + 1):
                    v = h[r, c]
                    if v < lo:
                        lo = v
                    if v > hi:
                        hi = v
            out_min[i, j] = lo
            out_max[i, j] = hi


@njit(cache=CACHE, fastmath=FASTMATH)
def _build_tree(npr, npc, pmin, pmax, px, pz, ranges, children, boxes):
    """Breadth-first build: node ranges [r0, r1) × [c0, c1) in patches, split in halves.

    Children always get higher indices than parents, so boxes are filled bottom-up by a
    reverse sweep. Returns the node count.
    """
    ranges[0, 0], ranges[0, 1], ranges[0, 2], ranges[0, 3] = 0, npr, 0, npc
    n = 1
    head = 0
    while head < n:
        r0, r1, c0, c1 = ranges[head, 0], ranges[head, 1], ranges[head, 2], ranges[head, 3]
        k = 0
        if r1 - r0 > 1 or c1 - c0 > 1:
            rm = (r0 + r1) // 2 if r1 - r0 > 1 else r1
            cm = (c0 + c1) // 2 if c1 - c0 > 1 else c1
            for a in range(2):
                ra = r0 if a == 0 else rm
                rb = rm if a == 0 else r1
                if rb <= ra:
                    continue
                for b in range(2):
                    ca = c0 if b == 0 else cm
                    cb = cm if b == 0 else c1
                    if cb <= ca:
                        continue
                    ranges[n, 0], ranges[n, 1], ranges[n, 2], ranges[n, 3] = ra, rb, ca, cb
                    children[head, k] = n
                    k += 1
                    n += 1
        head += 1
    for node in range(n - 1, -1, -1):
        r0, r1, c0, c1 = ranges[node, 0], ranges[node, 1], ranges[node, 2], ranges[node, 3]
        boxes[node, 0] = c0 * px
        boxes[node, 1] = c1 * px
        boxes[node, 4] = r0 * pz
        boxes[node, 5] = r1 * pz
        if children[node, 0] < 0:
            boxes[node, 2] = pmin[r0, c0]
            boxes[node, 3] = pmax[r0, c0]
        else:
            lo = np.inf
            hi = -np.inf
            for k in range(4):
                ch = children[node, k]
                if ch >= 0:
                    lo = min(lo, boxes[ch, 2])
                    hi = max(hi, boxes[ch, 3])
            boxes[node, 2] = lo
            boxes[node, 3] = hi
    return n


@njit(cache=CACHE, fastmath=FASTMATH)
def _classify(box, planes):
    """0 = outside some plane, 1 = straddling, 2 = fully inside all planes."""
    inside = True
    for i in range(planes.shape[0]):
        a, b, c, d = planes[i, 0], planes[i, 1], planes[i, 2], planes[i, 3]
        # p-vertex: the corner farthest along the inward normal
        px = box[1] if a >= 0 else box[0]
        py = box[3] if b >= 0 else box[2]
        pz = box[5] if c >= 0 else box[4]
        if a * px + b * py + c * pz + d < 0:
            return 0
        nx = box[0] if a >= 0 else box[1]
        ny = box[2] if b >= 0 else box[3]
        nz = box[4] if c >= 0 else box[5]
        if a * nx + b * ny + c * nz + d < 0:
            inside = False
    return 2 if inside else 1


@njit(cache=CACHE, fastmath=FASTMATH)
def _cull(boxes, ranges, children, planes, out, stack):
    out[:, :] = False
    top = 0
    stack[0] = 0
    top = 1
    tested = 0
    while top > 0:
        top -= 1
        node = stack[top]
        tested += 1
        cls = _classify(boxes[node], planes)
        if cls == 0:
            continue
        if cls == 2 or children[node, 0] < 0:
            for r in range(ranges[node, 0], ranges[node, 1]):
                for c in range(ranges[node, 2], ranges[node, 3]):
                    out[r, c] = True
            continue
        for k in range(4):
            ch = children[node, k]
            if ch >= 0:
                stack[top] = ch
                top += 1
    return tested


def _as_planes(frustum_planes) -> np.ndarray:
    planes = np.asarray(frustum_planes, dtype=np.float64)
    if planes.ndim != 2 or planes.shape[1] != 4 or planes.shape[0] == 0:
        raise InvalidParameterError(
            f"frustum planes must have shape (K, 4) as (a, b, c, d), got {planes.shape}"
        )
    if not np.isfinite(planes).all():
        raise InvalidParameterError("frustum planes must be finite (check the camera)")
    return np.ascontiguousarray(planes)


class PatchQuadtree:
    """Quadtree of AABBs over the ``patch_size``-sample patches of a heightmap.

    Parameters
    ----------
    heightmap
        :class:`~terrascape.Heightmap`; world positions are ``x = col·dx``, ``y = h``,
        ``z = row·dz``.
    patch_size
        Samples per patch side (patches share border samples): ``patch_size − 1`` must
        divide ``rows − 1`` and ``cols − 1``.

    Attributes
    ----------
    patch_shape
        ``(patch_rows, patch_cols)``.
    patch_aabbs
        float64 ``(patch_rows, patch_cols, 6)`` boxes ``(xmin, xmax, ymin, ymax, zmin, zmax)``.
    node_count
        Number of tree nodes.
    """

    def __init__(self, heightmap: Heightmap, patch_size: int = 17) -> None:
        if not isinstance(heightmap, Heightmap):
            raise InvalidParameterError(f"expected a Heightmap, got {type(heightmap).__name__}")
        npr, npc = patch_grid(heightmap.shape, patch_size)
        self.heightmap = heightmap
        self.patch_size = int(patch_size)
        self.patch_shape = (npr, npc)
        p = self.patch_size - 1
        pmin = np.empty((npr, npc), np.float32)
        pmax = np.empty((npr, npc), np.float32)
        _patch_minmax(heightmap.heights, p, npr, npc, pmin, pmax)
        dx, dz = heightmap.spacing
        cap = 2 * npr * npc + 8
        ranges = np.zeros((cap, 4), np.int64)
        children = np.full((cap, 4), -1, np.int64)
        boxes = np.zeros((cap, 6), np.float64)
        n = _build_tree(npr, npc, pmin, pmax, p * dx, p * dz, ranges, children, boxes)
        self._ranges = ranges[:n].copy()
        self._children = children[:n].copy()
        self._boxes = boxes[:n].copy()
        self.node_count = int(n)
        jj, ii = np.meshgrid(np.arange(npc), np.arange(npr))
        aabb = np.empty((npr, npc, 6))
        aabb[..., 0] = jj * p * dx
        aabb[..., 1] = (jj + 1) * p * dx
        aabb[..., 2] = pmin
        aabb[..., 3] = pmax
        aabb[..., 4] = ii * p * dz
        aabb[..., 5] = (ii + 1) * p * dz
        self.patch_aabbs = aabb
        self._out = np.zeros((npr, npc), np.bool_)
        self._stack = np.zeros(4 * n + 8, np.int64)
        self.last_nodes_tested = 0

    def visible(self, frustum_planes, *, out: np.ndarray | None = None) -> np.ndarray:
        """Patches whose AABB is not entirely outside a frustum plane.

        Parameters
        ----------
        frustum_planes
            ``(K, 4)`` planes ``(a, b, c, d)`` with inward normals (a point is inside when
            ``a·x + b·y + c·z + d >= 0`` for all), e.g. ``Camera.frustum_planes()``.
        out
            Optional bool ``(patch_rows, patch_cols)`` buffer to fill (no allocation).

        Returns
        -------
        numpy.ndarray
            bool ``(patch_rows, patch_cols)``; a new array unless ``out`` is given.
        """
        planes = _as_planes(frustum_planes)
        if out is None:
            out = np.zeros(self.patch_shape, np.bool_)
        elif out.shape != self.patch_shape or out.dtype != np.bool_:
            raise InvalidParameterError(
                f"out must be bool {self.patch_shape}, got {out.dtype} {out.shape}"
            )
        self.last_nodes_tested = int(
            _cull(self._boxes, self._ranges, self._children, planes, out, self._stack)
        )
        return out

    def visible_brute_force(self, frustum_planes) -> np.ndarray:
        """The same conservative AABB test applied to every patch, without the tree
        (reference for tests and the benchmark's disagreement count)."""
        planes = _as_planes(frustum_planes)
        box = self.patch_aabbs
        keep = np.ones(self.patch_shape, np.bool_)
        for a, b, c, d in planes:
            px = box[..., 1] if a >= 0 else box[..., 0]
            py = box[..., 3] if b >= 0 else box[..., 2]
            pz = box[..., 5] if c >= 0 else box[..., 4]
            keep &= a * px + b * py + c * pz + d >= 0
        return keep
