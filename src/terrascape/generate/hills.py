"""Hill ("circles") heightmaps: a sum of raised-cosine bumps (Filipović 2008 §2.4).

The thesis's pseudocode for one iteration (after Ramires Fernandes [3])::

    for every terrain point (tx, tz)
        pd = distance_to_circle_centre * 2 / circle_diameter
        if (abs(pd) <= 1.0)
            height(tx, tz) += odmak/2 + cos(pd * 3.14) * odmak/2;

i.e. a bump of height ``odmak`` (``d``) at the centre falling smoothly to 0 at the radius.
The seed notes that visiting every point for every hill is slow; here a hill only touches
the samples of its bounding box — in fact only the chord of each row that lies inside the
circle — and rows are processed in parallel (numba ``prange``), each row summing its hills
in draw order, so the result is deterministic. ``π`` is used instead of the thesis's 3.14 (which
would leave a 0.0000013·d step at the rim).

Centres are uniform over the grid (sample units), radii uniform in ``radius_range``
(samples), heights constant or uniform in a ``(min, max)`` range.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, prange
from terrascape._validate import check_int, check_positive, make_rng
from terrascape.errors import InvalidParameterError
from terrascape.generate._common import (
    accumulate_in_row_blocks,
    grid_shape,
    seed_meta,
    spacing_pair,
)
from terrascape.heightmap import Heightmap

CHUNK = 100


def default_radius_range(rows: int, cols: int) -> tuple[float, float]:
    """Default radii in samples: ``(m/64, m/16)`` of the shorter side ``m`` (at least 1, 2)."""
    m = min(rows, cols)
    return (max(1.0, m / 64.0), max(2.0, m / 16.0))


def draw_hills(
    rng: np.random.Generator,
    count: int,
    rows: int,
    cols: int,
    radius_range: tuple[float, float],
    height_range: tuple[float, float],
    margin: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Random hills in one bulk draw: ``(cx, cz, radius, height)`` float64 arrays.

    Centres are uniform over the grid widened by ``margin`` samples on every side."""
    u = rng.random((count, 4))
    cx = u[:, 0] * (cols - 1 + 2 * margin) - margin
    cz = u[:, 1] * (rows - 1 + 2 * margin) - margin
    radius = radius_range[0] + u[:, 2] * (radius_range[1] - radius_range[0])
    height = height_range[0] + u[:, 3] * (height_range[1] - height_range[0])
    return cx, cz, radius, height


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _hills_kernel(acc, z0, cx, cz, radius, height):  # pragma: no cover - compiled
    """Add the hills to the float64 accumulator ``acc`` (map rows ``z0 …``); per row only
    the in-circle chord."""
    rows, cols = acc.shape
    n = cx.shape[0]
    for zl in prange(rows):
        z = z0 + zl
        for k in range(n):
            r = radius[k]
            dz = z - cz[k]
            if dz > r or dz < -r:
                continue
            chord = math.sqrt(max(r * r - dz * dz, 0.0))
            # +-1 margin: the exact test below decides; this only bounds the loop.
            x0 = min(max(math.floor(cx[k] - chord) - 1, 0), cols)
            x1 = max(min(math.ceil(cx[k] + chord) + 1, cols - 1), -1)
            half_d = 0.5 * height[k]
            for x in range(x0, x1 + 1):
                dx = x - cx[k]
                pd = math.sqrt(dx * dx + dz * dz) / r
                if pd <= 1.0:
                    acc[zl, x] += half_d + math.cos(pd * math.pi) * half_d


def _pair(value: float | Sequence[float], name: str, *, allow_zero: bool) -> tuple[float, float]:
    if np.isscalar(value):
        v = check_positive(value, name, allow_zero=allow_zero)  # type: ignore[arg-type]
        return (v, v)
    vals = list(value)  # type: ignore[arg-type]
    if len(vals) != 2:
        raise InvalidParameterError(f"{name} must be a number or (min, max), got {value!r}")
    lo = check_positive(vals[0], f"{name} min", allow_zero=allow_zero)
    hi = check_positive(vals[1], f"{name} max", allow_zero=allow_zero)
    if lo > hi:
        raise InvalidParameterError(f"{name} needs min <= max, got ({lo}, {hi})")
    return (lo, hi)


def hills(
    size_or_shape: int | Sequence[int],
    *,
    count: int = 1000,
    radius_range: float | Sequence[float] | None = None,
    height: float | Sequence[float] = 1.0,
    seed: int | np.random.Generator | None = 0,
    spacing: float | Sequence[float] = 1.0,
    progress: Callable[[int, int], None] | None = None,
    margin: float = 0.0,
) -> Heightmap:
    """Heightmap made of ``count`` cosine hills (Filipović 2008 §2.4).

    Parameters
    ----------
    size_or_shape
        ``N`` for ``N × N`` or ``(rows, cols)``; any size.
    count
        Number of hills (``>= 1``).
    radius_range
        Radius in samples, a number or ``(min, max)`` (``> 0``); default
        :func:`default_radius_range` (1/64 to 1/16 of the shorter side).
    height
        The thesis's *odmak*: hill height in world units, a number or ``(min, max)`` (``>= 0``).
    seed
        Seed or numpy Generator; the same seed gives the same bytes.
    spacing
        Sample spacing ``dx`` or ``(dx, dz)`` in world units.
    progress
        Optional callback ``progress(done, total)`` after every chunk of hills.
    margin
        Centres are drawn over the grid widened by this many samples on every side (``>= 0``;
        the seed: 0). A margin of the largest radius lets hills cut by the border cover the
        edge as densely as the middle.

    Returns
    -------
    Heightmap
        float32 heights, ``>= 0`` (hills only add).
    """
    rows, cols = grid_shape(size_or_shape, algorithm="hills")
    count = check_int(count, "count", minimum=1, maximum=10_000_000)
    if radius_range is None:
        radius_range = default_radius_range(rows, cols)
    rr = _pair(radius_range, "radius_range", allow_zero=False)
    hr = _pair(height, "height", allow_zero=True)
    margin = check_positive(margin, "margin", allow_zero=True)
    rng = make_rng(seed)
    cx, cz, radius, hgt = draw_hills(rng, count, rows, cols, rr, hr, margin)

    def add(block: np.ndarray, z0: int, lo: int, hi: int) -> None:
        _hills_kernel(block, z0, cx[lo:hi], cz[lo:hi], radius[lo:hi], hgt[lo:hi])

    heights = accumulate_in_row_blocks((rows, cols), count, CHUNK, add, progress)
    meta = {
        "generator": "hills",
        "count": count,
        "radius_range": rr,
        "height": hr,
        "margin": margin,
        "seed": seed_meta(seed),
    }
    return Heightmap(heights, spacing_pair(spacing), meta)


__all__ = ["default_radius_range", "draw_hills", "hills"]
