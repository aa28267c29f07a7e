"""Relief *texture* mapping by pre-warping (Oliveira, Bishop & McAllister 2000; seed 000
§2.4.1–2.4.5, MISSION R9).

A relief texture is a colour image plus a per-texel orthogonal displacement. For a given
camera it is first *pre-warped* — every texel slides inside the texture plane to where the
camera would see its displaced 3-D point — and the result is then applied to the flat quad
with ordinary texture mapping: ``w = m ∘ p`` (§2.4.4).

Pre-warp equations (§2.4.4)::

    u_i = (u_s + k1·d) / (1 + k3·d),   v_i = (v_s + k2·d) / (1 + k3·d)

With the quad spanned by ``a`` (+u), ``b`` (+v) and ``f`` (world vector of one unit of
displacement) and the eye at ``C_s + a·e_u + b·e_v + f·e_d``, the line from the eye through
``C_s + a·u + b·v + f·d`` crosses the quad plane at ``u_i = (u − (e_u/e_d)·d)/(1 − d/e_d)``,
so ``k1 = −e_u/e_d``, ``k2 = −e_v/e_d``, ``k3 = −1/e_d`` — Oliveira's
``k1 = f·(b×c)/a·(b×c)`` etc. with ``c = C_s − eye``. Here the relief hangs *below* the
polygon (``f`` points away from the camera, ``d = 1 − height`` as in every relief shader of
this package), so ``e_d < 0`` and ``1 + k3·d > 0`` never vanishes.

Because ``u_i`` depends only on ``(u_s, d)`` and ``v_i`` only on ``(v_s, d)``, the warp is
separable into two 1-D passes (§2.4.5): every row is warped horizontally (colour and the
target ``v_i`` are interpolated linearly between neighbouring texels, the seed's
pseudocode), then every column of that intermediate image is warped vertically. Visibility is
resolved by McMillan's occlusion-compatible order: texels are processed from the far side
*toward the epipole* ``(e_u, e_v)`` (the eye's orthogonal projection on the texture plane);
a texel nearer the epipole is never behind one farther from it, so later writes simply
overwrite earlier ones, and folds (texels moving backwards) draw nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, prange
from terrascape._validate import as_height_array
from terrascape.errors import InvalidParameterError
from terrascape.relief.reference import ReliefQuad, _vec3, quad_entry


@dataclass(frozen=True)
class PrewarpCoefficients:
    """``k1, k2, k3`` in UV units and the epipole ``(e_u, e_v)`` in UV."""

    k1: float
    k2: float
    k3: float
    epipole: tuple[float, float]


def prewarp_coefficients(quad: ReliefQuad, eye) -> PrewarpCoefficients:
    """Pre-warp constants for a camera at ``eye`` (world) looking at ``quad``.

    Only untiled quads (``uv_scale == (1, 1)``) are supported: a tiled quad repeats the
    relief texture, and every tile would need its own epipole.
    """
    if quad.uv_scale != (1.0, 1.0):
        raise InvalidParameterError(
            f"pre-warping needs an untiled quad (uv_scale (1, 1)), got {quad.uv_scale}"
        )
    e = quad.world_to_uvd(eye) @ (_vec3(eye, "eye") - np.asarray(quad.origin))
    eu, ev, ed = (float(x) for x in e)
    if ed >= 0:  # cannot happen with front_normal(), kept as a guard against NaN input
        raise InvalidParameterError("the eye must be in front of the quad")
    return PrewarpCoefficients(-eu / ed, -ev / ed, -1.0 / ed, (eu, ev))


@njit(cache=CACHE, fastmath=FASTMATH)
def _span(out, written, xa, xb, va, vb):
    # Rasterise one span between two warped samples: every output pixel centre j in
    # [xa, xb] gets the linear interpolation (seed §2.4.5 pseudocode).
    m = out.shape[0]
    lo = max(math.ceil(xa), 0)
    hi = min(math.floor(xb), m - 1)
    if hi < lo:
        return
    inv = 1.0 / (xb - xa) if xb > xa else 0.0
    for j in range(lo, hi + 1):
        t = (j - xa) * inv
        for c in range(out.shape[1]):
            out[j, c] = va[c] + (vb[c] - va[c]) * t
        written[j] = 1


@njit(cache=CACHE, fastmath=FASTMATH)
def _warp_line(x, vals, ok, e, out, written):
    """Warp one line of samples (source order, target positions ``x``) into ``out``.

    Spans left of the epipole ``e`` are drawn left→right, those right of it right→left,
    the span containing it last: occlusion-compatible order, later writes win.
    """
    n = x.shape[0]
    ce = math.floor(e)
    if ce < -1:
        ce = -1
    if ce > n - 1:
        ce = n - 1
    # Left sweep: spans (i, i+1) for i < ce, increasing (texels move right).
    for i in range(0, ce):
        if ok[i] and ok[i + 1] and x[i + 1] > x[i]:
            _span(out, written, x[i], x[i + 1], vals[i], vals[i + 1])
    # Right sweep: spans (i, i+1) for i > ce, decreasing (texels move left).
    for i in range(n - 2, ce, -1):
        if ok[i] and ok[i + 1] and x[i + 1] > x[i]:
            _span(out, written, x[i], x[i + 1], vals[i], vals[i + 1])
    if 0 <= ce < n - 1 and ok[ce] and ok[ce + 1] and x[ce + 1] > x[ce]:
        _span(out, written, x[ce], x[ce + 1], vals[ce], vals[ce + 1])
    # A lone sample exactly on a pixel centre (no span), e.g. a zero-displacement texel.
    for i in range(n):
        if ok[i]:
            j = math.floor(x[i] + 0.5)
            if abs(x[i] - j) < 1e-9 and 0 <= j < out.shape[0] and written[j] == 0:
                for c in range(out.shape[1]):
                    out[j, c] = vals[i, c]
                written[j] = 1


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _pass_rows(colour, disp, k1p, k2p, k3, eu, ev, mx, my, inter, inter_ok):
    """Pass 1: every source row (with wrapped margins) warped horizontally.

    ``inter`` gets (colour..., target row position) per output column.
    """
    rows, cols, nc = colour.shape
    n_rows = rows + 2 * my
    n = cols + 2 * mx
    for rr in prange(n_rows):
        r = rr - my
        sr = r % rows
        x = np.empty(n)
        vals = np.empty((n, nc + 1))
        ok = np.ones(n, dtype=np.uint8)
        for i in range(n):
            c = i - mx
            sc = c % cols
            d = disp[sr, sc]
            w = 1.0 + k3 * d
            # Texel centre index c ↔ texel coordinate c + 0.5; output index = coord − 0.5.
            x[i] = (c + 0.5 + k1p * d) / w - 0.5
            for k in range(nc):
                vals[i, k] = colour[sr, sc, k]
            vals[i, nc] = (r + 0.5 + k2p * d) / w - 0.5
        out = np.zeros((cols, nc + 1))
        written = np.zeros(cols, dtype=np.uint8)
        _warp_line(x, vals, ok, eu + mx, out, written)
        for j in range(cols):
            for k in range(nc + 1):
                inter[rr, j, k] = out[j, k]
            inter_ok[rr, j] = written[j]


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _pass_cols(inter, inter_ok, ev, my, rows, result, result_ok):
    """Pass 2: every intermediate column warped vertically to its stored row positions."""
    n, cols, nc1 = inter.shape
    nc = nc1 - 1
    for j in prange(cols):
        x = np.empty(n)
        vals = np.empty((n, nc))
        ok = np.empty(n, dtype=np.uint8)
        for i in range(n):
            x[i] = inter[i, j, nc]
            ok[i] = inter_ok[i, j]
            for k in range(nc):
                vals[i, k] = inter[i, j, k]
        out = np.zeros((rows, nc))
        written = np.zeros(rows, dtype=np.uint8)
        _warp_line(x, vals, ok, ev + my, out, written)
        for i in range(rows):
            for k in range(nc):
                result[i, j, k] = out[i, k]
            result_ok[i, j] = written[i]


def _margin(k3: float, e: float, size: int) -> int:
    # A texel slides by k3·d·|e − x|/(1 + k3·d) ≤ |e − x|·k with k = k3/(1 + k3) (d = 1).
    # The margin texel at x = −M must still land left of pixel 0:  M ≥ (far + M)·k + 2.
    k = k3 / (1.0 + k3)
    far = max(abs(e), abs(e - size))
    return min(math.ceil((far * k + 2.0) / (1.0 - k)) + 1, 4 * size)


def prewarp(colour, displacement, coeffs: PrewarpCoefficients, *, wrap: bool = True):
    """Pre-warp a relief texture (two 1-D passes, occlusion-compatible order).

    Parameters
    ----------
    colour
        ``(rows, cols)`` or ``(rows, cols, C)`` float array (any channels: RGB, or the
        source UV to trace which texel lands where).
    displacement
        ``(rows, cols)`` displacement ``d ∈ [0, 1]`` (depth below the polygon, ``1 − h``).
    coeffs
        From :func:`prewarp_coefficients`.
    wrap
        Treat the texture as tiling (texels sliding in from beyond an edge come from the
        opposite edge); otherwise they are clamped copies of the edge texels.

    Returns
    -------
    image : numpy.ndarray
        float64 ``(rows, cols, C)`` (or ``(rows, cols)``) pre-warped texture.
    covered : numpy.ndarray
        bool ``(rows, cols)``: texels some warped span wrote (others keep 0).
    """
    col = np.asarray(colour, dtype=np.float64)
    squeeze = col.ndim == 2
    if squeeze:
        col = col[..., None]
    disp = as_height_array(displacement, name="displacement").astype(np.float64)
    if col.ndim != 3 or col.shape[:2] != disp.shape:
        raise InvalidParameterError(
            f"colour must be (rows, cols[, C]) matching displacement {disp.shape}, "
            f"got {np.shape(colour)}"
        )
    if disp.min() < 0.0 or disp.max() > 1.0:
        raise InvalidParameterError(
            f"displacement must lie in [0, 1], got [{disp.min():.4g}, {disp.max():.4g}]"
        )
    rows, cols = disp.shape
    if not wrap:
        # Clamp-to-edge: pad with edge copies instead of periodic margins.
        pad = max(_margin(coeffs.k3, coeffs.epipole[0] * cols, cols),
                  _margin(coeffs.k3, coeffs.epipole[1] * rows, rows))
        col_p = np.pad(col, ((pad, pad), (pad, pad), (0, 0)), mode="edge")
        disp_p = np.pad(disp, pad, mode="edge")
        k1p, k2p = coeffs.k1 * cols, coeffs.k2 * rows
        # Shift the problem into the padded frame: texel c ↔ c − pad in the original.
        shifted = PrewarpCoefficients(
            (k1p + pad * coeffs.k3) / (cols + 2 * pad),
            (k2p + pad * coeffs.k3) / (rows + 2 * pad),
            coeffs.k3,
            ((coeffs.epipole[0] * cols + pad) / (cols + 2 * pad),
             (coeffs.epipole[1] * rows + pad) / (rows + 2 * pad)),
        )
        img, ok = prewarp(col_p, disp_p, shifted, wrap=True)
        img, ok = img[pad:-pad, pad:-pad], ok[pad:-pad, pad:-pad]
        return (img[..., 0] if squeeze else img), ok
    eu = coeffs.epipole[0] * cols - 0.5
    ev = coeffs.epipole[1] * rows - 0.5
    mx = _margin(coeffs.k3, eu, cols)
    my = _margin(coeffs.k3, ev, rows)
    inter = np.zeros((rows + 2 * my, cols, col.shape[2] + 1))
    inter_ok = np.zeros((rows + 2 * my, cols), dtype=np.uint8)
    _pass_rows(
        np.ascontiguousarray(col), disp, coeffs.k1 * cols, coeffs.k2 * rows, coeffs.k3,
        eu, ev, mx, my, inter, inter_ok,
    )
    result = np.zeros((rows, cols, col.shape[2]))
    result_ok = np.zeros((rows, cols), dtype=np.uint8)
    _pass_cols(inter, inter_ok, ev, my, rows, result, result_ok)
    covered = result_ok.astype(bool)
    return (result[..., 0] if squeeze else result), covered


def sample_bilinear(image, uv, *, wrap: bool = False) -> np.ndarray:
    """GL-style bilinear sampling (texel centres at ``(i + 0.5)/n``) of ``image``
    ``(rows, cols[, C])`` at ``uv`` ``(..., 2)``; clamp-to-edge or repeat. NaN uv → NaN."""
    img = np.asarray(image, dtype=np.float64)
    squeeze = img.ndim == 2
    if squeeze:
        img = img[..., None]
    rows, cols = img.shape[:2]
    uv = np.asarray(uv, dtype=np.float64)
    bad = ~np.isfinite(uv).all(axis=-1)
    x = np.where(bad, 0.0, uv[..., 0]) * cols - 0.5
    y = np.where(bad, 0.0, uv[..., 1]) * rows - 0.5
    x0 = np.floor(x).astype(np.int64)
    y0 = np.floor(y).astype(np.int64)
    fx = (x - x0)[..., None]
    fy = (y - y0)[..., None]

    def idx(i, n):
        return np.mod(i, n) if wrap else np.clip(i, 0, n - 1)

    xa, xb, ya, yb = idx(x0, cols), idx(x0 + 1, cols), idx(y0, rows), idx(y0 + 1, rows)
    out = (img[ya, xa] * (1 - fx) + img[ya, xb] * fx) * (1 - fy) + (
        img[yb, xa] * (1 - fx) + img[yb, xb] * fx
    ) * fy
    out[bad] = np.nan
    return out[..., 0] if squeeze else out


def relief_texture_image(
    colour, displacement, quad: ReliefQuad, camera, width: int, height: int, *, wrap=True
) -> np.ndarray:
    """Render a relief-texture-mapped quad on the CPU: pre-warp, then texture-map.

    Returns a float64 ``(height, width, C)`` image (row 0 = bottom, NaN off the quad).
    ``displacement`` is normalised depth; ``quad.depth`` scales it into the scene.
    """
    coeffs = prewarp_coefficients(quad, camera.eye)
    warped, _ = prewarp(colour, displacement, coeffs, wrap=wrap)
    uv0, _, _ = quad_entry(quad, camera, width, height)
    return sample_bilinear(warped, uv0, wrap=False)


__all__ = [
    "PrewarpCoefficients",
    "prewarp",
    "prewarp_coefficients",
    "relief_texture_image",
    "sample_bilinear",
]
