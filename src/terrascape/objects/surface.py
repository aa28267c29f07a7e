"""The height of the terrain's full-resolution surface as drawn, at any world ``(x, z)``.

The renderer's full-detail mesh (:mod:`terrascape.mesh.terrain_mesh`) splits every grid cell
along the diagonal from vertex ``(row + 1, col)`` to ``(row, col + 1)`` into the triangles
``(i00, i10, i01)`` and ``(i01, i10, i11)``. Inside a cell, with ``u = x/dx − col`` and
``w = z/dz − row`` in ``[0, 1]``, the surface is the plane of the first triangle where
``u + w ≤ 1`` and of the second elsewhere — not the bilinear patch, which differs from the
triangles by up to a quarter of the cell's twist. Objects placed at this height sit exactly
on the full-detail mesh, and since it does not depend on any level-of-detail mesh, they do not
move when the LOD changes.
"""

from __future__ import annotations

import numpy as np

from terrascape._validate import check_finite, check_positive
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap

__all__ = ["surface_height", "surface_normal"]


def _cells(heightmap: Heightmap, x, z):
    if not isinstance(heightmap, Heightmap):
        raise InvalidParameterError(
            f"surface_height expects a terrascape Heightmap, got {type(heightmap).__name__}")
    xs = np.asarray(x, np.float64)
    zs = np.asarray(z, np.float64)
    if xs.shape != zs.shape:
        raise InvalidParameterError(f"x and z need the same shape, got {xs.shape} and {zs.shape}")
    if not (np.isfinite(xs).all() and np.isfinite(zs).all()):
        raise InvalidParameterError("x and z must be finite")
    rows, cols = heightmap.shape
    if rows < 2 or cols < 2:
        raise InvalidParameterError(f"the heightmap needs at least 2×2 samples, got {cols}×{rows}")
    dx, dz = heightmap.spacing
    # positions outside the map take the height of its nearest border point
    fx = np.clip(xs / dx, 0.0, cols - 1.0)
    fz = np.clip(zs / dz, 0.0, rows - 1.0)
    c = np.minimum(np.floor(fx).astype(np.int64), cols - 2)
    r = np.minimum(np.floor(fz).astype(np.int64), rows - 2)
    return fx - c, fz - r, r, c


def surface_height(heightmap: Heightmap, x, z, exaggeration: float = 1.0) -> np.ndarray:
    """Height of the drawn full-resolution surface at world ``(x, z)``.

    Parameters
    ----------
    heightmap
        The terrain (``x = col · dx``, ``z = row · dz``).
    x, z
        World coordinates, arrays of one shape; points outside the map are clamped to its edge.
    exaggeration
        The vertical scale the terrain is drawn with (> 0).

    Returns
    -------
    numpy.ndarray
        float64 heights (world units, exaggeration applied), the shape of ``x``.
    """
    exaggeration = check_positive(check_finite(exaggeration, "exaggeration"), "exaggeration")
    u, w, r, c = _cells(heightmap, x, z)
    h = heightmap.heights
    h00 = h[r, c].astype(np.float64)
    h01 = h[r, c + 1].astype(np.float64)
    h10 = h[r + 1, c].astype(np.float64)
    h11 = h[r + 1, c + 1].astype(np.float64)
    first = u + w <= 1.0
    lower = h00 + u * (h01 - h00) + w * (h10 - h00)
    upper = h11 + (1.0 - u) * (h10 - h11) + (1.0 - w) * (h01 - h11)
    # the mesh stores float32 heights × float32 exaggeration; the same product here
    return np.where(first, lower, upper) * float(np.float32(exaggeration))


def surface_normal(heightmap: Heightmap, x, z, exaggeration: float = 1.0) -> np.ndarray:
    """Unit normal ``(..., 3)`` of the drawn triangle under world ``(x, z)`` (flat per
    triangle, unlike the mesh's smoothed vertex normals)."""
    exaggeration = check_positive(check_finite(exaggeration, "exaggeration"), "exaggeration")
    u, w, r, c = _cells(heightmap, x, z)
    h = heightmap.heights.astype(np.float64) * exaggeration
    dx, dz = heightmap.spacing
    first = u + w <= 1.0
    gx = np.where(first, h[r, c + 1] - h[r, c], h[r + 1, c + 1] - h[r + 1, c]) / dx
    gz = np.where(first, h[r + 1, c] - h[r, c], h[r + 1, c + 1] - h[r, c + 1]) / dz
    n = np.stack([-gx, np.ones_like(gx), -gz], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)
