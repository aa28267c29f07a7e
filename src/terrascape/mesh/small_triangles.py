"""Small-triangle culling: the triangles of a grid tile that can draw something in a view.

A 1025² terrain seen whole puts 2 M triangles of about 0.1 px² on a 1280×720 image. GL
rasterisation (single-sampled) samples pixel centres ``(k + 0.5, j + 0.5)`` only, so a
triangle that contains no pixel centre of the viewport produces no fragment and can be left
out without changing a pixel: first the bounding box is tested (no centre in x or in y, or
none inside the viewport), then, for boxes holding at most :data:`MAX_CENTRE_TESTS`
centres, each centre against the three edges — 78–89 % of the triangles in the views of
``terrascape bench render``.
GPUs reject them in hardware; a software rasteriser (Mesa's llvmpipe) sets up and bins
each one on its single front-end thread, which is most of a far frame.
This is the small-primitive test of Wihlidal, "Optimizing the Graphics Pipeline with
Compute" (GDC 2016), run here on the CPU cores before the draw.

The tile's triangles are taken in the band order of
:func:`terrascape.mesh.terrain_mesh.banded_grid_triangles` and the survivors keep that order
(so the vertex cache keeps working). A triangle within ``margin`` pixels of a centre is
kept (the rasteriser snaps vertices to 1/256 px), and so is one with a vertex at or behind
the eye plane (``w <= 0``), which the GL clipper handles.
"""

from __future__ import annotations

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, prange
from terrascape._validate import check_int
from terrascape.errors import InvalidParameterError
from terrascape.mesh.terrain_mesh import DEFAULT_BAND

DEFAULT_MARGIN_PX = 1.0 / 64.0
# Triangles whose box holds more pixel centres than this are kept without testing each one
# (they are no longer small; most of them cover a centre).
MAX_CENTRE_TESTS = 4


@njit(cache=CACHE, fastmath=FASTMATH)
def _edge_ok(ax, ay, bx, by, px, py, sign, margin):
    # P on the triangle's inner side of edge A->B, or within margin px of the edge line:
    # cross >= -margin·|AB|, tested without the square root
    ex, ey = bx - ax, by - ay
    cross = sign * (ex * (py - ay) - ey * (px - ax))
    return cross >= 0.0 or cross * cross <= margin * margin * (ex * ex + ey * ey)


@njit(cache=CACHE, fastmath=FASTMATH)
def _may_cover_centre(x0, y0, x1, y1, x2, y2, width, height, margin, max_tests):
    """False only if no pixel centre of the viewport lies in the triangle or within
    ``margin`` px of it."""
    kx0 = np.ceil(max(min(x0, x1, x2), 0.0) - 0.5 - margin)
    kx1 = np.floor(min(max(x0, x1, x2), width) - 0.5 + margin)
    if kx0 > kx1:
        return False
    ky0 = np.ceil(max(min(y0, y1, y2), 0.0) - 0.5 - margin)
    ky1 = np.floor(min(max(y0, y1, y2), height) - 0.5 + margin)
    if ky0 > ky1:
        return False
    if (kx1 - kx0 + 1.0) * (ky1 - ky0 + 1.0) > max_tests:
        return True  # a larger triangle: not worth testing centre by centre
    area2 = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
    if area2 == 0.0:
        return True  # degenerate: GL draws nothing, but keep the rule simple and safe
    sign = 1.0 if area2 > 0.0 else -1.0
    ky = ky0
    while ky <= ky1:
        py = ky + 0.5
        kx = kx0
        while kx <= kx1:
            px = kx + 0.5
            if (_edge_ok(x0, y0, x1, y1, px, py, sign, margin)
                    and _edge_ok(x1, y1, x2, y2, px, py, sign, margin)
                    and _edge_ok(x2, y2, x0, y0, px, py, sign, margin)):
                return True
            kx += 1.0
        ky += 1.0
    return False


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _cull_banded(positions, m, width, height, band, margin, max_tests, out, counts):
    rows, cols = positions.shape[0], positions.shape[1]
    n_bands = (rows - 1 + band - 1) // band
    per_band = 6 * band * (cols - 1)  # room for every triangle of a full band
    hw, hh = 0.5 * width, 0.5 * height
    for b in prange(n_bands):
        r0 = b * band
        r1 = min(r0 + band, rows - 1)  # quad rows r0 .. r1 - 1, vertex rows r0 .. r1
        nv = r1 - r0 + 1
        sx = np.empty((nv, cols))
        sy = np.empty((nv, cols))
        behind = np.empty((nv, cols), dtype=np.bool_)
        for i in range(nv):
            for c in range(cols):
                px = positions[r0 + i, c, 0]
                py = positions[r0 + i, c, 1]
                pz = positions[r0 + i, c, 2]
                w = m[3, 0] * px + m[3, 1] * py + m[3, 2] * pz + m[3, 3]
                behind[i, c] = w <= 0.0
                inv = 1.0 / w if w > 0.0 else 0.0
                sx[i, c] = (m[0, 0] * px + m[0, 1] * py + m[0, 2] * pz + m[0, 3]) * inv * hw + hw
                sy[i, c] = (m[1, 0] * px + m[1, 1] * py + m[1, 2] * pz + m[1, 3]) * inv * hh + hh
        k = b * per_band
        for c in range(cols - 1):
            for i in range(r1 - r0):
                i00 = (r0 + i) * cols + c
                i01 = i00 + 1
                i10 = i00 + cols
                i11 = i10 + 1
                clipped = (behind[i, c] or behind[i, c + 1] or behind[i + 1, c]
                           or behind[i + 1, c + 1])
                # triangles (i00, i10, i01) and (i01, i10, i11), as banded_grid_triangles
                if clipped or _may_cover_centre(sx[i, c], sy[i, c], sx[i + 1, c], sy[i + 1, c],
                                                sx[i, c + 1], sy[i, c + 1], width, height,
                                                margin, max_tests):
                    out[k] = i00
                    out[k + 1] = i10
                    out[k + 2] = i01
                    k += 3
                if clipped or _may_cover_centre(sx[i, c + 1], sy[i, c + 1], sx[i + 1, c],
                                                sy[i + 1, c], sx[i + 1, c + 1], sy[i + 1, c + 1],
                                                width, height, margin, max_tests):
                    out[k] = i01
                    out[k + 1] = i10
                    out[k + 2] = i11
                    k += 3
        counts[b] = k - b * per_band
    # close the gaps between bands, keeping the order
    n = 0
    for b in range(n_bands):
        start = b * per_band
        for j in range(counts[b]):
            out[n + j] = out[start + j]
        n += counts[b]
    return n


def cull_small_triangles(
    positions: np.ndarray,
    view_projection: np.ndarray,
    viewport: tuple[int, int],
    *,
    band: int = DEFAULT_BAND,
    margin: float = DEFAULT_MARGIN_PX,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """Indices of the triangles of a vertex tile that can cover a pixel centre.

    Parameters
    ----------
    positions
        ``(rows, cols, 3)`` world positions of the tile's vertices (``rows, cols >= 2``).
    view_projection
        ``(4, 4)`` clip-from-world matrix (math convention, column vectors), e.g.
        :meth:`terrascape.camera.Camera.view_projection`.
    viewport
        ``(width, height)`` of the framebuffer in pixels.
    band
        Quad rows per band of the triangle order (as :func:`banded_grid_triangles`).
    margin
        Pixels by which a triangle's box may miss a centre and still be kept (>= 0).
    out
        Optional ``uint16``/``uint32`` scratch array of at least ``6·(rows-1)·(cols-1)``.

    Returns
    -------
    numpy.ndarray
        Flat index list (3 per kept triangle) into the tile's vertices ``row·cols + col``, a
        prefix of ``out`` when given; the kept triangles in band order.
    """
    pos = np.asarray(positions)
    if pos.ndim != 3 or pos.shape[2] != 3 or min(pos.shape[:2]) < 2:
        raise InvalidParameterError(
            f"positions must be (rows, cols, 3) with rows, cols >= 2, got {pos.shape}"
        )
    if not np.issubdtype(pos.dtype, np.floating):
        raise InvalidParameterError(f"positions must be floats, got {pos.dtype}")
    m = np.asarray(view_projection, dtype=np.float64)
    if m.shape != (4, 4) or not np.isfinite(m).all():
        raise InvalidParameterError(f"view_projection must be a finite 4×4 matrix, got {m.shape}")
    try:
        width, height = (check_int(v, "viewport size", minimum=1) for v in viewport)
    except TypeError:
        raise InvalidParameterError(f"viewport must be (width, height), got {viewport!r}") from None
    band = check_int(band, "band", minimum=1)
    if not (np.isfinite(margin) and margin >= 0):
        raise InvalidParameterError(f"margin must be a finite number >= 0, got {margin!r}")
    rows, cols = pos.shape[:2]
    need = 6 * (rows - 1) * (cols - 1)
    if out is None:
        out = np.empty(need, dtype=np.uint32 if rows * cols > 1 << 16 else np.uint16)
    elif out.ndim != 1 or out.size < need or out.dtype not in (np.uint16, np.uint32):
        raise InvalidParameterError(
            f"out must be a flat uint16/uint32 array of at least {need}, got {out.shape} "
            f"{out.dtype}"
        )
    if out.dtype == np.uint16 and rows * cols > 1 << 16:
        raise InvalidParameterError(f"a {rows}×{cols} tile needs uint32 indices")
    n_bands = -(-(rows - 1) // band)
    counts = np.zeros(n_bands, dtype=np.int64)
    n = _cull_banded(pos, m, float(width), float(height), band, float(margin),
                     float(MAX_CENTRE_TESTS), out, counts)
    return out[:n]


__all__ = ["DEFAULT_MARGIN_PX", "MAX_CENTRE_TESTS", "cull_small_triangles"]
