"""Droplet erosion of a tiled world, exact: core-only starts, halo windows, four phases.

Droplets run one after another and each sees the previous ones' work, so a droplet run
cannot simply be cut into tiles. A world runs it in a fixed order that tiles exactly:

* every chunk draws its own droplets from a counter-based stream keyed by
  ``(seed, chunk row, chunk column)`` and starts them in its core only;
* a droplet moves at most ``max_steps`` cells and wears/deposits within its brush radius
  (+1 for the bilinear corner), so all its reads and writes stay within
  :func:`~terrascape.world.recipe.erosion_halo` samples of its chunk;
* the chunks are run in four phases by the parity of their (row, column): with a halo of at
  most half a chunk, the windows (chunk + halo) of one phase never overlap, so their droplets
  never meet and can run in parallel; a chunk of phase ``p`` starts from the heights the
  earlier phases left (the latest window over each sample) and stores its whole window.

The result is the untiled run of the same droplets in phase order
(:func:`droplet_reference`) bit for bit: a droplet moves in absolute coordinates and reads
the window at ``x − origin`` (an exact subtraction), and it meets every change the
untiled run would show it. The cost: four barriers instead of one, and a float64 window per
chunk (``droplet_window``, ``8 · (chunk + 2 · halo)²`` bytes) kept in the store.

References
----------
.. [1] H. T. Beyer, "Implementation of a method for hydraulic erosion", TU München, 2015.
"""

from __future__ import annotations

import numpy as np

from terrascape.filters.hydraulic_erosion import droplets_in_window

#: Mixed into the droplet streams' keys so they never repeat another stage's stream.
_STREAM = 0xD5
PHASES = 4


def phase(i: int, j: int) -> int:
    """The phase of chunk ``(i, j)``: chunks of one phase are two chunks apart."""
    return (i % 2) * 2 + (j % 2)


def _params(erosion: dict) -> dict:
    return {k: erosion[k] for k in ("inertia", "capacity", "min_slope", "erosion",
                                    "deposition", "evaporation", "gravity", "max_steps",
                                    "radius")}


def chunk_droplet_starts(recipe, i: int, j: int) -> np.ndarray:
    """Droplets of chunk ``(i, j)``: ``(n, 3)`` absolute column, row (in the chunk's core)
    and the direction's fraction of a turn; ``n = density × core samples`` (rounded)."""
    from terrascape.world.stages import chunk_bounds

    r0, r1, c0, c1 = chunk_bounds(recipe.shape, recipe.chunk, i, j)
    n = round(recipe.erosion["density"] * (r1 - r0) * (c1 - c0))
    u = np.random.default_rng([recipe.seed, i, j, _STREAM]).random((n, 3))
    # The core's last column/row may be the map's last sample: stay on the map.
    x = c0 + u[:, 0] * (min(c1, recipe.cols - 1) - c0)
    z = r0 + u[:, 1] * (min(r1, recipe.rows - 1) - r0)
    return np.stack([x, z, u[:, 2]], axis=1)


def _window_origin(recipe, i: int, j: int) -> tuple[int, int]:
    """Absolute (row, col) of the stored window's ``[0, 0]`` (may be off the map)."""
    from terrascape.world.recipe import erosion_halo

    h = erosion_halo(recipe.erosion)
    return i * recipe.chunk - h, j * recipe.chunk - h


def window_bounds(recipe, i: int, j: int) -> tuple[int, int, int, int]:
    """Rows ``a0:a1`` and columns ``b0:b1`` of chunk ``(i, j)``'s window on the map."""
    wr, wc = _window_origin(recipe, i, j)
    w = recipe.chunk + 2 * (recipe.chunk * i - wr)
    return (max(0, wr), min(recipe.rows, wr + w), max(0, wc), min(recipe.cols, wc + w))


def current_heights(group, recipe, i: int, j: int, a0: int, a1: int, b0: int, b1: int,
                    before: int) -> np.ndarray:
    """Float64 heights of ``[a0:a1, b0:b1]`` after phases ``< before``: the raw heights,
    overwritten by the windows of chunk ``(i, j)``'s neighbours in phase order."""
    from terrascape.world.store import chunk_grid

    out = np.asarray(group["height_raw"][a0:a1, b0:b1]).astype(np.float64)
    gr, gc = chunk_grid(recipe.shape, recipe.chunk)
    for p in range(before):
        for ni in range(max(0, i - 1), min(gr, i + 2)):
            for nj in range(max(0, j - 1), min(gc, j + 2)):
                if phase(ni, nj) != p:
                    continue
                n0, n1, m0, m1 = window_bounds(recipe, ni, nj)
                r0, r1, c0, c1 = max(a0, n0), min(a1, n1), max(b0, m0), min(b1, m1)
                if r0 >= r1 or c0 >= c1:
                    continue
                wr, wc = _window_origin(recipe, ni, nj)
                part = group["droplet_window"][ni, nj, r0 - wr:r1 - wr, c0 - wc:c1 - wc]
                out[r0 - a0:r1 - a0, c0 - b0:c1 - b0] = np.asarray(part)
    return out


def run_chunk(group, recipe, i: int, j: int) -> None:
    """Phase work of chunk ``(i, j)``: its droplets on its window, stored whole."""
    a0, a1, b0, b1 = window_bounds(recipe, i, j)
    h = current_heights(group, recipe, i, j, a0, a1, b0, b1, phase(i, j))
    droplets_in_window(h, chunk_droplet_starts(recipe, i, j), (a0, b0), **_params(recipe.erosion))
    wr, wc = _window_origin(recipe, i, j)
    group["droplet_window"][i, j, a0 - wr:a1 - wr, b0 - wc:b1 - wc] = h


def eroded_chunk(group, recipe, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
    """The heights of a chunk after all four phases (float32)."""
    i, j = r0 // recipe.chunk, c0 // recipe.chunk
    return current_heights(group, recipe, i, j, r0, r1, c0, c1, PHASES).astype(np.float32)


def droplet_reference(raw: np.ndarray, recipe) -> np.ndarray:
    """The untiled run: every chunk's droplets over the whole map, phase by phase (chunks
    of a phase in row-major order)."""
    from terrascape.world.store import chunk_grid

    h = np.ascontiguousarray(raw, dtype=np.float64)
    gr, gc = chunk_grid(recipe.shape, recipe.chunk)
    for p in range(PHASES):
        for i in range(gr):
            for j in range(gc):
                if phase(i, j) == p:
                    droplets_in_window(h, chunk_droplet_starts(recipe, i, j),
                                       **_params(recipe.erosion))
    return h.astype(np.float32)


__all__ = ["PHASES", "chunk_droplet_starts", "current_heights", "droplet_reference",
           "eroded_chunk", "phase", "run_chunk", "window_bounds"]
