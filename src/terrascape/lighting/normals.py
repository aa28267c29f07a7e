"""Surface normals and packed normal + height textures.

Parallax mapping (§2.3.1) reads two inputs, "a normal map (also used by bump mapping)
and a depth map", stored in *one* texture — RGB holds the normal map, alpha the height.
:func:`pack_normal_height` produces exactly that texture from a heightmap.

Normals come from the height gradient with the real sample spacing ``(dx, dz)``: for
``y = s·h(x, z)`` the (unnormalised) normal is ``(-s·∂h/∂x, 1, -s·∂h/∂z)``. Derivatives are
central differences inside and second-order one-sided differences on the border, so a
plane *and* a quadratic surface get exact normals everywhere (the same stencils as
``numpy.gradient(..., edge_order=2)``).

References
----------
- D. Janković, "Reljefne tehnike teksturiranja u prikazu terena" (Relief texturing techniques
  in terrain rendering), MSc thesis 62, Faculty of Electrical Engineering and Computing,
  University of Zagreb, 2010, §2.3.1, §2.5.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, prange
from terrascape._validate import check_finite
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.lighting._common import as_heightmap


@njit(cache=CACHE, fastmath=FASTMATH)
def _grad_axis1(h, r, c, inv_d):
    """∂h/∂(axis 1) at (r, c), exact for quadratics (2nd-order stencils everywhere)."""
    n = h.shape[1]
    if n == 2:
        return (h[r, 1] - h[r, 0]) * inv_d
    if c == 0:
        return (-3.0 * h[r, 0] + 4.0 * h[r, 1] - h[r, 2]) * 0.5 * inv_d
    if c == n - 1:
        return (3.0 * h[r, n - 1] - 4.0 * h[r, n - 2] + h[r, n - 3]) * 0.5 * inv_d
    return (h[r, c + 1] - h[r, c - 1]) * 0.5 * inv_d


@njit(cache=CACHE, fastmath=FASTMATH)
def _grad_axis0(h, r, c, inv_d):
    """∂h/∂(axis 0) at (r, c), same stencils as :func:`_grad_axis1`."""
    n = h.shape[0]
    if n == 2:
        return (h[1, c] - h[0, c]) * inv_d
    if r == 0:
        return (-3.0 * h[0, c] + 4.0 * h[1, c] - h[2, c]) * 0.5 * inv_d
    if r == n - 1:
        return (3.0 * h[n - 1, c] - 4.0 * h[n - 2, c] + h[n - 3, c]) * 0.5 * inv_d
    return (h[r + 1, c] - h[r - 1, c]) * 0.5 * inv_d


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _normals_kernel(h, dx, dz, scale, tangent_space, out):
    """Unit normals into ``out`` (rows, cols, 3) float32; world (x, y, z) or tangent (u, v, up)."""
    rows, cols = h.shape
    inv_dx = 1.0 / dx
    inv_dz = 1.0 / dz
    for rp in prange(rows):
        # The prange index is unsigned in one of numba's typing passes and signed in the
        # other: one int64 row index, so the stencils compile once.
        r = np.int64(rp)
        for c in range(cols):
            # float64 arithmetic: float32 differences of large heights lose digits.
            gx = -scale * _grad_axis1(h, r, c, inv_dx)
            gz = -scale * _grad_axis0(h, r, c, inv_dz)
            inv = 1.0 / math.sqrt(gx * gx + gz * gz + 1.0)
            out[r, c, 0] = gx * inv
            if tangent_space:
                out[r, c, 1] = gz * inv
                out[r, c, 2] = inv
            else:
                out[r, c, 1] = inv
                out[r, c, 2] = gz * inv


def _normals(heightmap: Any, height_scale: float, tangent_space: bool) -> np.ndarray:
    hm = as_heightmap(heightmap)
    scale = check_finite(height_scale, "height_scale")
    h = hm.heights.astype(np.float64)
    out = np.empty((hm.rows, hm.cols, 3), dtype=np.float32)
    _normals_kernel(h, float(hm.spacing[0]), float(hm.spacing[1]), scale, tangent_space, out)
    return out


def normal_map(heightmap: Any, *, height_scale: float = 1.0) -> np.ndarray:
    """World-space unit normals, Y up.

    Parameters
    ----------
    heightmap
        :class:`~terrascape.heightmap.Heightmap` (its spacing ``(dx, dz)`` is used) or a 2-D
        array (spacing 1).
    height_scale
        Vertical exaggeration ``s``: the surface is ``y = s·h``. May be negative or 0
        (0 gives flat normals).

    Returns
    -------
    numpy.ndarray
        float32 ``(rows, cols, 3)``, ``(x, y, z)`` = normalise(``-s·∂h/∂x, 1, -s·∂h/∂z``).

    Notes
    -----
    Central differences inside, second-order one-sided differences on the border: exact
    for planes and paraboloids.
    """
    return _normals(heightmap, height_scale, False)


def tangent_space_normals(heightmap: Any, *, height_scale: float = 1.0) -> np.ndarray:
    """Normals in the texture's tangent frame — what a normal-map texture stores.

    The frame is ``x`` along +u (columns, world +X), ``y`` along +v (rows, world +Z) and
    ``z`` = up (world +Y), so a flat map gives ``(0, 0, 1)``. A shader rebuilds the world
    normal as ``x·T + y·B + z·N`` with ``T = +X``, ``B = +Z``, ``N = +Y``.

    Returns
    -------
    numpy.ndarray
        float32 ``(rows, cols, 3)``: normalise(``-s·∂h/∂x, -s·∂h/∂z, 1``).
    """
    return _normals(heightmap, height_scale, True)


def pack_normal_height(
    heightmap: Any, *, height_scale: float = 1.0, bits: int = 8
) -> np.ndarray:
    """The RGBA texture parallax/relief shaders read: RGB = normal, A = height.

    Parameters
    ----------
    heightmap
        Heightmap or 2-D array.
    height_scale
        Passed to :func:`tangent_space_normals`.
    bits
        8 (``uint8``) or 16 (``uint16``).

    Returns
    -------
    numpy.ndarray
        ``(rows, cols, 4)``; ``RGB = round((n·0.5 + 0.5)·maxval)`` of the tangent-space
        normal, ``A = round((h - min)/(max - min)·maxval)`` (0 for a flat map). Shaders that
        want *depth* (relief mapping) use ``1 - A``.
    """
    if bits not in (8, 16) or isinstance(bits, bool):
        raise InvalidParameterError(f"bits must be 8 or 16, got {bits!r}")
    hm = as_heightmap(heightmap)
    check_finite(height_scale, "height_scale")
    dtype = np.uint8 if bits == 8 else np.uint16
    maxval = float(np.iinfo(dtype).max)
    out = np.empty((hm.rows, hm.cols, 4), dtype=dtype)
    lo = float(hm.heights.min())
    span = float(hm.heights.max()) - lo
    rows, cols = hm.rows, hm.cols
    # A block of rows at a time, with two halo rows either side so every kept row sees the
    # stencils of the whole map (identical codes): the float32 normals and the float64
    # temporaries exist for one block only, not 40+ bytes per sample of the whole map.
    step = max(1, _PACK_BLOCK_SAMPLES // cols)
    for r0 in range(0, rows, step):
        r1 = min(rows, r0 + step)
        a, b = max(0, r0 - 2), min(rows, r1 + 2)
        sub = Heightmap(hm.heights[a:b], hm.spacing)
        n = tangent_space_normals(sub, height_scale=height_scale)[r0 - a:r1 - a]
        out[r0:r1, :, :3] = np.rint((n.astype(np.float64) * 0.5 + 0.5) * maxval).clip(0, maxval)
        h = hm.heights[r0:r1].astype(np.float64)
        unit = (h - lo) / span if span > 0 else np.zeros_like(h)  # float64: exact codes
        out[r0:r1, :, 3] = np.rint(unit * maxval).clip(0, maxval)
    return out


#: Samples per block of rows in :func:`pack_normal_height`.
_PACK_BLOCK_SAMPLES = 1 << 20


def unpack_normals(packed: np.ndarray) -> np.ndarray:
    """Inverse of the RGB part of :func:`pack_normal_height`: unit float32 normals."""
    p = np.asarray(packed)
    if p.ndim != 3 or p.shape[2] < 3 or p.dtype not in (np.uint8, np.uint16):
        raise InvalidParameterError(
            f"expected a uint8/uint16 (rows, cols, 3 or 4) array, got {p.dtype} {p.shape}"
        )
    maxval = float(np.iinfo(p.dtype).max)
    n = p[..., :3].astype(np.float64) / maxval * 2.0 - 1.0
    n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12)
    return n.astype(np.float32)


__all__ = ["normal_map", "pack_normal_height", "tangent_space_normals", "unpack_normals"]
