"""Hex-tiling: texture a surface of any size from one exemplar without a visible period.

Plain wrap sampling repeats a texture exactly every tile, a regular grid the eye (and the
power spectrum, as a peak at the tile frequency) finds at once. Hex-tiling (Mikkelsen 2022,
after Heitz & Neyret 2018) covers the plane with a triangle grid whose vertices are the
centres of hexagons; each vertex gets its own random offset (and rotation) into the
exemplar, and a point blends the three exemplar lookups of its triangle's vertices with its
barycentric weights raised to a power (``sharpness``: hexagon-shaped patches with narrow
transitions) and modulated by each lookup's luminance (``contrast``: brighter texels, for
a height channel the higher ones, win the transition instead of averaging to grey). The
result has the exemplar's look but no period.

This module is the CPU version; ``render/shaders/common/hextile.glsl`` is the same
construction (same grid, same integer hash, same weights) for the renderer. Both hash the
grid vertex with PCG2D (Jarzynski & Olano 2020), an integer hash that gives the same bits on
CPU and GPU.

References
----------
.. [1] M. S. Mikkelsen, "Practical Real-Time Hex-Tiling", Journal of Computer Graphics
   Techniques 11(3), 2022, 77–94.
.. [2] E. Heitz, F. Neyret, "High-Performance By-Example Noise using a Histogram-Preserving
   Blending Operator", Proc. ACM Comput. Graph. Interact. Tech. 1(2), 2018.
.. [3] M. Jarzynski, M. Olano, "Hash Functions for GPU Rendering", JCGT 9(3), 2020.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, prange
from terrascape._validate import check_int, check_positive, check_range
from terrascape.errors import InvalidParameterError

#: Defaults shared with the shaders (Mikkelsen's paper uses contrast 0.6 and exponent 7).
HEX_CONTRAST = 0.6
HEX_SHARPNESS = 7.0
HEX_ROTATION = 1.0

_SQRT3_2 = 2.0 * math.sqrt(3.0)
_M32 = 0xFFFFFFFF


@njit(cache=CACHE, fastmath=FASTMATH)
def _pcg2d(x, y):
    """PCG2D on two uint32 (held in int64): returns two uint32."""
    x = (x * 1664525 + 1013904223) & 0xFFFFFFFF
    y = (y * 1664525 + 1013904223) & 0xFFFFFFFF
    x = (x + y * 1664525) & 0xFFFFFFFF
    y = (y + x * 1664525) & 0xFFFFFFFF
    x ^= x >> 16
    y ^= y >> 16
    x = (x + y * 1664525) & 0xFFFFFFFF
    y = (y + x * 1664525) & 0xFFFFFFFF
    x ^= x >> 16
    y ^= y >> 16
    return x, y


@njit(cache=CACHE, fastmath=FASTMATH)
def _vertex_transform(vx, vy, seed, rotation):
    """Random offset ``(ox, oy)`` in [0, 1)² and rotation ``(cos, sin)`` of grid vertex v."""
    hx, hy = _pcg2d((vx + seed * 7919) & 0xFFFFFFFF, (vy + seed * 104729) & 0xFFFFFFFF)
    ox = hx / 4294967296.0
    oy = hy / 4294967296.0
    gx, _ = _pcg2d(hx, hy)
    angle = (gx / 4294967296.0 * 2.0 - 1.0) * math.pi * rotation
    return ox, oy, math.cos(angle), math.sin(angle)


@njit(cache=CACHE, fastmath=FASTMATH)
def _hex_grid(u, v):
    """Triangle-grid vertices and barycentric weights at texture coordinate (u, v).

    Returns ``(v1x, v1y, v2x, v2y, v3x, v3y, w1, w2, w3)`` (Mikkelsen 2022, TriangleGrid).
    """
    x = u * _SQRT3_2
    y = v * _SQRT3_2
    sx = x
    sy = -0.57735027 * x + 1.15470054 * y
    bx = math.floor(sx)
    by = math.floor(sy)
    fx = sx - bx
    fy = sy - by
    fz = 1.0 - fx - fy
    s = 1 if fz < 0.0 else 0
    s2 = 2.0 * s - 1.0
    w1 = -fz * s2
    w2 = s - fy * s2
    w3 = s - fx * s2
    ibx = int(bx)
    iby = int(by)
    return (ibx + s, iby + s, ibx + s, iby + 1 - s, ibx + 1 - s, iby + s, w1, w2, w3)


@njit(cache=CACHE, fastmath=FASTMATH)
def _vertex_uv(vx, vy, u, v, seed, rotation):
    """Exemplar coordinate of (u, v) seen from grid vertex v: rotated about the hexagon's
    centre and offset by the vertex's hash. Returns ``(uu, vv, cos, sin)``."""
    cx = vx / _SQRT3_2
    cy = (0.5 * vx + 0.8660254 * vy) / _SQRT3_2
    ox, oy, c, s = _vertex_transform(vx, vy, seed, rotation)
    du = u - cx
    dv = v - cy
    return c * du - s * dv + cx + ox, s * du + c * dv + cy + oy, c, s


@njit(cache=CACHE, fastmath=FASTMATH)
def _wrap_cell(tex, u, v):
    """The texel cell around uv (texel centres, wrapped): rows i0, i1, columns j0, j1 and
    the bilinear weights fx, fy."""
    size_y, size_x = tex.shape[0], tex.shape[1]
    x = u * size_x - 0.5
    y = v * size_y - 0.5
    x0 = math.floor(x)
    y0 = math.floor(y)
    i0 = int(y0) % size_y
    j0 = int(x0) % size_x
    return i0, j0, (i0 + 1) % size_y, (j0 + 1) % size_x, x - x0, y - y0


@njit(cache=CACHE, fastmath=FASTMATH)
def _bilinear_wrap(tex, u, v, c):
    """Bilinear, wrapped lookup of channel ``c`` of ``tex (S, S, C)`` at uv (texel centres)."""
    i0, j0, i1, j1, fx, fy = _wrap_cell(tex, u, v)
    top = tex[i0, j0, c] + (tex[i0, j1, c] - tex[i0, j0, c]) * fx
    bottom = tex[i1, j0, c] + (tex[i1, j1, c] - tex[i1, j0, c]) * fx
    return top + (bottom - top) * fy


@njit(cache=CACHE, fastmath=FASTMATH)
def _bilinear_wrap_all(tex, u, v, out):
    """Every channel of a bilinear, wrapped lookup into ``out`` (one index computation)."""
    i0, j0, i1, j1, fx, fy = _wrap_cell(tex, u, v)
    for c in range(out.shape[0]):
        top = tex[i0, j0, c] + (tex[i0, j1, c] - tex[i0, j0, c]) * fx
        bottom = tex[i1, j0, c] + (tex[i1, j1, c] - tex[i1, j0, c]) * fx
        out[c] = top + (bottom - top) * fy


@njit(cache=CACHE, fastmath=FASTMATH)
def _hex_weights(w1, w2, w3, l1, l2, l3, contrast, sharpness):
    """Mikkelsen's blend weights: ``mix(1, lum, contrast) · w^sharpness``, normalised."""
    a = (1.0 + (l1 - 1.0) * contrast) * w1**sharpness
    b = (1.0 + (l2 - 1.0) * contrast) * w2**sharpness
    c = (1.0 + (l3 - 1.0) * contrast) * w3**sharpness
    t = a + b + c
    if t <= 0.0:
        return 1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0
    return a / t, b / t, c / t


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _hex_tile_kernel(tex, lum_channel, rows, cols, tile, seed, rotation, contrast, sharpness,
                     out):
    n_ch = tex.shape[2]
    for i in prange(rows):
        for j in range(cols):
            u = (j + 0.5) / tile
            v = (i + 0.5) / tile
            g = _hex_grid(u, v)
            u1, v1, _, _ = _vertex_uv(g[0], g[1], u, v, seed, rotation)
            u2, v2, _, _ = _vertex_uv(g[2], g[3], u, v, seed, rotation)
            u3, v3, _, _ = _vertex_uv(g[4], g[5], u, v, seed, rotation)
            if lum_channel >= 0:
                l1 = _bilinear_wrap(tex, u1, v1, lum_channel)
                l2 = _bilinear_wrap(tex, u2, v2, lum_channel)
                l3 = _bilinear_wrap(tex, u3, v3, lum_channel)
            else:
                l1 = l2 = l3 = 1.0
            a, b, c = _hex_weights(g[6], g[7], g[8], l1, l2, l3, contrast, sharpness)
            for ch in range(n_ch):
                out[i, j, ch] = (a * _bilinear_wrap(tex, u1, v1, ch)
                                 + b * _bilinear_wrap(tex, u2, v2, ch)
                                 + c * _bilinear_wrap(tex, u3, v3, ch))


def box_mip(texture: np.ndarray, levels: int) -> np.ndarray:
    """``texture (S, S, C)`` reduced ``levels`` times by exact 2×2 means (wrap-safe)."""
    t = np.asarray(texture, dtype=np.float32)
    for _ in range(levels):
        if t.shape[0] % 2 or t.shape[1] % 2 or min(t.shape[:2]) <= 4:
            break
        h, w = t.shape[0] // 2, t.shape[1] // 2
        t = t.reshape(h, 2, w, 2, t.shape[2]).mean(axis=(1, 3), dtype=np.float32)
    return np.ascontiguousarray(t)


def mip_levels_for(texture_size: int, pixels_per_tile: float) -> int:
    """Mip reductions so one texel of the sampled level covers about one output pixel."""
    texels_per_pixel = texture_size / max(pixels_per_tile, 1e-9)
    return max(0, math.floor(math.log2(texels_per_pixel))) if texels_per_pixel > 1 else 0


def _as_texture(texture: Any) -> tuple[np.ndarray, bool]:
    t = np.asarray(texture)
    squeeze = t.ndim == 2
    if squeeze:
        t = t[..., None]
    if t.ndim != 3 or t.shape[0] < 2 or t.shape[1] < 2 or t.shape[2] > 4:
        raise InvalidParameterError(
            f"texture must be (H, W) or (H, W, C≤4) of at least 2×2, got shape {t.shape}"
        )
    if not np.issubdtype(t.dtype, np.number) or t.dtype == np.bool_:
        raise InvalidParameterError(f"texture must be numeric, got dtype {t.dtype}")
    t = t.astype(np.float32)
    if not np.isfinite(t).all():
        raise InvalidParameterError("texture contains NaN/infinite values")
    return t, squeeze


def hex_tile(
    texture: Any,
    shape: tuple[int, int],
    *,
    tile: float = 64.0,
    seed: int = 0,
    rotation: float = HEX_ROTATION,
    contrast: float = HEX_CONTRAST,
    sharpness: float = HEX_SHARPNESS,
    luminance_channel: int | None = None,
) -> np.ndarray:
    """Synthesise a ``shape`` image from an exemplar texture with hex-tiling.

    Parameters
    ----------
    texture
        Exemplar ``(H, W)`` or ``(H, W, C)``, C ≤ 4, any numeric dtype; it should tile
        seamlessly itself (e.g. :func:`terrascape.texture.photo_materials.periodic_component`).
    shape
        Output ``(rows, cols)``.
    tile
        Output pixels per exemplar repeat (the exemplar is box-mip-mapped down so one of its
        texels covers about one output pixel).
    seed
        Seeds the per-vertex offsets and rotations (non-negative int).
    rotation
        Fraction of ±180° each hexagon may be rotated by (0: offsets only).
    contrast, sharpness
        Mikkelsen's luminance fall-off contrast in [0, 1] and barycentric exponent ≥ 1.
    luminance_channel
        Channel that weights the blend (its values should be in [0, 1]); ``None``: the mean
        of the channels scaled to [0, 1] by the exemplar's range.

    Returns
    -------
    numpy.ndarray
        float32 ``(rows, cols)`` or ``(rows, cols, C)`` in the exemplar's value range.
    """
    tex, squeeze = _as_texture(texture)
    if not isinstance(shape, (tuple, list)) or len(shape) != 2:
        raise InvalidParameterError(f"shape must be (rows, cols), got {shape!r}")
    rows = check_int(shape[0], "rows", minimum=1, maximum=1 << 15)
    cols = check_int(shape[1], "cols", minimum=1, maximum=1 << 15)
    tile = check_positive(tile, "tile")
    seed = check_int(seed, "seed", minimum=0, maximum=_M32)
    rotation = check_range(rotation, "rotation", 0.0, 1.0)
    contrast = check_range(contrast, "contrast", 0.0, 1.0)
    sharpness = check_range(sharpness, "sharpness", 1.0, 64.0)
    tex = box_mip(tex, mip_levels_for(tex.shape[1], tile))
    if luminance_channel is None:
        lo, hi = float(tex.min()), float(tex.max())
        lum = (tex.mean(axis=2) - lo) / (hi - lo) if hi > lo else np.ones(tex.shape[:2])
        work = np.ascontiguousarray(np.concatenate([tex, lum[..., None].astype(np.float32)],
                                                   axis=2))
        ch = tex.shape[2]
    else:
        ch = check_int(luminance_channel, "luminance_channel", minimum=0,
                       maximum=tex.shape[2] - 1)
        work = tex
    out = np.empty((rows, cols, work.shape[2]), dtype=np.float32)
    _hex_tile_kernel(work, ch, rows, cols, tile, seed, rotation, contrast, sharpness, out)
    out = out[..., : tex.shape[2]]
    return np.ascontiguousarray(out[..., 0] if squeeze else out)


__all__ = [
    "HEX_CONTRAST",
    "HEX_ROTATION",
    "HEX_SHARPNESS",
    "box_mip",
    "hex_tile",
    "mip_levels_for",
]
