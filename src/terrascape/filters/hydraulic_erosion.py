"""Particle (droplet) hydraulic erosion (beyond the theses).

After H. T. Beyer, "Implementation of a method for hydraulic erosion" (TU München, 2015):
a droplet starts at a random position with water 1, speed 1 and no sediment, and for at most
``max_steps`` steps

1. takes height ``h`` and gradient ``g`` at its position by bilinear interpolation;
2. turns: ``dir = dir · inertia − g · (1 − inertia)``, normalised (a zero direction takes a
   pre-drawn random one), and moves one cell: ``p' = p + dir``;
3. with ``Δh = h(p') − h(p)``, its capacity is
   ``c = max(−Δh, min_slope) · speed · water · capacity``;
4. uphill (``Δh > 0``) it drops ``min(Δh, sediment)`` (fills the pit behind it); if it carries
   more than ``c`` it drops ``(sediment − c) · deposition``; otherwise it erodes
   ``min((c − sediment) · erosion, −Δh)``. Deposits and erosion go to the four corners of
   the cell at ``p`` with bilinear weights (erosion never digs a corner below the height
   the droplet moves to, which keeps the map free of spikes);
5. ``speed = √max(speed² + Δh · gravity, 0)``, ``water *= 1 − evaporation``.

Where Beyer lets sediment vanish when a droplet dies or leaves the map, here the remaining
sediment is dropped at the droplet's last position: every eroded amount is deposited
somewhere, so the total height is conserved up to float round-off. Droplets run one after
another (each sees the previous ones' work) in one numba kernel; their start positions are
drawn in bulk from the seed, so the result is deterministic.
"""

from __future__ import annotations

import math

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit
from terrascape._validate import check_int, check_positive, check_range, make_rng
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap


@njit(cache=CACHE, fastmath=FASTMATH)
def _height_grad(h, x, z):  # pragma: no cover - compiled
    rows, cols = h.shape
    ix = min(int(x), cols - 2)
    iz = min(int(z), rows - 2)
    u = x - ix
    v = z - iz
    h00 = h[iz, ix]
    h10 = h[iz, ix + 1]
    h01 = h[iz + 1, ix]
    h11 = h[iz + 1, ix + 1]
    gx = (h10 - h00) * (1.0 - v) + (h11 - h01) * v
    gz = (h01 - h00) * (1.0 - u) + (h11 - h10) * u
    hh = h00 * (1 - u) * (1 - v) + h10 * u * (1 - v) + h01 * (1 - u) * v + h11 * u * v
    return hh, gx, gz


@njit(cache=CACHE, fastmath=FASTMATH)
def _deposit(h, x, z, amount):  # pragma: no cover - compiled
    rows, cols = h.shape
    ix = min(int(x), cols - 2)
    iz = min(int(z), rows - 2)
    u = x - ix
    v = z - iz
    w00 = (1 - u) * (1 - v)
    w10 = u * (1 - v)
    w01 = (1 - u) * v
    # The last weight takes the remainder so the four parts add up to ``amount`` exactly.
    a00 = amount * w00
    a10 = amount * w10
    a01 = amount * w01
    a11 = amount - a00 - a10 - a01
    h[iz, ix] += a00
    h[iz, ix + 1] += a10
    h[iz + 1, ix] += a01
    h[iz + 1, ix + 1] += a11


@njit(cache=CACHE, fastmath=FASTMATH)
def _erode(h, x, z, amount, floor_h):  # pragma: no cover - compiled
    """Remove up to ``amount`` (bilinear split), never below ``floor_h``; return the removal."""
    rows, cols = h.shape
    ix = min(int(x), cols - 2)
    iz = min(int(z), rows - 2)
    u = x - ix
    v = z - iz
    taken = 0.0
    for k in range(4):
        cz = iz + (k // 2)
        cx = ix + (k % 2)
        wu = u if (k % 2) == 1 else 1.0 - u
        wv = v if (k // 2) == 1 else 1.0 - v
        want = amount * wu * wv
        room = h[cz, cx] - floor_h
        take = min(want, room) if room > 0.0 else 0.0
        h[cz, cx] -= take
        taken += take
    return taken


@njit(cache=CACHE, fastmath=FASTMATH)
def _erode_brush(h, x, z, amount, floor_h, bz, bx, bw):  # pragma: no cover - compiled
    """Remove up to ``amount`` spread over the brush around the droplet's cell (weights
    ``bw`` sum to 1), never below ``floor_h``; return the removal."""
    rows, cols = h.shape
    iz = int(z + 0.5)
    ix = int(x + 0.5)
    # Brush samples that fall off the map give their share to none: renormalise.
    wsum = 0.0
    for k in range(bw.shape[0]):
        cz = iz + bz[k]
        cx = ix + bx[k]
        if 0 <= cz < rows and 0 <= cx < cols:
            wsum += bw[k]
    if wsum <= 0.0:
        return 0.0
    taken = 0.0
    for k in range(bw.shape[0]):
        cz = iz + bz[k]
        cx = ix + bx[k]
        if 0 <= cz < rows and 0 <= cx < cols:
            want = amount * bw[k] / wsum
            room = h[cz, cx] - floor_h
            take = min(want, room) if room > 0.0 else 0.0
            h[cz, cx] -= take
            taken += take
    return taken


@njit(cache=CACHE, fastmath=FASTMATH)
def _droplets(h, starts, ox, oz, inertia, capacity, min_slope, erosion, deposition,
              evaporation, gravity, max_steps, bz, bx, bw):  # pragma: no cover - compiled
    # ``starts`` holds absolute positions; ``h`` is the window whose sample [0, 0] is the
    # absolute (oz, ox). A droplet moves in absolute coordinates and indexes the window at
    # x − ox: subtracting a whole number from a float is exact, so a window gives the same
    # bytes as the whole map wherever the droplet stays inside it.
    rows, cols = h.shape
    xmax = cols - 1.0
    zmax = rows - 1.0
    for d in range(starts.shape[0]):
        x = starts[d, 0]
        z = starts[d, 1]
        dirx = 0.0
        dirz = 0.0
        speed = 1.0
        water = 1.0
        sediment = 0.0
        for _ in range(max_steps):
            hh, gx, gz = _height_grad(h, x - ox, z - oz)
            dirx = dirx * inertia - gx * (1.0 - inertia)
            dirz = dirz * inertia - gz * (1.0 - inertia)
            norm = math.sqrt(dirx * dirx + dirz * dirz)
            if norm == 0.0:
                ang = starts[d, 2] * 2.0 * math.pi
                dirx = math.cos(ang)
                dirz = math.sin(ang)
            else:
                dirx /= norm
                dirz /= norm
            nx = x + dirx
            nz = z + dirz
            if nx - ox < 0.0 or nx - ox > xmax or nz - oz < 0.0 or nz - oz > zmax:
                break
            nh, _gx, _gz = _height_grad(h, nx - ox, nz - oz)
            dh = nh - hh
            cap = max(-dh, min_slope) * speed * water * capacity
            if dh > 0.0 or sediment > cap:
                amount = min(dh, sediment) if dh > 0.0 else (sediment - cap) * deposition
                sediment -= amount
                _deposit(h, x - ox, z - oz, amount)
            else:
                amount = min((cap - sediment) * erosion, -dh)
                if bw.shape[0] > 1:
                    sediment += _erode_brush(h, x - ox, z - oz, amount, nh, bz, bx, bw)
                else:
                    sediment += _erode(h, x - ox, z - oz, amount, nh)
            speed = math.sqrt(max(speed * speed + dh * gravity, 0.0))
            water *= 1.0 - evaporation
            x = nx
            z = nz
        if sediment > 0.0:
            _deposit(h, x - ox, z - oz, sediment)


#: Droplets per compiled call (a few hundredths of a second each at the default 30 steps).
_CHUNK_DROPLETS = 25_000


def _brush(radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Offsets and weights ``max(0, r − distance)`` (normalised) of a round brush."""
    r = math.ceil(radius)
    oz, ox = np.mgrid[-r:r + 1, -r:r + 1]
    w = np.maximum(0.0, radius - np.hypot(oz, ox))
    keep = w > 0
    w = w[keep] / w[keep].sum()
    return oz[keep].astype(np.int64), ox[keep].astype(np.int64), w.astype(np.float64)


def _droplet_params(inertia, capacity, min_slope, erosion, deposition, evaporation, gravity,
                    max_steps, radius) -> tuple:
    """The droplet kernel's parameters, validated, with the erosion brush: shared by the whole
    map and by a world's windows so both run exactly the same droplets."""
    radius = check_range(radius, "radius", 0.0, 16.0)
    bz, bx, bw = _brush(radius) if radius >= 1.0 else (np.zeros(1, np.int64),
                                                       np.zeros(1, np.int64), np.ones(1))
    return (check_range(inertia, "inertia", 0.0, 1.0),
            check_positive(capacity, "capacity", allow_zero=True),
            check_positive(min_slope, "min_slope", allow_zero=True),
            check_range(erosion, "erosion", 0.0, 1.0),
            check_range(deposition, "deposition", 0.0, 1.0),
            check_range(evaporation, "evaporation", 0.0, 1.0),
            check_positive(gravity, "gravity", allow_zero=True),
            check_int(max_steps, "max_steps", minimum=1, maximum=100_000), bz, bx, bw)


def hydraulic_erosion(
    heightmap: Heightmap,
    *,
    droplets: int | None = None,
    seed: int | np.random.Generator | None = 0,
    inertia: float = 0.05,
    capacity: float = 4.0,
    min_slope: float = 0.01,
    erosion: float = 0.3,
    deposition: float = 0.3,
    evaporation: float = 0.01,
    gravity: float = 4.0,
    max_steps: int = 30,
    radius: float = 3.0,
) -> Heightmap:
    """Droplet hydraulic erosion (Beyer 2015); heights in the map's own units.

    Parameters
    ----------
    heightmap
        Input map (at least 2×2). Steps are one cell long; the parameters are Beyer's
        defaults, which assume heights of the order of the grid size — scale first if the
        relief is tiny.
    droplets
        Number of droplets (``>= 0``); default one per sample.
    seed
        Seed for the start positions (same seed → same bytes).
    inertia, erosion, deposition, evaporation
        Fractions in ``[0, 1]``.
    capacity, min_slope, gravity
        ``>= 0``.
    max_steps
        Lifetime of a droplet in steps (``>= 1``).
    radius
        Erosion brush radius in samples (``[0, 16]``): a droplet wears the samples within
        ``radius`` of its cell with weights ``radius − distance`` (as in the widely used
        implementation of S. Lague, 2019), which cuts smooth valleys instead of one-sample
        pits; below 1 it wears the four bilinear corners (Beyer's scheme). Deposition is
        always bilinear.

    Returns
    -------
    Heightmap
        Same shape/spacing/metadata; the total height is conserved up to float round-off.
    """
    if not isinstance(heightmap, Heightmap):
        raise InvalidParameterError(f"expected a Heightmap, got {type(heightmap).__name__}")
    if droplets is None:
        droplets = heightmap.rows * heightmap.cols
    droplets = check_int(droplets, "droplets", minimum=0, maximum=100_000_000)
    params = _droplet_params(inertia, capacity, min_slope, erosion, deposition, evaporation,
                             gravity, max_steps, radius)
    rng = make_rng(seed)
    h = heightmap.heights.astype(np.float64)
    # Droplets run one after another, so running them in chunks from Python gives the same
    # bytes (the generator yields the same start positions chunk by chunk) while a pending
    # signal (Ctrl-C, SIGTERM) is handled between chunks, within a fraction of a second, and
    # the start positions need 24 bytes per chunk droplet instead of per droplet.
    scale = np.array([heightmap.cols - 1.0, heightmap.rows - 1.0, 1.0])
    for first in range(0, droplets, _CHUNK_DROPLETS):
        starts = rng.random((min(_CHUNK_DROPLETS, droplets - first), 3)) * scale
        _droplets(h, starts, 0.0, 0.0, *params)
    return heightmap.with_heights(h.astype(np.float32))


def droplets_in_window(
    heights: np.ndarray,
    starts: np.ndarray,
    origin: tuple[int, int] = (0, 0),
    *,
    inertia: float = 0.05,
    capacity: float = 4.0,
    min_slope: float = 0.01,
    erosion: float = 0.3,
    deposition: float = 0.3,
    evaporation: float = 0.01,
    gravity: float = 4.0,
    max_steps: int = 30,
    radius: float = 3.0,
) -> None:
    """Run the droplets ``starts`` in order on the float64 window ``heights``, in place.

    ``starts`` is ``(n, 3)``: absolute column, row and the fraction of a turn a droplet
    heads to on flat ground; ``origin`` is the absolute ``(row, col)`` of ``heights[0, 0]``.
    The parameters are :func:`hydraulic_erosion`'s. A droplet that stays inside the window
    changes it exactly as it would change the whole map (a tiled world relies on it).
    """
    if not isinstance(heights, np.ndarray) or heights.dtype != np.float64 \
            or heights.ndim != 2 or min(heights.shape) < 2 or not heights.flags.c_contiguous:
        raise InvalidParameterError("heights must be a C-contiguous float64 2-D array, ≥ 2×2")
    starts = np.ascontiguousarray(starts, dtype=np.float64)
    if starts.ndim != 2 or starts.shape[1] != 3 or not np.isfinite(starts).all():
        raise InvalidParameterError("starts must be a finite (n, 3) array")
    oz, ox = (float(check_int(v, "origin", minimum=0)) for v in origin)
    rows, cols = heights.shape
    if len(starts) and (starts[:, 0].min() < ox or starts[:, 0].max() > ox + cols - 1
                        or starts[:, 1].min() < oz or starts[:, 1].max() > oz + rows - 1):
        raise InvalidParameterError("every droplet must start inside the window")
    params = _droplet_params(inertia, capacity, min_slope, erosion, deposition, evaporation,
                             gravity, max_steps, radius)
    for first in range(0, len(starts), _CHUNK_DROPLETS):
        _droplets(heights, starts[first:first + _CHUNK_DROPLETS], ox, oz, *params)

__all__ = ["droplets_in_window", "hydraulic_erosion"]
