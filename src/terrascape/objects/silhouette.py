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

import warnings
from dataclasses import dataclass

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
    """lit[t] = the plane of triangle t (world vertices wp) faces the homogeneous light."""
    for t in range(tri.shape[0]):
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        e1x, e1y, e1z = wp[b, 0] - wp[a, 0], wp[b, 1] - wp[a, 1], wp[b, 2] - wp[a, 2]
        e2x, e2y, e2z = wp[c, 0] - wp[a, 0], wp[c, 1] - wp[a, 1], wp[c, 2] - wp[a, 2]
        nx = e1y * e2z - e1z * e2y
        ny = e1z * e2x - e1x * e2z
        nz = e1x * e2y - e1y * e2x
        d = -(nx * wp[a, 0] + ny * wp[a, 1] + nz * wp[a, 2])
        lit[t] = nx * light[0] + ny * light[1] + nz * light[2] + d * light[3] > 0.0


@njit(cache=CACHE, fastmath=FASTMATH)
def _boundary(tri, half_edge, half_sign, lit, count):
    """count[e] = signed multiplicity of edge e in the boundary of the lit faces."""
    count[:] = 0
    for t in range(tri.shape[0]):
        if lit[t]:
            for k in range(3):
                count[half_edge[t, k]] += half_sign[t, k]


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _volume_counts(pos, tri, half_edge, half_sign, n_edges, mats, light, counts):
    point = light[3] != 0.0
    for i in prange(mats.shape[0]):
        wp = np.empty((pos.shape[0], 3))
        lit = np.empty(tri.shape[0], np.bool_)
        count = np.empty(n_edges, np.int32)
        _world_vertices(pos, mats[i], wp)
        _lit_faces(wp, tri, light, lit)
        _boundary(tri, half_edge, half_sign, lit, count)
        caps = lit.sum()
        sides = np.abs(count).sum()
        counts[i] = caps * 2 + sides * 2 if point else caps + sides


@njit(cache=CACHE, fastmath=FASTMATH)
def _put(out, k, x, y, z, w):
    out[k, 0] = x
    out[k, 1] = y
    out[k, 2] = z
    out[k, 3] = w


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _volume_fill(pos, tri, half_edge, half_sign, edges, mats, light, offsets, out):
    """Volume triangles of every instance (homogeneous world vertices, 3 rows each) from
    row 3·offsets[i]: near caps, far caps (point light), then the extruded silhouette."""
    point = light[3] != 0.0
    lx, ly, lz, lw = light[0], light[1], light[2], light[3]
    for i in prange(mats.shape[0]):
        wp = np.empty((pos.shape[0], 3))
        lit = np.empty(tri.shape[0], np.bool_)
        count = np.empty(edges.shape[0], np.int32)
        _world_vertices(pos, mats[i], wp)
        _lit_faces(wp, tri, light, lit)
        _boundary(tri, half_edge, half_sign, lit, count)
        k = 3 * offsets[i]
        for t in range(tri.shape[0]):
            if not lit[t]:
                continue
            for c in range(3):
                v = tri[t, c]
                _put(out, k, wp[v, 0], wp[v, 1], wp[v, 2], 1.0)
                k += 1
            if point:  # far cap: the same face at infinity, reversed
                for c in range(2, -1, -1):
                    v = tri[t, c]
                    _put(out, k, wp[v, 0] * lw - lx, wp[v, 1] * lw - ly, wp[v, 2] * lw - lz, 0.0)
                    k += 1
        for e in range(edges.shape[0]):
            m = count[e]
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


def mesh_volume(mesh: ObjectMesh, matrices: np.ndarray, light) -> np.ndarray:
    """Shadow volume triangles of copies of one mesh.

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
        seen from outside the volume (w = 0: a point at infinity).
    """
    if not isinstance(mesh, ObjectMesh):
        raise InvalidParameterError(f"expected an ObjectMesh, got {type(mesh).__name__}")
    mats = np.ascontiguousarray(matrices, dtype=np.float64)
    if mats.ndim != 3 or mats.shape[1:] != (4, 4) or not np.isfinite(mats).all():
        raise InvalidParameterError(f"matrices must be finite (N, 4, 4), got {mats.shape}")
    lt = _light4(light)
    prep = _prepared(mesh)
    pos, tri, edges = prep.positions, prep.triangles, prep.edges
    counts = np.zeros(len(mats), np.int64)
    _volume_counts(pos, tri, edges.half_edge, edges.half_sign, len(edges.edges), mats, lt,
                   counts)
    offsets = np.zeros(len(mats), np.int64)
    np.cumsum(counts[:-1], out=offsets[1:])
    out = np.empty((int(counts.sum()) * 3, 4), np.float32)
    _volume_fill(pos, tri, edges.half_edge, edges.half_sign, edges.edges, mats, lt, offsets,
                 out)
    return out.reshape(-1, 3, 4)


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


def bounded_volume(triangles: np.ndarray, light, floor: float) -> np.ndarray:
    """The volume triangles of :func:`mesh_volume` for a sun (directional light) cut off at
    height ``floor``: the silhouette is extruded down to the plane ``y = floor`` instead of
    to infinity, and the near caps, projected onto that plane and reversed, close it there.

    Below the lowest drawn surface a volume contains nothing visible, so the count is the
    same on every pixel; what changes is the fill: each volume covers the screen only down
    to the ground instead of to the vanishing point of the sun's direction, and no vertex is
    at infinity. (The same closed-volume argument as Everitt & Kilgard's §3; Lengyel 2002
    bounds volumes by the light's range the same way.)

    Parameters
    ----------
    triangles
        float32 ``(M, 3, 4)`` from :func:`mesh_volume` / :func:`shadow_volume` for the
        directional ``light``: near caps (three w = 1 corners) and sides ``(q, p, −L∞)``.
    light
        The direction toward the sun they were built for (above the horizon).
    floor
        Height of the cut, below every surface that can be shadowed.

    Returns
    -------
    numpy.ndarray
        float32 ``(M', 3, 4)``, every w = 1: near caps, far caps, two triangles per side.
    """
    tri = np.asarray(triangles, dtype=np.float32)
    if tri.ndim != 3 or tri.shape[1:] != (3, 4):
        raise InvalidParameterError(f"volume triangles must be (M, 3, 4), got {tri.shape}")
    lt = _light4(light)
    if lt[3] != 0.0 or lt[1] <= 0.0:
        raise InvalidParameterError(
            f"bounded volumes need a sun above the horizon (a direction with y > 0), got "
            f"{light!r}")
    d = lt[:3]
    floor = float(floor)

    def down(v):  # (K, 4) corners slid along −d onto the plane y = floor
        t = np.maximum(v[:, 1].astype(np.float64) - floor, 0.0) / d[1]
        out = np.empty_like(v)
        out[:, :3] = v[:, :3] - (t[:, None] * d).astype(np.float32)
        out[:, 1] = np.where(v[:, 1] > floor, np.float32(floor), v[:, 1])
        out[:, 3] = 1.0
        return out

    side = tri[:, 2, 3] == 0.0
    caps, sides = tri[~side], tri[side]
    n_cap, n_side = len(caps), len(sides)
    out = np.empty((2 * n_cap + 2 * n_side, 3, 4), np.float32)
    out[:n_cap] = caps
    far = down(caps.reshape(-1, 4)).reshape(-1, 3, 4)
    out[n_cap:2 * n_cap] = far[:, ::-1]
    q, p = sides[:, 0], sides[:, 1]
    p2, q2 = down(p), down(q)
    k = 2 * n_cap
    out[k:k + n_side] = np.stack([q, p, p2], axis=1)
    out[k + n_side:] = np.stack([q, p2, q2], axis=1)
    return out


def shadow_volume(instances: Instances, light, keep: np.ndarray | None = None) -> np.ndarray:
    """Shadow volume triangles of every instance (or of those ``keep`` marks, a bool
    ``(N,)`` mask such as :func:`casters_in_view`): float32 ``(M, 3, 4)`` homogeneous world
    vertices (see :func:`mesh_volume`), mesh after mesh."""
    if not isinstance(instances, Instances):
        raise InvalidParameterError(f"expected Instances, got {type(instances).__name__}")
    mats = instances.matrices()
    if keep is None:
        keep = np.ones(len(instances), bool)
    keep = np.asarray(keep, bool)
    if keep.shape != (len(instances),):
        raise InvalidParameterError(
            f"keep must be a bool mask of the {len(instances)} instances, got {keep.shape}")
    groups = [(mesh, np.flatnonzero((instances.kind == k) & keep))
              for k, mesh in enumerate(instances.meshes)]
    parts = [mesh_volume(mesh, mats[sel], light) for mesh, sel in groups if len(sel)]
    if not parts:
        return np.zeros((0, 3, 4), np.float32)
    return np.concatenate(parts)


__all__ = [
    "MeshEdges",
    "OpenMeshWarning",
    "bounded_volume",
    "bounding_spheres",
    "casters_in_view",
    "mesh_edges",
    "mesh_volume",
    "shadow_volume",
    "welded",
]
