"""The exact sun shadow of objects and terrain per pixel of a camera, by ray casting on the
CPU: the reference the GPU's shadow volumes and shadow maps are measured against.

For each pixel the surface point seen is taken from the frame's depth buffer (so reference
and frame agree on *what* is seen and are compared only on *whether it is in shadow*); the
segment from that point toward the sun is tested against every object triangle (a uniform
grid over the ground plane, walked cell by cell along the segment's shadow on it) and
against the terrain as drawn (the two triangles of every grid cell the segment passes over).

References
----------
Amanatides, J. & Woo, A. (1987). A fast voxel traversal algorithm for ray tracing.
*Eurographics '87*, 3-10.

Möller, T. & Trumbore, B. (1997). Fast, minimum storage ray-triangle intersection.
*Journal of Graphics Tools* 2(1), 21-28.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, prange
from terrascape.camera import Camera
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.objects.model import Instances

# Start each shadow ray this many depth quanta along it: a point from a 24-bit depth buffer
# lies up to a quantum off its surface (behind it, inside the object) and must not shadow
# itself.
_START_QUANTA = 4.0
# ... and a triangle whose plane passes within this many depth quanta of the ray's start is
# the surface the point lies on: it cannot shadow the point. A start point a fraction of a
# quantum behind a face the sun grazes (N·L ≈ 0.07) leaves through that face at t = δ / N·L,
# beyond any start offset along the ray. A few quanta cover the points' offsets; far more
# would hide real occluders close to a face (docs/benchmarks.md, "Object shadows").
_PLANE_QUANTA = 8.0
_DEPTH_BITS = 24


@njit(cache=CACHE, fastmath=FASTMATH)
def _hit_triangle(ox, oy, oz, dx, dy, dz, ax, ay, az, bx, by, bz, cx, cy, cz, t_min, t_max,
                  plane_tol):
    """Möller-Trumbore: does the ray o + t·d hit triangle abc for t in (t_min, t_max)? Not
    when o lies within ``plane_tol`` of the triangle's plane (the triangle o lies on)."""
    e1x, e1y, e1z = bx - ax, by - ay, bz - az
    e2x, e2y, e2z = cx - ax, cy - ay, cz - az
    if plane_tol > 0.0:
        nx = e1y * e2z - e1z * e2y
        ny = e1z * e2x - e1x * e2z
        nz = e1x * e2y - e1y * e2x
        dist = (ox - ax) * nx + (oy - ay) * ny + (oz - az) * nz
        if dist * dist < plane_tol * plane_tol * (nx * nx + ny * ny + nz * nz):
            return False
    px = dy * e2z - dz * e2y
    py = dz * e2x - dx * e2z
    pz = dx * e2y - dy * e2x
    det = e1x * px + e1y * py + e1z * pz
    if abs(det) < 1e-20:
        return False
    inv = 1.0 / det
    sx, sy, sz = ox - ax, oy - ay, oz - az
    u = (sx * px + sy * py + sz * pz) * inv
    if u < 0.0 or u > 1.0:
        return False
    qx = sy * e1z - sz * e1y
    qy = sz * e1x - sx * e1z
    qz = sx * e1y - sy * e1x
    v = (dx * qx + dy * qy + dz * qz) * inv
    if v < 0.0 or u + v > 1.0:
        return False
    t = (e2x * qx + e2y * qy + e2z * qz) * inv
    return t_min < t < t_max


@njit(cache=CACHE, fastmath=FASTMATH)
def _cell_walk_start(o, d, x0, z0, cell, nx, nz):
    """Amanatides-Woo set-up on a 2-D grid of square cells over x, z: the first cell and the
    per-axis step, t of the next boundary and t between boundaries."""
    fx = (o[0] - x0) / cell
    fz = (o[2] - z0) / cell
    ix = min(max(int(np.floor(fx)), 0), nx - 1)
    iz = min(max(int(np.floor(fz)), 0), nz - 1)
    sx = 1 if d[0] > 0 else -1
    sz = 1 if d[2] > 0 else -1
    if d[0] != 0.0:
        bx = x0 + (ix + (1 if sx > 0 else 0)) * cell
        tx, dtx = (bx - o[0]) / d[0], cell / abs(d[0])
    else:
        tx, dtx = np.inf, np.inf
    if d[2] != 0.0:
        bz = z0 + (iz + (1 if sz > 0 else 0)) * cell
        tz, dtz = (bz - o[2]) / d[2], cell / abs(d[2])
    else:
        tz, dtz = np.inf, np.inf
    return ix, iz, sx, sz, tx, tz, dtx, dtz


@njit(cache=CACHE, fastmath=FASTMATH)
def _ray_hits_objects(o, d, t_min, plane_tol, y_top, tris, cell_start, cell_tris, x0, z0, cell,
                      nx, nz):
    """Does the ray o + t·d (t > t_min, d pointing up) hit a triangle (not one whose plane
    passes within plane_tol of o) before rising above y_top or leaving the grid?"""
    t_exit = (y_top - o[1]) / d[1] if d[1] > 0.0 else np.inf
    # clip the ray to the grid's footprint (slabs in x and z): it may start outside it
    t_in, t_out = 0.0, t_exit
    for a, lo, size in ((0, x0, nx * cell), (2, z0, nz * cell)):
        if d[a] == 0.0:
            if o[a] < lo or o[a] > lo + size:
                return False
        else:
            ta, tb = (lo - o[a]) / d[a], (lo + size - o[a]) / d[a]
            t_in = max(t_in, min(ta, tb))
            t_out = min(t_out, max(ta, tb))
    if t_out < t_in:
        return False
    s = o + t_in * d
    ix, iz, sx, sz, tx, tz, dtx, dtz = _cell_walk_start(s, d, x0, z0, cell, nx, nz)
    tx += t_in
    tz += t_in
    while True:
        c = iz * nx + ix
        t_next = min(tx, tz)
        for k in range(cell_start[c], cell_start[c + 1]):
            j = cell_tris[k]
            if _hit_triangle(o[0], o[1], o[2], d[0], d[1], d[2],
                             tris[j, 0, 0], tris[j, 0, 1], tris[j, 0, 2],
                             tris[j, 1, 0], tris[j, 1, 1], tris[j, 1, 2],
                             tris[j, 2, 0], tris[j, 2, 1], tris[j, 2, 2], t_min, np.inf,
                             plane_tol):
                return True
        if t_next > t_out:
            return False
        if tx < tz:
            ix += sx
            tx += dtx
        else:
            iz += sz
            tz += dtz
        if ix < 0 or iz < 0 or ix >= nx or iz >= nz:
            return False


@njit(cache=CACHE, fastmath=FASTMATH)
def _ray_hits_terrain(o, d, t_min, h, dx, dz, y_top):
    """Does the ray hit the terrain as drawn (cell (r, c): triangles (r,c)(r+1,c)(r,c+1) and
    (r,c+1)(r+1,c)(r+1,c+1)) before rising above y_top or leaving it?"""
    rows, cols = h.shape
    ext_x, ext_z = (cols - 1) * dx, (rows - 1) * dz
    if o[0] < 0.0 or o[2] < 0.0 or o[0] > ext_x or o[2] > ext_z:
        return False
    # a point from the depth buffer may lie a little under the drawn surface: lift it onto
    # the surface there, or the ray would leave the ground through its own triangle
    c0 = min(int(np.floor(o[0] / dx)), cols - 2)
    r0 = min(int(np.floor(o[2] / dz)), rows - 2)
    u, v = o[0] / dx - c0, o[2] / dz - r0
    if u + v <= 1.0:
        y = h[r0, c0] + u * (h[r0, c0 + 1] - h[r0, c0]) + v * (h[r0 + 1, c0] - h[r0, c0])
    else:
        y = (h[r0 + 1, c0 + 1] + (1.0 - u) * (h[r0 + 1, c0] - h[r0 + 1, c0 + 1])
             + (1.0 - v) * (h[r0, c0 + 1] - h[r0 + 1, c0 + 1]))
    if o[1] < y:
        o = np.array([o[0], y, o[2]])
    # cells in x of width dx and in z of depth dz: walk a grid scaled to square cells
    s = dz / dx
    oo = np.array([o[0], o[1], o[2] / s])
    dd = np.array([d[0], d[1], d[2] / s])
    t_exit = (y_top - o[1]) / d[1] if d[1] > 0.0 else np.inf
    ix, iz, sx, sz, tx, tz, dtx, dtz = _cell_walk_start(oo, dd, 0.0, 0.0, dx, cols - 1, rows - 1)
    while True:
        x0, x1 = ix * dx, (ix + 1) * dx
        z0, z1 = iz * dz, (iz + 1) * dz
        h00, h01 = h[iz, ix], h[iz, ix + 1]
        h10, h11 = h[iz + 1, ix], h[iz + 1, ix + 1]
        if _hit_triangle(o[0], o[1], o[2], d[0], d[1], d[2], x0, h00, z0, x0, h10, z1,
                         x1, h01, z0, t_min, np.inf, 0.0):
            return True
        if _hit_triangle(o[0], o[1], o[2], d[0], d[1], d[2], x1, h01, z0, x0, h10, z1,
                         x1, h11, z1, t_min, np.inf, 0.0):
            return True
        if min(tx, tz) > t_exit:
            return False
        if tx < tz:
            ix += sx
            tx += dtx
        else:
            iz += sz
            tz += dtz
        if ix < 0 or iz < 0 or ix >= cols - 1 or iz >= rows - 1:
            return False


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _occlusion_kernel(points, valid, t_start, plane_tol, sun, tris, cell_start, cell_tris, x0,
                      z0, cell, nx, nz, y_obj, h, dx, dz, y_ter, use_objects, use_terrain,
                      obj_out, ter_out):
    n = points.shape[0]
    for i in prange(n):
        if not valid[i]:
            continue
        o = points[i]
        if use_objects:
            obj_out[i] = _ray_hits_objects(o, sun, t_start[i], plane_tol[i], y_obj, tris,
                                           cell_start, cell_tris, x0, z0, cell, nx, nz)
        if use_terrain:
            ter_out[i] = _ray_hits_terrain(o, sun, t_start[i], h, dx, dz, y_ter)


@dataclass(frozen=True)
class TriangleGrid:
    """Triangles bucketed by a uniform grid of square cells over the ground plane (x, z)."""

    triangles: np.ndarray  # float64 (T, 3, 3)
    cell_start: np.ndarray  # int64 (nx·nz + 1,)
    cell_tris: np.ndarray  # int64: triangle ids, cell after cell
    origin: tuple[float, float]
    cell: float
    shape: tuple[int, int]  # (nx, nz)
    top: float  # highest vertex

    @classmethod
    def build(cls, triangles: np.ndarray, cell: float | None = None) -> TriangleGrid:
        tri = np.ascontiguousarray(triangles, dtype=np.float64)
        if tri.ndim != 3 or tri.shape[1:] != (3, 3) or not np.isfinite(tri).all():
            raise InvalidParameterError(f"triangles must be finite (T, 3, 3), got {tri.shape}")
        if len(tri) == 0:
            return cls(tri, np.zeros(2, np.int64), np.zeros(0, np.int64), (0.0, 0.0), 1.0,
                       (1, 1), -np.inf)
        lo = tri[:, :, [0, 2]].min(axis=1)
        hi = tri[:, :, [0, 2]].max(axis=1)
        glo, ghi = lo.min(axis=0), hi.max(axis=0)
        if cell is None:
            # about one triangle's extent per cell, at most 4096² cells
            size = float(np.median((hi - lo).max(axis=1)))
            cell = max(size, float((ghi - glo).max()) / 4096.0, 1e-6)
        n = np.maximum(np.ceil((ghi - glo) / cell).astype(np.int64), 1)
        i0 = np.clip(((lo - glo) / cell).astype(np.int64), 0, n - 1)
        i1 = np.clip(((hi - glo) / cell).astype(np.int64), 0, n - 1)
        span = (i1 - i0 + 1)
        reps = span[:, 0] * span[:, 1]
        tid = np.repeat(np.arange(len(tri)), reps)
        k = np.arange(reps.sum()) - np.repeat(np.cumsum(reps) - reps, reps)
        cx = i0[tid, 0] + k % span[tid, 0]
        cz = i0[tid, 1] + k // span[tid, 0]
        cid = cz * n[0] + cx
        order = np.argsort(cid, kind="stable")
        start = np.zeros(n[0] * n[1] + 1, np.int64)
        np.add.at(start, cid + 1, 1)
        return cls(tri, np.cumsum(start), tid[order].astype(np.int64),
                   (float(glo[0]), float(glo[1])), float(cell), (int(n[0]), int(n[1])),
                   float(tri[..., 1].max()))


def _sun_vector(sun) -> np.ndarray:
    from terrascape.lighting.sun import sun_direction

    arr = np.asarray(sun, dtype=np.float64).reshape(-1)
    if arr.size == 2:
        arr = np.asarray(sun_direction(float(arr[0]), float(arr[1])), np.float64)
    if arr.size != 3 or not np.isfinite(arr).all() or np.linalg.norm(arr) == 0:
        raise InvalidParameterError(
            f"sun must be (azimuth, elevation) degrees or a direction toward it, got {sun!r}")
    return arr / np.linalg.norm(arr)


def sun_occlusion(points: np.ndarray, sun, *, triangles: np.ndarray | None = None,
                  heightmap: Heightmap | None = None, exaggeration: float = 1.0,
                  start: np.ndarray | float = 0.0, plane: np.ndarray | float = 0.0,
                  grid: TriangleGrid | None = None) -> tuple[np.ndarray, np.ndarray]:
    """For world points ``(N, 3)`` (NaN rows are skipped): does the ray toward the sun hit
    an object triangle, and does it hit the terrain?

    Parameters
    ----------
    sun
        ``(azimuth, elevation)`` degrees or a direction toward the sun.
    triangles
        float ``(T, 3, 3)`` world triangles of the objects (e.g.
        :meth:`Instances.world_triangles`), or ``grid`` already built from them.
    heightmap, exaggeration
        The terrain as drawn (heights × exaggeration); ``None``: objects only.
    start
        Distance along each ray before which hits do not count (per point or one value).
    plane
        An object triangle whose plane passes within this distance of a point is the
        surface the point lies on and does not count (per point or one value; 0: every
        triangle counts). A point read from a depth buffer lies a little off its surface,
        and behind a face the sun grazes its ray leaves through that face far beyond any
        ``start``.

    Returns
    -------
    (object_hit, terrain_hit)
        bool ``(N,)`` each.
    """
    pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    valid = np.isfinite(pts).all(axis=1)
    d = _sun_vector(sun)
    n = len(pts)
    t0 = np.ascontiguousarray(np.broadcast_to(np.asarray(start, np.float64), (n,)))
    tol = np.ascontiguousarray(np.broadcast_to(np.asarray(plane, np.float64), (n,)))
    if not (np.isfinite(t0).all() and np.isfinite(tol).all() and (tol >= 0).all()):
        raise InvalidParameterError("start and plane must be finite, plane ≥ 0")
    if grid is None:
        grid = TriangleGrid.build(np.zeros((0, 3, 3)) if triangles is None else triangles)
    use_terrain = heightmap is not None
    if use_terrain:
        if not isinstance(heightmap, Heightmap):
            raise InvalidParameterError(
                f"heightmap must be a Heightmap, got {type(heightmap).__name__}")
        h = np.ascontiguousarray(heightmap.heights, np.float64) * float(exaggeration)
        hdx, hdz = (float(s) for s in heightmap.spacing)
    else:
        h, hdx, hdz = np.zeros((2, 2)), 1.0, 1.0
    obj = np.zeros(n, np.bool_)
    ter = np.zeros(n, np.bool_)
    if d[1] <= 0.0:  # the sun at or below the horizon: nothing is lit
        obj[valid] = len(grid.triangles) > 0
        ter[valid] = use_terrain
        return obj, ter
    pts_safe = np.where(valid[:, None], pts, 0.0)
    _occlusion_kernel(pts_safe, valid, t0, tol, d, grid.triangles, grid.cell_start, grid.cell_tris,
                      grid.origin[0], grid.origin[1], grid.cell, grid.shape[0], grid.shape[1],
                      grid.top, h, hdx, hdz, float(h.max()), len(grid.triangles) > 0,
                      use_terrain, obj, ter)
    return obj, ter


def surface_points(camera: Camera, depth: np.ndarray) -> np.ndarray:
    """World points ``(h, w, 3)`` of a window-depth image (row 0 at the top, [0, 1], 1 = no
    surface → NaN) seen by ``camera`` (its aspect as drawn)."""
    if not isinstance(camera, Camera):
        raise InvalidParameterError(f"camera must be a Camera, got {type(camera).__name__}")
    z = np.asarray(depth, dtype=np.float64)
    if z.ndim != 2:
        raise InvalidParameterError(f"depth must be a 2-D image, got shape {z.shape}")
    h, w = z.shape
    inv = np.linalg.inv(camera.view_projection())
    x = (np.arange(w) + 0.5) / w * 2.0 - 1.0
    y = 1.0 - (np.arange(h) + 0.5) / h * 2.0
    xx, yy = np.meshgrid(x, y)
    ndc = np.stack([xx, yy, z * 2.0 - 1.0, np.ones_like(xx)], axis=-1)
    world = ndc @ inv.T
    pts = world[..., :3] / world[..., 3:4]
    pts[z >= 1.0] = np.nan
    return pts


def depth_quantum(camera: Camera, points: np.ndarray) -> np.ndarray:
    """Eye-space length of one step of a 24-bit depth buffer at world ``points`` (N, 3):
    ``Δz = 2⁻²⁴ · z² · (f − n) / (f · n)`` for eye depth z (perspective depth is 1/z-like;
    ``2⁻²⁴ · z² / n`` with an infinite far plane)."""
    pts = np.asarray(points, np.float64).reshape(-1, 3)
    z = -(np.c_[pts, np.ones(len(pts))] @ camera.view_matrix().T)[:, 2]
    n, f = camera.near, camera.far
    per_n = 1.0 / n if camera.infinite_far else (f - n) / (f * n)  # the limit f → ∞
    return 2.0 ** -_DEPTH_BITS * z * z * per_n


@dataclass(frozen=True)
class ShadowReference:
    """Per pixel of a frame (row 0 at the top): the surface point seen and its sun shadow."""

    points: np.ndarray  # float64 (h, w, 3), NaN where nothing was drawn
    object_shadow: np.ndarray  # bool (h, w): the ray to the sun hits an object
    terrain_shadow: np.ndarray  # bool (h, w): ... hits the terrain

    @property
    def surface(self) -> np.ndarray:
        """bool (h, w): a surface was drawn there."""
        return np.isfinite(self.points).all(axis=-1)

    @property
    def shadow(self) -> np.ndarray:
        return self.object_shadow | self.terrain_shadow


def shadow_reference(camera: Camera, depth: np.ndarray, sun, *,
                     instances: Instances | None = None, heightmap: Heightmap | None = None,
                     exaggeration: float = 1.0) -> ShadowReference:
    """The exact sun shadow per pixel of a frame drawn with ``camera``.

    Parameters
    ----------
    camera
        The frame's camera (with the aspect it was drawn with).
    depth
        Its window depth image (``OffscreenRenderer.last_depth()``), row 0 at the top.
    sun
        ``(azimuth, elevation)`` degrees or a direction toward the sun.
    instances
        The objects casting shadows; ``None`` for none.
    heightmap, exaggeration
        The terrain casting shadows (as drawn); ``None`` for none.
    """
    pts = surface_points(camera, depth)
    h, w = pts.shape[:2]
    flat = pts.reshape(-1, 3)
    quantum = np.nan_to_num(depth_quantum(camera, flat))
    start = _START_QUANTA * quantum + 1e-6
    tris = instances.world_triangles() if instances is not None else None
    obj, ter = sun_occlusion(flat, sun, triangles=tris, heightmap=heightmap,
                             exaggeration=exaggeration, start=start,
                             plane=_PLANE_QUANTA * quantum + 1e-6)
    valid = np.isfinite(flat).all(axis=1)
    return ShadowReference(pts, (obj & valid).reshape(h, w), (ter & valid).reshape(h, w))


def boundary_band(mask: np.ndarray, radius: int = 1) -> np.ndarray:
    """bool: pixels within ``radius`` pixels (chessboard distance) of a change of ``mask``
    — the shadow edges, where a rasterised shadow and the exact one may differ by a pixel."""
    from scipy.ndimage import binary_dilation, binary_erosion

    m = np.asarray(mask, dtype=bool)
    structure = np.ones((3, 3), bool)
    grown = binary_dilation(m, structure, iterations=radius)
    shrunk = binary_erosion(m, structure, iterations=radius, border_value=1)
    return grown & ~shrunk


def agreement(mask: np.ndarray, reference: np.ndarray, where: np.ndarray | None = None) -> float:
    """Share of the pixels in ``where`` (default all) on which two bool masks agree."""
    a, b = np.asarray(mask, bool), np.asarray(reference, bool)
    if a.shape != b.shape:
        raise InvalidParameterError(f"masks differ in shape: {a.shape} vs {b.shape}")
    sel = np.ones(a.shape, bool) if where is None else np.asarray(where, bool)
    n = int(sel.sum())
    if n == 0:
        raise InvalidParameterError("no pixels to compare")
    return float((a[sel] == b[sel]).sum()) / n


__all__ = [
    "ShadowReference",
    "TriangleGrid",
    "agreement",
    "boundary_band",
    "depth_quantum",
    "shadow_reference",
    "sun_occlusion",
    "surface_points",
]
