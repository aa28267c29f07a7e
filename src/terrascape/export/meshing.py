"""Terrain meshes for export: RTIN on a DEM of any rectangular size, UVs, normals, skirts.

:func:`rtin_rectangle` pads a ``rows × cols`` map to the next ``2**n + 1`` square and runs the
static RTIN mesher of :mod:`terrascape.lod.rtin` on it. The padding is a cliff far below the
data (deeper than any error the mesh may keep), so every bintree triangle that reaches into
the padding has an error larger than the tolerance and is split, down to triangles that lie
wholly inside or wholly outside the data; dropping the outside ones leaves a mesh that covers
exactly the data rectangle ``[0, cols−1] × [0, rows−1]`` with RTIN's true error bound on every
data sample (a triangle of the kept set only covers data samples). The price is a fringe of
small triangles along the right and bottom edges of non-square maps.

:class:`TerrainMesh` holds what glTF and engine exporters need: world positions (Y up,
``x = col·dx``, ``z = row·dz``), unit vertex normals from the heightmap's gradient (smooth
shading that matches the full-resolution surface, not the coarse triangles), texture
coordinates on the sample grid's texel centres, and optional skirts (a strip hanging down from
every border edge, which hides cracks between neighbouring tiles of different detail).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit
from terrascape._validate import check_positive
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.lod.rtin import Rtin, rtin_mesh

__all__ = ["TerrainMesh", "border_edges", "rtin_rectangle", "terrain_mesh", "uint16_parts"]


def _next_pow2_plus1(n: int) -> int:
    side = 3
    while side < n:
        side = (side - 1) * 2 + 1
    return side


def rtin_rectangle(
    heightmap: Heightmap,
    *,
    max_error: float | None = None,
    max_triangles: int | None = None,
) -> np.ndarray:
    """RTIN triangles (grid indices ``row·cols + col`` of ``heightmap``) for any size.

    A ``2**n + 1`` square map goes straight to :func:`terrascape.lod.rtin.rtin_mesh`; any
    other size is padded internally (see the module docstring). With ``max_triangles`` the
    budget counts the padding's triangles too, so a padded map gets fewer data triangles.

    Returns
    -------
    numpy.ndarray
        ``uint32 (M, 3)``, counter-clockwise from above, covering the whole map.
    """
    if not isinstance(heightmap, Heightmap):
        raise InvalidParameterError(f"expected a Heightmap, got {type(heightmap).__name__}")
    if max_error is None and max_triangles is None:
        raise InvalidParameterError("give max_error (world units) and/or max_triangles")
    if heightmap.is_pow2_plus1:
        return rtin_mesh(heightmap, max_error=max_error, max_triangles=max_triangles)
    rows, cols = heightmap.shape
    side = _next_pow2_plus1(max(rows, cols))
    tol = 0.0 if max_error is None else check_positive(max_error, "max_error", allow_zero=True)
    relief = heightmap.max - heightmap.min
    # Deep enough that a triangle reaching the cliff misses it by more than the tolerance
    # on at least one data sample (the plane moves by ≥ depth / side per sample there).
    depth = 4.0 * side * (relief + tol + 1.0)
    padded = np.full((side, side), heightmap.min - depth, np.float32)
    padded[:rows, :cols] = heightmap.heights
    big = Heightmap(padded, heightmap.spacing)
    if max_triangles is None:
        tri = rtin_mesh(big, max_error=tol).astype(np.int64)
    else:
        tri = Rtin(big).mesh(max_error=max_error, max_triangles=max_triangles).triangles
        tri = tri.astype(np.int64)
    r, c = tri // side, tri % side
    inside = ((r < rows) & (c < cols)).all(axis=1)
    kept = r[inside] * cols + c[inside]
    return kept.astype(np.uint32)


def border_edges(faces: np.ndarray) -> np.ndarray:
    """Edges ``(E, 2)`` used by exactly one face, oriented as in that face."""
    f = np.asarray(faces, np.int64)
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    key = np.sort(edges, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return edges[counts[inverse.ravel()] == 1]


def uint16_parts(faces: np.ndarray, max_vertices: int = 65535
                 ) -> list[tuple[np.ndarray, np.ndarray]]:
    """Cut a triangle list into consecutive runs that each use fewer than ``max_vertices``
    vertices (65 535: the largest ``UNSIGNED_SHORT`` index, 65 535, is glTF's and OpenGL ES's
    primitive-restart value, so a 16-bit index must stay below it).

    Each run is the longest run of the remaining triangles that fits (one greedy pass), so
    the parts follow the mesh's own triangle order; RTIN's bintree order keeps each part a
    compact patch of the terrain and the repeated vertices on the cuts few.

    Returns
    -------
    list of (vertex_ids, local_faces)
        ``vertex_ids`` int64 (sorted) into the mesh's vertices; ``local_faces`` uint32
        ``(m, 3)`` indices into ``vertex_ids`` with the original winding. Concatenating the
        parts' ``vertex_ids[local_faces]`` gives back ``faces`` exactly.
    """
    f = np.asarray(faces)
    if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
        raise InvalidParameterError(f"faces must have shape (M>0, 3), got {f.shape}")
    if max_vertices < 3:
        raise InvalidParameterError(f"max_vertices must be at least 3, got {max_vertices}")
    limit = max_vertices - 1  # vertices per part, so that every local index < max_vertices
    f = np.ascontiguousarray(f, dtype=np.int64)
    if f.min() < 0:
        raise InvalidParameterError("face indices must not be negative")
    stops = _part_stops(f, int(f.max()) + 1, limit)
    parts = []
    start = 0
    for stop in stops:
        ids, local = np.unique(f[start:stop], return_inverse=True)
        parts.append((ids.astype(np.int64), local.reshape(-1, 3).astype(np.uint32)))
        start = int(stop)
    return parts


@njit(cache=CACHE, fastmath=FASTMATH)
def _part_stops(faces, n_vertices, limit):
    # Greedy: a triangle joins the current part unless its new vertices would pass the limit.
    stamp = np.full(n_vertices, -1, np.int64)
    stops = np.empty(len(faces) + 1, np.int64)
    part = 0
    used = 0
    for t in range(len(faces)):
        a, b, c = faces[t, 0], faces[t, 1], faces[t, 2]
        fresh = (stamp[a] != part) + (stamp[b] != part and b != a) + (
            stamp[c] != part and c != a and c != b)
        if used + fresh > limit:
            stops[part] = t
            part += 1
            used = 0
            fresh = 1 + (b != a) + (c != a and c != b)
        stamp[a] = part
        stamp[b] = part
        stamp[c] = part
        used += fresh
    stops[part] = len(faces)
    return stops[:part + 1]


@dataclass(frozen=True)
class TerrainMesh:
    """An export mesh in world units, Y up.

    Attributes
    ----------
    positions
        float64 ``(N, 3)`` ``(col·dx, h, row·dz)``.
    normals
        float32 ``(N, 3)`` unit normals (Y up).
    uvs
        float32 ``(N, 2)``: ``u = (col + ½)/cols``, ``v = (row + ½)/rows`` — the centre of the
        matching texel of a ``rows × cols`` texture (glTF's ``v`` runs down the image).
    faces
        uint32 ``(M, 3)``, counter-clockwise from above (glTF front faces).
    grid_index
        int64 ``(N,)``: the heightmap sample each vertex comes from.
    skirt_vertices
        How many of the last vertices are skirt vertices (0 without skirts).
    """

    positions: np.ndarray
    normals: np.ndarray
    uvs: np.ndarray
    faces: np.ndarray
    grid_index: np.ndarray
    skirt_vertices: int = 0

    def grid_triangles(self) -> np.ndarray:
        """The terrain's faces (the skirt's left out) as ``uint32 (M, 3)`` grid indices
        ``row·cols + col`` of the heightmap, e.g. to measure the mesh's error."""
        faces = np.asarray(self.faces, np.int64)
        if self.skirt_vertices:
            surface = len(self.grid_index) - self.skirt_vertices
            faces = faces[(faces < surface).all(axis=1)]
        return self.grid_index[faces].astype(np.uint32)


def terrain_mesh(
    heightmap: Heightmap,
    triangles: np.ndarray,
    *,
    skirt: float = 0.0,
) -> TerrainMesh:
    """Compact ``triangles`` (grid indices) into a :class:`TerrainMesh`.

    Parameters
    ----------
    skirt
        Depth in world units of a skirt hung from every border edge (0: none).
    """
    if not isinstance(heightmap, Heightmap):
        raise InvalidParameterError(f"expected a Heightmap, got {type(heightmap).__name__}")
    skirt = check_positive(skirt, "skirt depth", allow_zero=True)
    tri = np.asarray(triangles)
    if tri.ndim != 2 or tri.shape[1] != 3 or tri.shape[0] == 0:
        raise InvalidParameterError(f"triangles must have shape (M>0, 3), got {tri.shape}")
    rows, cols = heightmap.shape
    tri = tri.astype(np.int64)
    if tri.min() < 0 or tri.max() >= rows * cols:
        raise InvalidParameterError("triangle indices outside the heightmap grid")
    used, inverse = np.unique(tri.reshape(-1), return_inverse=True)
    faces = inverse.reshape(-1, 3).astype(np.int64)
    r, c = used // cols, used % cols
    dx, dz = heightmap.spacing
    pos = np.empty((used.size, 3), np.float64)
    pos[:, 0] = c * dx
    pos[:, 1] = heightmap.heights.reshape(-1)[used]
    pos[:, 2] = r * dz
    normals = heightmap.normals().reshape(-1, 3)[used]
    uvs = np.empty((used.size, 2), np.float32)
    uvs[:, 0] = (c + 0.5) / cols
    uvs[:, 1] = (r + 0.5) / rows
    grid = used.astype(np.int64)
    n_skirt = 0
    if skirt > 0:
        edges = border_edges(faces)
        ring = np.unique(edges)
        low = np.full(len(pos), -1, np.int64)
        low[ring] = len(pos) + np.arange(ring.size)
        drop = pos[ring].copy()
        drop[:, 1] -= skirt
        pos = np.concatenate([pos, drop])
        normals = np.concatenate([normals, normals[ring]])
        uvs = np.concatenate([uvs, uvs[ring]])
        grid = np.concatenate([grid, grid[ring]])
        a, b = edges[:, 0], edges[:, 1]
        # The face runs a→b on its border, so the outward side keeps that order reversed
        # when walking down: (b, a, a_low) and (b, a_low, b_low) face outwards.
        wall = np.concatenate([np.stack([b, a, low[a]], 1), np.stack([b, low[a], low[b]], 1)])
        faces = np.concatenate([faces, wall])
        n_skirt = ring.size
    return TerrainMesh(pos, normals.astype(np.float32), uvs, faces.astype(np.uint32), grid,
                       n_skirt)
