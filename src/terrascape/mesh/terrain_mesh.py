"""Regular-grid terrain mesh with per-vertex tangent space, planar uvs and chunked indices.

The mesh mirrors the original program (a terrain mesh with tangents and
planar texture mapping with a scale factor — Irrlicht's ``makePlanarTextureMapping(mesh,
scale)``), in terrascape's conventions:

* vertex ``k = row·cols + col`` sits at ``x = col·dx``, ``y = h[row, col]·exaggeration``,
  ``z = row·dz`` (Y up, rows grow toward +Z = south);
* planar mapping ``u = x / extent_x · uv_scale``, ``v = z / extent_z · uv_scale``: with
  ``uv_scale = 1`` one texture covers the terrain once (texel row 0 at the north edge, the
  same orientation as the height array), larger values tile it;
* two triangles per cell, ``(i00, i10, i01)`` and ``(i01, i10, i11)``, counter-clockwise seen
  from above (+Y) — GL's default front face — so back-face culling keeps the top side;
* chunks of ``2**k + 1`` vertices per side share their border vertices (geomipmapping-style
  tiles), each with its own index list and bounding box, so very large maps
  (4097²) are drawn chunk by chunk and culled against the view frustum.

References
----------
- D. Filipović, "Generiranje i prikaz terena" (Terrain generation and display), BSc thesis 221,
  Faculty of Electrical Engineering and Computing, University of Zagreb, 2008, §4.2.
- D. Janković, "Reljefne tehnike teksturiranja u prikazu terena" (Relief texturing techniques
  in terrain rendering), MSc thesis 62, Faculty of Electrical Engineering and Computing,
  University of Zagreb, 2010, §2.5, §2.6.4.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from terrascape._validate import check_finite, check_int, check_positive, is_pow2_plus1
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.mesh.tangent_space import heightfield_tangent_frames

DEFAULT_CHUNK = 257
# Quad rows per band in :func:`banded_grid_triangles` (see there for why 8).
DEFAULT_BAND = 8
# Rows per block when computing frames: bounds the float64 temporaries for 4097² maps.
_FRAME_BLOCK_ROWS = 256


def grid_triangles(
    rows: int,
    cols: int,
    *,
    row0: int = 0,
    col0: int = 0,
    stride: int | None = None,
    n_rows: int | None = None,
    n_cols: int | None = None,
) -> np.ndarray:
    """Triangle indices ``(m, 3)`` uint32 of a vertex sub-grid of a ``rows × cols`` grid.

    The sub-grid starts at vertex ``(row0, col0)`` and spans ``n_rows × n_cols`` vertices
    (default: everything); indices are global ``row·stride + col`` (``stride`` = ``cols``).
    """
    stride = cols if stride is None else stride
    n_rows = rows - row0 if n_rows is None else n_rows
    n_cols = cols - col0 if n_cols is None else n_cols
    if n_rows < 2 or n_cols < 2:
        return np.zeros((0, 3), dtype=np.uint32)
    r = np.arange(row0, row0 + n_rows - 1, dtype=np.int64)[:, None]
    c = np.arange(col0, col0 + n_cols - 1, dtype=np.int64)[None, :]
    return _cell_triangles((r * stride + c).ravel(), stride)


def _cell_triangles(i00: np.ndarray, stride: int) -> np.ndarray:
    """The two triangles ``(i00, i10, i01)``, ``(i01, i10, i11)`` of each cell whose first
    vertex is ``i00`` (rows ``stride`` apart), as ``(2·cells, 3)`` uint32."""
    i01 = i00 + 1
    i10 = i00 + stride
    i11 = i10 + 1
    tris = np.empty((i00.size, 2, 3), dtype=np.uint32)
    tris[:, 0, 0], tris[:, 0, 1], tris[:, 0, 2] = i00, i10, i01
    tris[:, 1, 0], tris[:, 1, 1], tris[:, 1, 2] = i01, i10, i11
    return tris.reshape(-1, 3)


def banded_grid_triangles(n_rows: int, n_cols: int, band: int = DEFAULT_BAND) -> np.ndarray:
    """The triangles of :func:`grid_triangles` for an ``n_rows × n_cols`` vertex grid (local
    indices ``row·n_cols + col``, same diagonal and winding), in a vertex-cache-friendly order.

    Quads are visited in horizontal bands of ``band`` quad rows, each band column by column.
    A row-by-row order keeps two whole vertex rows alive between reuses; a band keeps only
    ``2·(band + 1)`` vertices alive, so a small post-transform vertex cache shades each vertex
    about once. That matters on Mesa's software pipeline, whose vertex splitter caches shaded
    vertices per 1024-index segment in a 256-entry table hashed by ``index % 256``: with the
    grid order of a whole 1025-wide map (stride ≡ 1 mod 256) the two vertices of every quad
    diagonal share a slot and each triangle re-shades two vertices (2.0 shaded vertices per
    triangle against 0.59 for this order on 129² chunks, measured by the same cache model in
    ``tests/mesh/test_terrain_mesh.py``).
    """
    n_rows = check_int(n_rows, "n_rows", minimum=0)
    n_cols = check_int(n_cols, "n_cols", minimum=0)
    band = check_int(band, "band", minimum=1)
    if n_rows < 2 or n_cols < 2:
        return np.zeros((0, 3), dtype=np.uint32)
    parts = []
    cols = np.arange(n_cols - 1, dtype=np.int64)
    for r0 in range(0, n_rows - 1, band):
        rows = np.arange(r0, min(r0 + band, n_rows - 1), dtype=np.int64)
        # column-major inside the band: all quads of column c, then column c + 1
        parts.append(_cell_triangles((rows[None, :] * n_cols + cols[:, None]).ravel(), n_cols))
    return np.concatenate(parts)


@dataclass(frozen=True)
class MeshChunk:
    """A tile of the grid: vertex rows ``[row0, row0 + rows)``, cols ``[col0, col0 + cols)``.

    ``bbox_min``/``bbox_max`` are world-space ``(x, y, z)`` bounds for frustum culling.
    """

    row0: int
    col0: int
    rows: int
    cols: int
    grid_cols: int
    bbox_min: tuple[float, float, float]
    bbox_max: tuple[float, float, float]

    @property
    def n_triangles(self) -> int:
        return 2 * (self.rows - 1) * (self.cols - 1)

    @property
    def rows_slice(self) -> slice:
        return slice(self.row0, self.row0 + self.rows)

    @property
    def cols_slice(self) -> slice:
        return slice(self.col0, self.col0 + self.cols)

    def local_indices(self, band: int = DEFAULT_BAND) -> np.ndarray:
        """Flat uint32 index list into the chunk's *own* vertices (``row·cols + col`` of the
        tile, its border vertices included), in the cache-friendly band order of
        :func:`banded_grid_triangles`."""
        return banded_grid_triangles(self.rows, self.cols, band).reshape(-1)

    def indices(self) -> np.ndarray:
        """Flat uint32 index list (3 per triangle) into the whole grid's vertex array."""
        return grid_triangles(
            0,
            self.grid_cols,
            row0=self.row0,
            col0=self.col0,
            stride=self.grid_cols,
            n_rows=self.rows,
            n_cols=self.cols,
        ).reshape(-1)


@dataclass(frozen=True, eq=False)
class TerrainMesh:
    """Vertex attributes of a terrain grid (float32) and triangle/chunk indices.

    Attributes
    ----------
    positions : (n, 3) float32
    normals : (n, 3) float32, unit
    tangents : (n, 4) float32 — unit tangent along +u and handedness ``w`` (B = w·N×T)
    rows, cols : grid size (``n = rows·cols``)
    spacing : (dx, dz)
    uv_scale, exaggeration : the parameters the mesh was built with
    """

    positions: np.ndarray
    normals: np.ndarray
    tangents: np.ndarray
    rows: int
    cols: int
    spacing: tuple[float, float]
    uv_scale: float = 1.0
    exaggeration: float = 1.0

    @property
    def n_vertices(self) -> int:
        return self.rows * self.cols

    @property
    def n_triangles(self) -> int:
        return 2 * (self.rows - 1) * (self.cols - 1)

    @property
    def extent(self) -> tuple[float, float]:
        return ((self.cols - 1) * self.spacing[0], (self.rows - 1) * self.spacing[1])

    @cached_property
    def bitangents(self) -> np.ndarray:
        """(n, 3) float32 ``w · (N × T)`` — computed on first use (saves memory on big maps)."""
        b = np.cross(self.normals, self.tangents[:, :3]) * self.tangents[:, 3:4]
        return b.astype(np.float32)

    @cached_property
    def uvs(self) -> np.ndarray:
        """(n, 2) float32 planar texture coordinates (see module docstring)."""
        ex, ez = self.extent
        u = self.positions[:, 0].astype(np.float64) / ex * self.uv_scale
        v = self.positions[:, 2].astype(np.float64) / ez * self.uv_scale
        return np.stack([u, v], axis=1).astype(np.float32)

    @cached_property
    def triangles(self) -> np.ndarray:
        """(m, 3) uint32 triangle indices of the whole grid."""
        return grid_triangles(self.rows, self.cols)

    def chunks(self, size: int = DEFAULT_CHUNK) -> list[MeshChunk]:
        """Split the grid into tiles of ``size`` (2**k + 1) vertices per side sharing borders.

        The last row/column of tiles may be smaller when the grid is not a multiple.
        """
        size = check_int(size, "chunk size", minimum=3)
        if not is_pow2_plus1(size):
            raise InvalidParameterError(f"chunk size must be 2**k + 1 (e.g. 65, 257), got {size}")
        step = size - 1
        ys = self.positions[:, 1].reshape(self.rows, self.cols)
        dx, dz = self.spacing
        out = []
        for r0 in range(0, self.rows - 1, step):
            nr = min(size, self.rows - r0)
            for c0 in range(0, self.cols - 1, step):
                nc = min(size, self.cols - c0)
                block = ys[r0 : r0 + nr, c0 : c0 + nc]
                out.append(
                    MeshChunk(
                        r0,
                        c0,
                        nr,
                        nc,
                        self.cols,
                        (c0 * dx, float(block.min()), r0 * dz),
                        ((c0 + nc - 1) * dx, float(block.max()), (r0 + nr - 1) * dz),
                    )
                )
        return out


def terrain_mesh(
    heightmap: Heightmap, *, uv_scale: float = 1.0, exaggeration: float = 1.0
) -> TerrainMesh:
    """Build the render mesh of a heightmap.

    Parameters
    ----------
    heightmap
        Any size ≥ 2×2, any spacing.
    uv_scale
        Texture repeats over the terrain (planar mapping scale); > 0.
    exaggeration
        Vertical scale applied to heights (and therefore to normals and tangents); > 0.

    Returns
    -------
    TerrainMesh
        float32 positions, unit normals (central differences, as ``Heightmap.normals``),
        tangents with handedness; bitangents/uvs/triangles on demand.
    """
    if not isinstance(heightmap, Heightmap):
        raise InvalidParameterError(
            f"terrain_mesh expects a terrascape Heightmap, got {type(heightmap).__name__}"
        )
    uv_scale = check_positive(uv_scale, "uv_scale")
    exaggeration = check_positive(exaggeration, "exaggeration")
    check_finite(exaggeration, "exaggeration")
    rows, cols = heightmap.shape
    dx, dz = heightmap.spacing
    h = heightmap.heights
    positions = np.empty((rows, cols, 3), dtype=np.float32)
    positions[..., 0] = (np.arange(cols, dtype=np.float64) * dx).astype(np.float32)[None, :]
    positions[..., 1] = h * np.float32(exaggeration)
    positions[..., 2] = (np.arange(rows, dtype=np.float64) * dz).astype(np.float32)[:, None]
    normals = np.empty((rows * cols, 3), dtype=np.float32)
    tangents = np.empty((rows * cols, 4), dtype=np.float32)
    # Central differences inside, one-sided at the map border (np.gradient, exactly like
    # Heightmap.gradient), computed in row blocks with a one-row halo so that inner block
    # edges still see their neighbours; blocks bound the float64 temporaries on 4097² maps.
    for r0 in range(0, rows, _FRAME_BLOCK_ROWS):
        r1 = min(rows, r0 + _FRAME_BLOCK_ROWS)
        lo, hi = max(0, r0 - 1), min(rows, r1 + 1)
        block = h[lo:hi].astype(np.float64) * exaggeration
        gz, gx = np.gradient(block, dz, dx)
        gx, gz = gx[r0 - lo : r1 - lo], gz[r0 - lo : r1 - lo]
        n, t4, _ = heightfield_tangent_frames(gx, gz)
        normals[r0 * cols : r1 * cols] = n
        tangents[r0 * cols : r1 * cols] = t4
    return TerrainMesh(
        positions=positions.reshape(-1, 3),
        normals=normals,
        tangents=tangents,
        rows=rows,
        cols=cols,
        spacing=(dx, dz),
        uv_scale=uv_scale,
        exaggeration=exaggeration,
    )


__all__ = [
    "DEFAULT_BAND",
    "DEFAULT_CHUNK",
    "MeshChunk",
    "TerrainMesh",
    "banded_grid_triangles",
    "grid_triangles",
    "terrain_mesh",
]
