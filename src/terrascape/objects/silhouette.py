"""Stencil shadow volumes of objects: silhouette edges from the light's side, extruded to
infinity, with the caps z-fail counting needs (plain numpy/numba, no GL).

For each instance the faces that face the light (``plane · L > 0`` with the homogeneous light
``L``: ``(toward-sun direction, 0)`` for the sun, ``(position, 1)`` for a point light) form
the near cap. The volume's sides are the boundary of that set of faces — the silhouette:
edges between a lit and an unlit face, and the open edges of lit faces — each extruded away
from the light to a vertex at infinity, ``(v·L_w − L_xyz, 0)`` (w = 0). The far cap is the
near cap reversed at infinity. Built from the lit faces' boundary, the volume is closed (every
edge used twice, once in each direction) for any mesh, open or not; the count is exact for
closed (2-manifold) meshes, which :func:`mesh_edges` checks. For a directional light every
vertex at infinity is the same point ``(−L, 0)``: the far cap and one triangle of each side
quad have no area and are left out.

References
----------
Everitt, C. & Kilgard, M. J. (2002). Practical and robust stenciled shadow volumes for
hardware-accelerated rendering. NVIDIA technical report (arXiv:cs/0301002).

Crow, F. C. (1977). Shadow algorithms for computer graphics. *SIGGRAPH '77*, 242-248.

Lengyel, E. (2002). The mechanics of robust stencil shadows. *Gamasutra*, October 11, 2002.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numba
import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, prange
from terrascape.errors import InvalidParameterError
from terrascape.objects.model import Instances, ObjectMesh


class OpenMeshWarning(UserWarning):
    """A mesh is not closed: its shadow volume counts are exact only where its open edges
    do not face the light."""


@dataclass(frozen=True)
class MeshEdges:
    """Edge adjacency of one triangle mesh.

    Attributes
    ----------
    edges
        int32 ``(E, 2)``: the undirected edges, lower vertex index first.
    half_edge
        int32 ``(T, 3)``: the edge of triangle ``t``'s side ``k`` (from corner ``k`` to
        ``k + 1``).
    half_sign
        int8 ``(T, 3)``: +1 when that side runs from the edge's first vertex to its second.
    open_edges
        Edges with one triangle (a hole's border).
    non_manifold_edges
        Edges with more than two triangles, or two running the same way.
    """

    edges: np.ndarray
    half_edge: np.ndarray
    half_sign: np.ndarray
    open_edges: int
    non_manifold_edges: int

    @property
    def closed(self) -> bool:
        return self.open_edges == 0 and self.non_manifold_edges == 0


def mesh_edges(indices: np.ndarray) -> MeshEdges:
    """Edge adjacency of triangles ``indices`` (``(T, 3)`` integers) and a 2-manifold check."""
    tri = np.asarray(indices)
    if tri.ndim != 2 or tri.shape[1] != 3 or tri.dtype.kind not in "iu":
        raise InvalidParameterError(f"triangle indices must be (T, 3) integers, got {tri.shape}")
    tri = tri.astype(np.int64)
    a = tri.reshape(-1)
    b = np.roll(tri, -1, axis=1).reshape(-1)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = lo * (int(tri.max(initial=0)) + 1) + hi
    uniq, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    sign = np.where(a < b, 1, -1).astype(np.int8)
    # a manifold inner edge: two triangles running opposite ways (signed sum 0)
    signed = np.bincount(inverse, weights=sign, minlength=len(uniq))
    first = np.zeros(len(uniq), np.int64)
    first[inverse[::-1]] = np.arange(len(a))[::-1]
    edges = np.stack([lo[first], hi[first]], axis=1).astype(np.int32)
    return MeshEdges(
        edges=edges,
        half_edge=inverse.reshape(-1, 3).astype(np.int32),
        half_sign=sign.reshape(-1, 3),
        open_edges=int((counts == 1).sum()),
        non_manifold_edges=int(((counts > 2) | ((counts == 2) & (signed != 0))).sum()),
    )


def _light4(light) -> np.ndarray:
    arr = np.asarray(light, dtype=np.float64).reshape(-1)
    if arr.size == 3:
        arr = np.r_[arr, 0.0]
    if arr.size != 4 or not np.isfinite(arr).all():
        raise InvalidParameterError(
            f"light must be a direction toward the sun (3 numbers) or homogeneous "
            f"(x, y, z, w) with w 0 (direction) or 1 (point), got {light!r}")
    if arr[3] not in (0.0, 1.0):
        raise InvalidParameterError(f"light w must be 0 (direction) or 1 (point), got {arr[3]}")
    if arr[3] == 0.0:
        norm = float(np.linalg.norm(arr[:3]))
        if norm == 0.0:
            raise InvalidParameterError("a directional light needs a non-zero direction")
        arr[:3] /= norm
    return arr


@njit(cache=CACHE, fastmath=FASTMATH)
def _world_vertices(pos, mat, out):
    for v in range(pos.shape[0]):
        for r in range(3):
            out[v, r] = (mat[r, 0] * pos[v, 0] + mat[r, 1] * pos[v, 1]
                         + mat[r, 2] * pos[v, 2] + mat[r, 3])


@njit(cache=CACHE, fastmath=FASTMATH)
def _lit_faces(wp, tri, light, lit):
    """lit[t] = the plane of triangle t (world vertices wp) faces the homogeneous light;
    returns how many do."""
    n = 0
    for t in range(tri.shape[0]):
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        e1x, e1y, e1z = wp[b, 0] - wp[a, 0], wp[b, 1] - wp[a, 1], wp[b, 2] - wp[a, 2]
        e2x, e2y, e2z = wp[c, 0] - wp[a, 0], wp[c, 1] - wp[a, 1], wp[c, 2] - wp[a, 2]
        nx = e1y * e2z - e1z * e2y
        ny = e1z * e2x - e1x * e2z
        nz = e1x * e2y - e1y * e2x
        d = -(nx * wp[a, 0] + ny * wp[a, 1] + nz * wp[a, 2])
        lit[t] = nx * light[0] + ny * light[1] + nz * light[2] + d * light[3] > 0.0
        if lit[t]:
            n += 1
    return n


@njit(cache=CACHE, fastmath=FASTMATH)
def _boundary(tri, half_edge, half_sign, lit, count):
    """count[e] = signed multiplicity of edge e in the boundary of the lit faces; returns
    the number of side quads, the sum of |count|."""
    count[:] = 0
    for t in range(tri.shape[0]):
        if lit[t]:
            for k in range(3):
                count[half_edge[t, k]] += half_sign[t, k]
    n = 0
    for e in range(count.shape[0]):
        n += abs(count[e])
    return n


@njit(cache=CACHE, fastmath=FASTMATH)
def _silhouette(pos, tri, half_edge, half_sign, mat, light, wp, lit, count):
    """World vertices ``wp``, lit faces and boundary ``count`` of one instance; returns
    (lit faces, side quads)."""
    _world_vertices(pos, mat, wp)
    caps = _lit_faces(wp, tri, light, lit)
    return caps, _boundary(tri, half_edge, half_sign, lit, count)


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _volume_sizes(pos, tri, half_edge, half_sign, mats, light, chunks, lit, count, caps,
                  sides):
    """Instance i's lit faces lit[i] and silhouette count[i] (kept for the fill), and how
    many of each: caps[i], side quads sides[i]."""
    n = mats.shape[0]
    for c in prange(chunks):
        # scratch once per block of instances: an allocation per instance cost as much as
        # the silhouette itself
        wp = np.empty((pos.shape[0], 3))
        for i in range(c * n // chunks, (c + 1) * n // chunks):
            caps[i], sides[i] = _silhouette(pos, tri, half_edge, half_sign, mats[i], light,
                                            wp, lit[i], count[i])


@njit(cache=CACHE, fastmath=FASTMATH)
def _put(out, k, x, y, z, w):
    out[k, 0] = x
    out[k, 1] = y
    out[k, 2] = z
    out[k, 3] = w


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _volume_fill(pos, tri, edges, mats, light, lit, count, chunks, offsets, out):
    """Volume triangles to infinity of every instance (homogeneous world vertices, 3 rows
    each) from row 3·offsets[i]: near caps, far caps (point light), then the extruded
    silhouette."""
    n = mats.shape[0]
    point = light[3] != 0.0
    lx, ly, lz, lw = light[0], light[1], light[2], light[3]
    for c in prange(chunks):
        wp = np.empty((pos.shape[0], 3))
        for i in range(c * n // chunks, (c + 1) * n // chunks):
            _world_vertices(pos, mats[i], wp)
            k = 3 * offsets[i]
            for t in range(tri.shape[0]):
                if not lit[i, t]:
                    continue
                for j in range(3):
                    v = tri[t, j]
                    _put(out, k, wp[v, 0], wp[v, 1], wp[v, 2], 1.0)
                    k += 1
                if point:  # far cap: the same face at infinity, reversed
                    for j in range(2, -1, -1):
                        v = tri[t, j]
                        _put(out, k, wp[v, 0] * lw - lx, wp[v, 1] * lw - ly,
                             wp[v, 2] * lw - lz, 0.0)
                        k += 1
            for e in range(edges.shape[0]):
                m = count[i, e]
                if m == 0:
                    continue
                # the side runs p -> q as in the lit face's winding; its quad (q, p, p', q')
                p, q = (edges[e, 0], edges[e, 1]) if m > 0 else (edges[e, 1], edges[e, 0])
                for _ in range(abs(m)):
                    px, py, pz = wp[p, 0] * lw - lx, wp[p, 1] * lw - ly, wp[p, 2] * lw - lz
                    _put(out, k, wp[q, 0], wp[q, 1], wp[q, 2], 1.0)
                    _put(out, k + 1, wp[p, 0], wp[p, 1], wp[p, 2], 1.0)
                    _put(out, k + 2, px, py, pz, 0.0)
                    k += 3
                    if point:
                        _put(out, k, wp[q, 0], wp[q, 1], wp[q, 2], 1.0)
                        _put(out, k + 1, px, py, pz, 0.0)
                        _put(out, k + 2, wp[q, 0] * lw - lx, wp[q, 1] * lw - ly,
                             wp[q, 2] * lw - lz, 0.0)
                        k += 3


@njit(cache=CACHE, fastmath=FASTMATH)
def _corner(out, row, j, src, v):
    out[row, j, 0] = src[v, 0]
    out[row, j, 1] = src[v, 1]
    out[row, j, 2] = src[v, 2]
    out[row, j, 3] = 1.0


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _cut_fill(pos, tri, edges, mats, sun, floor, lit, count, chunks, cap_at, side_at,
              far_base, upper_base, lower_base, out):
    """Volumes of a sun cut at height ``floor`` into ``out`` (K, 3, 4) float32, every
    w = 1. Instance i's near caps from row cap_at[i], their far caps from far_base +
    cap_at[i], its side quads' upper triangles (q, p, p↓) from upper_base + side_at[i] and
    lower ones (q, p↓, q↓) from lower_base + side_at[i]; ↓ slides a corner along −sun onto
    y = floor (corners below it stay). The corners are rounded to float32 before they slide,
    as the volume to infinity stores them."""
    n = mats.shape[0]
    nv = pos.shape[0]
    sx, sy, sz = sun[0], sun[1], sun[2]
    f32 = np.float32(floor)
    for c in prange(chunks):
        wp = np.empty((nv, 3))
        top = np.empty((nv, 3), np.float32)
        low = np.empty((nv, 3), np.float32)
        for i in range(c * n // chunks, (c + 1) * n // chunks):
            _world_vertices(pos, mats[i], wp)
            for v in range(nv):
                x, y, z = np.float32(wp[v, 0]), np.float32(wp[v, 1]), np.float32(wp[v, 2])
                top[v, 0], top[v, 1], top[v, 2] = x, y, z
                t = max(np.float64(y) - floor, 0.0) / sy
                low[v, 0] = x - np.float32(t * sx)
                low[v, 1] = f32 if y > f32 else y
                low[v, 2] = z - np.float32(t * sz)
            k = cap_at[i]
            for t in range(tri.shape[0]):
                if not lit[i, t]:
                    continue
                for j in range(3):  # the far cap: the face slid down, reversed
                    _corner(out, k, j, top, tri[t, j])
                    _corner(out, far_base + k, 2 - j, low, tri[t, j])
                k += 1
            s = side_at[i]
            for e in range(edges.shape[0]):
                m = count[i, e]
                if m == 0:
                    continue
                p, q = (edges[e, 0], edges[e, 1]) if m > 0 else (edges[e, 1], edges[e, 0])
                for _ in range(abs(m)):
                    _corner(out, upper_base + s, 0, top, q)
                    _corner(out, upper_base + s, 1, top, p)
                    _corner(out, upper_base + s, 2, low, p)
                    _corner(out, lower_base + s, 0, top, q)
                    _corner(out, lower_base + s, 1, low, p)
                    _corner(out, lower_base + s, 2, low, q)
                    s += 1


_WARNED: set[str] = set()


@dataclass(frozen=True)
class _Prepared:
    mesh: ObjectMesh
    positions: np.ndarray  # float64 (U, 3): the mesh's distinct vertex positions
    triangles: np.ndarray  # int32 (T, 3) into positions, triangles with 3 distinct corners
    edges: MeshEdges


def welded(mesh: ObjectMesh) -> tuple[np.ndarray, np.ndarray]:
    """The mesh with vertices at the same position merged: ``(positions (U, 3) float64,
    triangles (T, 3) int32)``, triangles that collapse left out. Flat-shaded meshes repeat
    each corner once per face (one normal each); their edges meet only by position."""
    pos, inverse = np.unique(mesh.positions, axis=0, return_inverse=True)
    tri = inverse.reshape(-1)[mesh.indices.astype(np.int64)].astype(np.int32)
    keep = (tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 2] != tri[:, 0])
    return pos.astype(np.float64), np.ascontiguousarray(tri[keep])


_PREPARED: dict[int, _Prepared] = {}


def _prepared(mesh: ObjectMesh) -> _Prepared:
    have = _PREPARED.get(id(mesh))
    if have is not None and have.mesh is mesh:
        return have
    pos, tri = welded(mesh)
    edges = mesh_edges(tri)
    if not edges.closed and mesh.name not in _WARNED:
        _WARNED.add(mesh.name)
        warnings.warn(
            f"object mesh {mesh.name!r} is not closed ({edges.open_edges} open and "
            f"{edges.non_manifold_edges} non-manifold edges): its shadow is exact only where "
            f"the open edges face the light", OpenMeshWarning, stacklevel=3)
    prep = _Prepared(mesh, pos, tri, edges)
    _PREPARED[id(mesh)] = prep
    return prep


def _chunks(n: int) -> int:
    """How many blocks the kernels split ``n`` instances into (each block's scratch is
    allocated once; a few blocks per thread balance the threads)."""
    return max(1, min(n, 8 * numba.get_num_threads()))


def _matrices(matrices) -> np.ndarray:
    mats = np.ascontiguousarray(matrices, dtype=np.float64)
    if mats.ndim != 3 or mats.shape[1:] != (4, 4) or not np.isfinite(mats).all():
        raise InvalidParameterError(f"matrices must be finite (N, 4, 4), got {mats.shape}")
    return mats


def _silhouettes(prep: _Prepared, mats: np.ndarray, lt: np.ndarray) -> tuple:
    """``(prep, mats, lit (N, T), count (N, E), caps (N,), sides (N,))``: the lit faces and
    the silhouette of each copy ``mats`` of the prepared mesh, and how many of each."""
    n, e = len(mats), prep.edges
    lit = np.empty((n, len(prep.triangles)), np.bool_)
    # a multiplicity is at most the number of triangles on one edge
    count = np.empty((n, len(e.edges)), np.int16)
    caps = np.empty(n, np.int64)
    sides = np.empty(n, np.int64)
    _volume_sizes(prep.positions, prep.triangles, e.half_edge, e.half_sign, mats, lt,
                  _chunks(n), lit, count, caps, sides)
    return prep, mats, lit, count, caps, sides


def _starts(counts: np.ndarray, base: int = 0) -> np.ndarray:
    """Exclusive running sum of ``counts`` from ``base``: where each instance's rows start."""
    at = np.empty(len(counts), np.int64)
    if len(counts):
        at[0] = base
        np.cumsum(counts[:-1], out=at[1:])
        at[1:] += base
    return at


def _rows(out: np.ndarray | None, rows: int) -> np.ndarray:
    """``rows`` volume triangles to write: the leading rows of ``out`` when it has room, else
    of a new array with a quarter more (so that a caller who keeps ``result.base`` for the
    next rebuild, whose size changes a little with the sun, rarely allocates again)."""
    if out is not None:
        if (not isinstance(out, np.ndarray) or out.dtype != np.float32 or out.ndim != 3
                or out.shape[1:] != (3, 4) or not out.flags.c_contiguous):
            raise InvalidParameterError(
                "out must be a C-contiguous float32 (K, 3, 4) array, got "
                f"{getattr(out, 'dtype', type(out).__name__)} {getattr(out, 'shape', '')}")
        if len(out) >= rows:
            return out[:rows]
        return np.empty((rows + rows // 4, 3, 4), np.float32)[:rows]
    return np.empty((rows, 3, 4), np.float32)


def _fill(parts: list, lt: np.ndarray, floor: float | None,
          out: np.ndarray | None) -> np.ndarray:
    """The volume triangles of ``parts`` (:func:`_silhouettes`), mesh after mesh."""
    if floor is None:
        per = [(caps + sides) * (2 if lt[3] != 0.0 else 1) for *_, caps, sides in parts]
        res = _rows(out, sum(int(p.sum()) for p in per))
        flat = res.reshape(-1, 4)
        base = 0
        for (prep, mats, lit, count, _, _), rows in zip(parts, per, strict=True):
            _volume_fill(prep.positions, prep.triangles, prep.edges.edges, mats, lt, lit,
                         count, _chunks(len(mats)), _starts(rows, base), flat)
            base += int(rows.sum())
        return res
    # all near caps, all far caps, all upper side triangles, all lower ones
    n_cap = sum(int(caps.sum()) for *_, caps, _ in parts)
    n_side = sum(int(sides.sum()) for *_, sides in parts)
    res = _rows(out, 2 * n_cap + 2 * n_side)
    cap_base = side_base = 0
    for prep, mats, lit, count, caps, sides in parts:
        _cut_fill(prep.positions, prep.triangles, prep.edges.edges, mats, lt, floor, lit,
                  count, _chunks(len(mats)), _starts(caps, cap_base),
                  _starts(sides, side_base), n_cap, 2 * n_cap, 2 * n_cap + n_side, res)
        cap_base += int(caps.sum())
        side_base += int(sides.sum())
    return res


def mesh_volume(mesh: ObjectMesh, matrices: np.ndarray, light) -> np.ndarray:
    """Shadow volume triangles of copies of one mesh, extruded to infinity.

    Parameters
    ----------
    mesh
        The mesh (closed for exact counts; an open one warns once).
    matrices
        ``(N, 4, 4)`` model matrices (column vectors), as :meth:`Instances.matrices`.
    light
        Toward-sun direction (3 numbers, or ``(x, y, z, 0)``) or a point light ``(x, y, z, 1)``.

    Returns
    -------
    numpy.ndarray
        float32 ``(M, 3, 4)``: M triangles of homogeneous world vertices, counter-clockwise
        seen from outside the volume (w = 0: a point at infinity), instance after instance:
        its near caps (and far caps, for a point light), then its sides.
    """
    if not isinstance(mesh, ObjectMesh):
        raise InvalidParameterError(f"expected an ObjectMesh, got {type(mesh).__name__}")
    mats = _matrices(matrices)
    lt = _light4(light)
    return _fill([_silhouettes(_prepared(mesh), mats, lt)], lt, None, None)


def bounding_spheres(instances: Instances) -> tuple[np.ndarray, np.ndarray]:
    """World bounding spheres of every instance: ``(centres (N, 3), radii (N,))`` float64.
    Each mesh's sphere is centred on its vertical axis (halfway up), so yaw cannot move it."""
    if not isinstance(instances, Instances):
        raise InvalidParameterError(f"expected Instances, got {type(instances).__name__}")
    n = len(instances)
    mid = np.zeros(n)
    radius = np.zeros(n)
    for k, mesh in enumerate(instances.meshes):
        sel = instances.of_kind(k)
        if not len(sel):
            continue
        p = mesh.positions.astype(np.float64)
        m = 0.5 * (float(p[:, 1].min()) + float(p[:, 1].max()))
        mid[sel] = m
        radius[sel] = float(np.sqrt(p[:, 0] ** 2 + (p[:, 1] - m) ** 2 + p[:, 2] ** 2).max())
    scale = instances.scale.astype(np.float64)
    centres = instances.positions.astype(np.float64).copy()
    centres[:, 1] += mid * scale
    return centres, radius * scale


def casters_in_view(instances: Instances, planes: np.ndarray, light, floor: float
                    ) -> np.ndarray:
    """bool ``(N,)``: the instances whose shadow volume can reach what the frustum shows.

    Shadow caster culling (Everitt & Kilgard 2002, §5; Lengyel 2002): a caster off screen
    can still shadow visible ground, so each caster is kept when its bounding sphere swept
    away from the sun, down to the lowest surface that can be drawn (``floor``), is not
    entirely outside one of the frustum ``planes``. Below the floor no surface is drawn, so
    a volume that misses the frustum above it contains no visible point and counts 0 on
    every pixel: dropping it leaves the stencil exactly as it was.

    Parameters
    ----------
    planes
        ``(6, 4)`` inward planes ``(a, b, c, d)`` (:meth:`terrascape.camera.Camera.frustum_planes`).
    light
        Direction toward the sun (3 numbers, or ``(x, y, z, 0)``) — point lights, whose
        volumes widen, are not culled (all kept).
    floor
        The lowest height any drawn surface has (world units).
    """
    centres, radii = bounding_spheres(instances)
    pl = np.asarray(planes, np.float64)
    if pl.ndim != 2 or pl.shape[1] != 4 or not np.isfinite(pl).all():
        raise InvalidParameterError(f"planes must be finite (P, 4), got {pl.shape}")
    lt = _light4(light)
    if lt[3] != 0.0:
        return np.ones(len(instances), bool)
    d = lt[:3]
    if d[1] <= 0.0:  # a sun at or below the horizon casts no volumes above any floor
        return np.zeros(len(instances), bool)
    # the swept sphere is the capsule from c to c − T·d: every point of the caster reaches
    # the floor along −d within T = (top − floor) / d_y
    reach = np.maximum(centres[:, 1] + radii - float(floor), 0.0) / d[1]
    ends = centres - reach[:, None] * d
    norm = np.linalg.norm(pl[:, :3], axis=1)
    near = (centres @ pl[:, :3].T + pl[:, 3]) / norm
    far = (ends @ pl[:, :3].T + pl[:, 3]) / norm
    outside = (near < -radii[:, None]) & (far < -radii[:, None])
    return ~outside.any(axis=1)


def shadow_volume(instances: Instances, light, keep: np.ndarray | None = None,
                  floor: float | None = None, out: np.ndarray | None = None) -> np.ndarray:
    """Shadow volume triangles of every instance, or of those ``keep`` marks (a bool
    ``(N,)`` mask such as :func:`casters_in_view`), mesh after mesh.

    Without ``floor`` the silhouettes are extruded to infinity (:func:`mesh_volume`). With
    it (a sun above the horizon) they are extruded only down to the plane ``y = floor``, and
    the near caps, slid along the sun's direction onto that plane and reversed, close them
    there. Below the lowest drawn surface a volume contains nothing visible, so the count is
    the same on every pixel; what changes is the fill: each volume covers the screen only
    down to the ground instead of to the vanishing point of the sun's direction, and no
    vertex is at infinity. (The same closed-volume argument as Everitt & Kilgard's §3;
    Lengyel 2002 bounds volumes by the light's range the same way.)

    Parameters
    ----------
    light
        Toward-sun direction (3 numbers, or ``(x, y, z, 0)``) or a point light
        ``(x, y, z, 1)`` (volumes to infinity only).
    floor
        Height of the cut, below every surface that can be shadowed; None: to infinity.
    out
        A C-contiguous float32 ``(K, 3, 4)`` array to write into when it has room: the
        result is then its leading rows. A rebuild every frame (a moving sun) that passes
        the previous result's ``base`` back spares the allocation and first touch of
        tens of megabytes.

    Returns
    -------
    numpy.ndarray
        float32 ``(M, 3, 4)`` homogeneous world vertices, counter-clockwise seen from
        outside. To infinity: see :func:`mesh_volume`. Cut at ``floor`` (every w = 1): all
        near caps, then all far caps (in the same order), then the upper triangle
        ``(q, p, p↓)`` of every side quad, then the lower ones ``(q, p↓, q↓)``, where ``↓``
        slides a corner along the sun's direction down onto the floor (a corner already
        below it stays).
    """
    if not isinstance(instances, Instances):
        raise InvalidParameterError(f"expected Instances, got {type(instances).__name__}")
    lt = _light4(light)
    if floor is not None:
        floor = float(floor)
        if not math.isfinite(floor):
            raise InvalidParameterError(f"floor must be a finite height, got {floor}")
        if lt[3] != 0.0 or lt[1] <= 0.0:
            raise InvalidParameterError(
                f"volumes cut at a floor need a sun above the horizon (a direction with "
                f"y > 0), got {light!r}")
    mats = instances.matrices()
    if keep is None:
        keep = np.ones(len(instances), bool)
    keep = np.asarray(keep, bool)
    if keep.shape != (len(instances),):
        raise InvalidParameterError(
            f"keep must be a bool mask of the {len(instances)} instances, got {keep.shape}")
    parts = [_silhouettes(_prepared(mesh), np.ascontiguousarray(mats[sel], np.float64), lt)
             for k, mesh in enumerate(instances.meshes)
             if len(sel := np.flatnonzero((instances.kind == k) & keep))]
    return _fill(parts, lt, floor, out)


__all__ = [
    "MeshEdges",
    "OpenMeshWarning",
    "bounding_spheres",
    "casters_in_view",
    "mesh_edges",
    "mesh_volume",
    "shadow_volume",
    "welded",
]
