"""Square-square subdivision (Miller 1986): diamond-square's family without its lattice artefacts.

Diamond-square keeps every point it has set and fills the gaps with means of older points,
so the points of the coarse levels stay where they were put: the first centre carries the
largest offset of the map (a spike at the centre), and the rows and columns of the coarse
lattice (multiples of 32, 64, … samples) are where the interpolation changes its stencil,
which shows as creases.

Miller's square-square subdivision replaces *all* points at every level. Each cell of the
current ``m × m`` grid gets four new points at a quarter of the way in from its corners,
weighted ``9/16`` (nearest corner), ``3/16``, ``3/16`` and ``1/16`` (the tensor product of
Chaikin's ``3/4, 1/4`` corner cutting, i.e. a quadratic B-spline refinement), plus a random
offset of the level's roughness. The new grid has ``2(m - 1)`` points per side, evenly
spaced, with no point or line that is special, so there is no spike and no crease; the
result is stationary.

Starting from a ``3 × 3`` grid of offsets of amplitude ``r_0`` (spacing ``2**n``), ``n``
levels give ``2**n + 2`` points per side, cropped to the requested ``2**n + 1``. Level
``k ≥ 1`` produces spacing ``2**(n-k)`` and uses ``r_{k-1}`` of the same roughness schedule
(:func:`~terrascape.generate.diamond_square.roughness_schedule`, Filipović 2008 §5.3.1) that
diamond-square uses for the same spacing.

References
----------
.. [1] G. S. P. Miller, "The definition and rendering of terrain maps", Computer Graphics
   (SIGGRAPH '86) 20(4), 39–48, 1986 — the square-square subdivision and its comparison
   with diamond-square's creases.
.. [2] G. Chaikin, "An algorithm for high-speed curve generation", Computer Graphics and
   Image Processing 3(4), 346–349, 1974.
"""

from __future__ import annotations

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, prange
from terrascape._validate import check_size_pow2_plus1, make_rng
from terrascape.generate._common import seed_meta, spacing_pair
from terrascape.generate.diamond_square import roughness_schedule
from terrascape.heightmap import Heightmap

#: Child samples refined per call: the uniform draws of one level are made block by block
#: (the same stream as one draw of the whole level), so they never take a map's worth.
_BLOCK_SAMPLES = 1 << 17


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _refine_rows(parent, u, r, ci0, child):  # pragma: no cover - compiled
    """Rows ``ci0 …`` of one square-square level, ``(m, m)`` → ``(2(m-1), 2(m-1))`` plus
    ``r · (2u - 1)``, written into ``child`` (which may be cropped: rows and columns past
    its shape are skipped).

    Separable: rows are blended 3/4 · near + 1/4 · far, then columns the same way, which is
    the 9/16, 3/16, 3/16, 1/16 stencil. Each child row is written by one thread."""
    m = parent.shape[0]
    cols = child.shape[1]
    n = min(u.shape[0], child.shape[0] - ci0)
    near_w = np.float32(0.75)
    far_w = np.float32(0.25)
    two_r = np.float32(2.0) * r
    for i in prange(n):
        ci = ci0 + i
        pi = ci // 2
        near = pi + ci % 2
        far = pi + 1 - ci % 2
        row = np.empty(m, dtype=np.float32)
        for j in range(m):
            row[j] = near_w * parent[near, j] + far_w * parent[far, j]
        for cj in range(cols):
            pj = cj // 2
            nc = pj + cj % 2
            fc = pj + 1 - cj % 2
            child[ci, cj] = near_w * row[nc] + far_w * row[fc] + (two_r * u[i, cj] - r)


def square_square(
    size: int,
    *,
    roughness: float = 1.0,
    decay: str = "halve",
    decay_step: float | None = None,
    hurst: float | None = None,
    seed: int | np.random.Generator | None = 0,
    spacing: float | tuple[float, float] = 1.0,
) -> Heightmap:
    """Square-square (Miller 1986) fractal heightmap of ``size × size`` samples.

    Parameters
    ----------
    size
        Side length, ``2**n + 1`` (as for diamond-square).
    roughness, decay, decay_step, hurst
        The roughness ``r_0`` (world units) and its decay law per level, exactly as for
        :func:`~terrascape.generate.diamond_square.diamond_square`.
    seed
        Seed (or numpy Generator); the same seed gives the same bytes.
    spacing
        Sample spacing ``dx`` or ``(dx, dz)`` in world units.

    Returns
    -------
    Heightmap
        float32 heights; ``metadata`` records the generator and its roughness schedule.
    """
    size = check_size_pow2_plus1(size, algorithm="square-square")
    levels = (size - 1).bit_length() - 1
    rough = roughness_schedule(roughness, decay, step=decay_step, hurst=hurst, levels=levels)
    rng = make_rng(seed)
    r0 = np.float32(rough[0])
    grid = (np.float32(2.0) * r0 * rng.random((3, 3), dtype=np.float32) - r0)
    for k in range(levels):
        full = 2 * (grid.shape[0] - 1)
        side = size if k == levels - 1 else full  # the last level is cropped to the map
        child = np.empty((side, side), dtype=np.float32)
        step = max(1, min(full // 16, _BLOCK_SAMPLES // full))  # ≤ a sixteenth of the level
        for ci0 in range(0, full, step):
            u = rng.random((min(step, full - ci0), full), dtype=np.float32)
            _refine_rows(grid, u, np.float32(rough[k]), ci0, child)
        grid = child
    meta = {
        "generator": "square_square",
        "roughness": float(roughness),
        "decay": decay,
        "seed": seed_meta(seed),
        "roughness_schedule": [float(x) for x in rough],
    }
    return Heightmap(grid, spacing_pair(spacing), meta)


__all__ = ["square_square"]
