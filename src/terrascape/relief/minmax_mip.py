"""Min/max mip pyramid of a bilinear height field ("maximum mipmaps", Tevs, Ihrke & Seidel
2008; quadtree displacement mapping, Drobot 2009) for an exact hierarchical relief tracer.

Level 0 has one node per *bilinear cell*: cell ``(i, j)`` spans the square between texel
centres ``(i, j)`` and ``(i + 1, j + 1)`` (wrapping), and a bilinear patch never leaves the
range of its four corner texels, so ``min``/``max`` of those corners bound the surface in
the cell exactly. Level ``k`` nodes cover ``2^k × 2^k`` cells: ``min``/``max`` of their four
children. A ray whose depth stays above a node's minimum depth across the node cannot hit
anything in it, so the tracer skips the whole node (the GLSL side is
``relief/common/heightfield.glsl``'s ``trace_minmax``).
"""

from __future__ import annotations

import numpy as np

from terrascape.errors import HeightmapSizeError
from terrascape.relief.reference import heights_to_depth


def corner_depths(depth: np.ndarray) -> np.ndarray:
    """``(n, m, 4)``: the depths of cell ``(i, j)``'s corner texels ``(i, j)``, ``(i, j+1)``,
    ``(i+1, j)``, ``(i+1, j+1)`` (x = column first), wrapping, in ``depth``'s dtype."""
    right = np.roll(depth, -1, axis=1)
    return np.stack([depth, right, np.roll(depth, -1, axis=0), np.roll(right, -1, axis=0)],
                    axis=-1)


def minmax_mip(heights) -> list[np.ndarray]:
    """Min/max depth pyramid of a square power-of-two height texture.

    Parameters
    ----------
    heights
        ``(n, n)`` heights in [0, 1], ``n`` a power of two (the texture tiles).

    Returns
    -------
    list of numpy.ndarray
        ``levels[k]`` is float32 ``(n >> k, n >> k, 2)``: channel 0 = minimum depth (the
        highest point), channel 1 = maximum depth; ``levels[-1]`` is ``(1, 1, 2)``.
    """
    depth = heights_to_depth(heights)
    n = depth.shape[0]
    if depth.shape[0] != depth.shape[1] or n & (n - 1):
        raise HeightmapSizeError(
            f"the min/max mip tracer needs a square power-of-two texture (e.g. 256×256), "
            f"got {depth.shape[1]}×{depth.shape[0]}"
        )
    corners = corner_depths(depth)
    level = np.stack([corners.min(axis=-1), corners.max(axis=-1)], axis=-1)
    levels = [level.astype(np.float32)]
    while level.shape[0] > 1:
        m = level.shape[0] // 2
        blocks = level.reshape(m, 2, m, 2, 2)
        level = np.stack(
            [blocks[..., 0].min(axis=(1, 3)), blocks[..., 1].max(axis=(1, 3))], axis=-1
        )
        levels.append(level.astype(np.float32))
    return levels


def cell_corners(heights) -> np.ndarray:
    """float32 ``(n, n, 4)``: the depths of cell ``(i, j)``'s corner texels ``(i, j)``,
    ``(i + 1, j)``, ``(i, j + 1)``, ``(i + 1, j + 1)`` (x = column first), wrapping — one
    texel holds a whole bilinear cell."""
    return corner_depths(heights_to_depth(heights)).astype(np.float32)


def packed_minmax_mip(heights) -> list[np.ndarray]:
    """The pyramid as one RGBA mip chain for a tracer that reads one texel per node.

    ``levels[0]`` is :func:`cell_corners` (the exact cell test needs the corners, and their
    minimum is the level-0 bound); ``levels[k]``, ``k >= 1``, is ``(min, max, min, max)``
    of :func:`minmax_mip` level ``k``. The minimum of the four channels is the node's
    minimum depth at every level, so the tracer's bound test does not branch on the level.
    """
    levels = minmax_mip(heights)
    packed = [cell_corners(heights)]
    packed += [np.ascontiguousarray(np.concatenate([lv, lv], axis=-1)) for lv in levels[1:]]
    return packed


__all__ = ["cell_corners", "corner_depths", "minmax_mip", "packed_minmax_mip"]
