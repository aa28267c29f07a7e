"""Periodic value noise for seamless material textures and smooth band jitter.

Private helpers. Value noise on a lattice that wraps around (index ``mod period``) is exactly
periodic: sampling ``size`` pixels across ``period`` lattice cells makes pixel ``size`` equal
pixel ``0``, so column 0 continues column ``size - 1`` like any interior neighbour.
"""

from __future__ import annotations

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit


def _quintic(t: np.ndarray) -> np.ndarray:
    # Perlin's 6t^5 - 15t^4 + 10t^3: C2-continuous, so no visible lattice creases.
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


def periodic_value_noise(
    size: int, period: tuple[int, int], rng: np.random.Generator
) -> np.ndarray:
    """One octave of periodic value noise, ``(size, size)`` float64 in ``[-1, 1]``.

    ``period = (cells_x, cells_z)``: lattice cells across the image; each is clamped to
    ``[1, size]``. Anisotropic periods give stretched features (water ripples).
    """
    return value_noise_rows(value_noise_lattice(size, period, rng), size, 0, size)


def value_noise_lattice(size: int, period: tuple[int, int], rng: np.random.Generator
                        ) -> np.ndarray:
    """The random lattice ``(cells_z, cells_x)`` of one octave (the only draw from ``rng``)."""
    px = int(min(max(period[0], 1), size))
    pz = int(min(max(period[1], 1), size))
    return rng.uniform(-1.0, 1.0, size=(pz, px))


def value_noise_rows(lattice: np.ndarray, size: int, z0: int, z1: int) -> np.ndarray:
    """Rows ``z0 … z1 - 1`` of the ``size²`` periodic value noise of ``lattice``: the same
    values as those rows of the whole image, so textures can be built in blocks of rows."""
    pz, px = lattice.shape
    x = np.arange(size) * (px / size)
    z = np.arange(z0, z1) * (pz / size)
    ix0 = np.floor(x).astype(np.int64)
    iz0 = np.floor(z).astype(np.int64)
    fx = _quintic(x - ix0)[None, :]
    fz = _quintic(z - iz0)[:, None]
    ix0 %= px
    iz0 %= pz
    ix1 = (ix0 + 1) % px  # the wrap that makes the texture seamless
    iz1 = (iz0 + 1) % pz
    a = lattice[np.ix_(iz0, ix0)]
    b = lattice[np.ix_(iz0, ix1)]
    c = lattice[np.ix_(iz1, ix0)]
    d = lattice[np.ix_(iz1, ix1)]
    top = a + (b - a) * fx
    bottom = c + (d - c) * fx
    return top + (bottom - top) * fz


class PeriodicFbm:
    """Fractal sum of periodic value-noise octaves (periods doubling), scaled to ``[-1, 1]``,
    evaluated by blocks of rows. The octaves' lattices are drawn from ``rng`` when it is
    made, in octave order, so the draws do not depend on how the rows are evaluated.

    ``ridged=True`` uses ``1 - 2|n|`` per octave (sharp creases: cracks in rock).
    """

    def __init__(self, size: int, base_period: tuple[int, int], rng: np.random.Generator, *,
                 octaves: int = 4, gain: float = 0.5, ridged: bool = False) -> None:
        self.size = size
        self.gain = gain
        self.ridged = ridged
        self.lattices = [value_noise_lattice(size, (base_period[0] * 2**k,
                                                    base_period[1] * 2**k), rng)
                         for k in range(octaves)]

    def rows(self, z0: int, z1: int) -> np.ndarray:
        """Rows ``z0 … z1 - 1``, float64 ``(z1 - z0, size)``."""
        total = np.zeros((z1 - z0, self.size))
        amp = 1.0
        norm = 0.0
        for lattice in self.lattices:
            n = value_noise_rows(lattice, self.size, z0, z1)
            if self.ridged:
                n = 1.0 - 2.0 * np.abs(n)
            total += amp * n
            norm += amp
            amp *= self.gain
        return total / norm


def periodic_fbm(
    size: int,
    base_period: tuple[int, int],
    rng: np.random.Generator,
    *,
    octaves: int = 4,
    gain: float = 0.5,
    ridged: bool = False,
) -> np.ndarray:
    """Fractal sum of periodic value-noise octaves (periods doubling), scaled to ``[-1, 1]``
    (the whole ``(size, size)`` image of :class:`PeriodicFbm`).

    ``ridged=True`` uses ``1 - 2|n|`` per octave (sharp creases: cracks in rock).
    """
    return PeriodicFbm(size, base_period, rng, octaves=octaves, gain=gain,
                       ridged=ridged).rows(0, size)


# --- smooth jitter noise evaluated inside numba kernels ----------------------------------------
JITTER_CELLS = (8, 16)  # lattice cells across the map for the two jitter octaves


def jitter_lattices(n_regions: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Random lattices ``(R, g+1, g+1)`` for the two jitter octaves (values in ``[-1, 1]``)."""
    g1, g2 = JITTER_CELLS
    lat1 = rng.uniform(-1.0, 1.0, size=(n_regions, g1 + 1, g1 + 1))
    lat2 = rng.uniform(-1.0, 1.0, size=(n_regions, g2 + 1, g2 + 1))
    return lat1, lat2


@njit(cache=CACHE, fastmath=FASTMATH)
def _lattice_noise(lat, r, u, v):
    """Smooth value noise of lattice ``lat[r]`` at map fractions ``u`` (x), ``v`` (z) in [0, 1]."""
    g = lat.shape[1] - 1
    x = u * g
    y = v * g
    i = min(max(int(x), 0), g - 1)
    j = min(max(int(y), 0), g - 1)
    fx = x - i
    fy = y - j
    fx = fx * fx * (3.0 - 2.0 * fx)
    fy = fy * fy * (3.0 - 2.0 * fy)
    a = lat[r, j, i]
    b = lat[r, j, i + 1]
    c = lat[r, j + 1, i]
    d = lat[r, j + 1, i + 1]
    top = a + (b - a) * fx
    bottom = c + (d - c) * fx
    return top + (bottom - top) * fy


@njit(cache=CACHE, fastmath=FASTMATH)
def _jitter_noise(lat1, lat2, r, u, v):
    """Two-octave jitter noise in ``[-1, 1]``."""
    return (_lattice_noise(lat1, r, u, v) + 0.5 * _lattice_noise(lat2, r, u, v)) / 1.5
