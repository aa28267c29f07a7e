"""Seeded gradient noise, fBm and ridged multifractal heightmaps (MISSION H7, beyond the seeds).

Gradient noise after Perlin ("Improving Noise", SIGGRAPH 2002): a lattice with a
pseudo-random unit gradient per lattice point (hashed through a seeded permutation table),
each corner contributing ``g · (p - corner)``, blended with the quintic fade
``6t⁵ - 15t⁴ + 10t³``. The value is 0 at every lattice point and, scaled by ``√2``, lies in
``[-1, 1]``. The permutation and the 256 gradient angles come from ``make_rng(seed)``,
so the same seed gives the same bytes on every platform.

Fractal sums (Musgrave, *Texturing & Modeling*, ch. 16):

* :func:`fbm` — ``Σ_o gain^o · noise(lacunarity^o · p)``, normalised by ``Σ gain^o`` so the
  result stays in ``[-1, 1]``; every octave also gets a random lattice offset, which avoids
  the octaves sharing zeros at the origin.
* :func:`ridged` — Musgrave's ridged multifractal: ``s_o = (offset - |noise|)²``, weighted by
  the previous octave's signal (``w = clamp(s · 2, 0, 1)``), giving sharp ridges and
  smooth valleys; normalised to ``[0, 1]`` by the sum of the octave amplitudes.

Coordinates: sample ``(row z, col x)`` is at noise position ``(x, z) / scale``, i.e. ``scale``
is the base wavelength in samples.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, prange
from terrascape._validate import check_int, check_positive, check_range, make_rng
from terrascape.generate._common import grid_shape, seed_meta, spacing_pair
from terrascape.heightmap import Heightmap

_TABLE = 256
_SQRT2 = math.sqrt(2.0)


def _tables(rng: np.random.Generator, octaves: int) -> tuple[np.ndarray, ...]:
    """Permutation (doubled to 512), gradients (256 × 2) and per-octave offsets, in bulk."""
    perm = rng.permutation(_TABLE).astype(np.int64)
    angles = rng.random(_TABLE) * (2.0 * math.pi)
    grads = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    offsets = rng.random((octaves, 2)) * _TABLE
    return np.concatenate([perm, perm]), grads, offsets


@njit(cache=CACHE, fastmath=FASTMATH)
def _fade(t):  # pragma: no cover - compiled
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


@njit(cache=CACHE, fastmath=FASTMATH)
def _noise2(x, z, perm, grads):  # pragma: no cover - compiled
    """Perlin gradient noise at (x, z), in [-1, 1] (scaled by sqrt 2)."""
    xf = math.floor(x)
    zf = math.floor(z)
    fx = x - xf
    fz = z - zf
    xi = int(xf) & 255
    zi = int(zf) & 255
    a = perm[perm[xi] + zi]
    b = perm[perm[xi + 1] + zi]
    c = perm[perm[xi] + zi + 1]
    d = perm[perm[xi + 1] + zi + 1]
    n00 = grads[a, 0] * fx + grads[a, 1] * fz
    n10 = grads[b, 0] * (fx - 1.0) + grads[b, 1] * fz
    n01 = grads[c, 0] * fx + grads[c, 1] * (fz - 1.0)
    n11 = grads[d, 0] * (fx - 1.0) + grads[d, 1] * (fz - 1.0)
    u = _fade(fx)
    v = _fade(fz)
    nx0 = n00 + u * (n10 - n00)
    nx1 = n01 + u * (n11 - n01)
    return (nx0 + v * (nx1 - nx0)) * 1.4142135623730951


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _fbm_kernel(out, inv_scale, octaves, lacunarity, gain, perm, grads, offsets):
    # pragma: no cover - compiled
    rows, cols = out.shape
    norm = 0.0
    amp = 1.0
    for _ in range(octaves):
        norm += amp
        amp *= gain
    for z in prange(rows):
        for x in range(cols):
            total = 0.0
            amp = 1.0
            freq = inv_scale
            for o in range(octaves):
                total += amp * _noise2(x * freq + offsets[o, 0], z * freq + offsets[o, 1],
                                       perm, grads)
                amp *= gain
                freq *= lacunarity
            out[z, x] = total / norm


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _ridged_kernel(out, inv_scale, octaves, lacunarity, gain, offset, perm, grads, offsets):
    # pragma: no cover - compiled
    rows, cols = out.shape
    norm = 0.0
    amp = 1.0
    for _ in range(octaves):
        norm += amp
        amp *= gain
    norm *= offset * offset
    for z in prange(rows):
        for x in range(cols):
            total = 0.0
            amp = 1.0
            freq = inv_scale
            weight = 1.0
            for o in range(octaves):
                n = _noise2(x * freq + offsets[o, 0], z * freq + offsets[o, 1], perm, grads)
                s = offset - abs(n)
                s = s * s * weight
                total += amp * s
                # Musgrave: the next octave is weighted by this signal -> detail on ridges only.
                weight = min(max(s * 2.0, 0.0), 1.0)
                amp *= gain
                freq *= lacunarity
            out[z, x] = total / norm


def _common(size_or_shape, scale, octaves, lacunarity, gain, amplitude, name):
    shape = grid_shape(size_or_shape, algorithm=name)
    scale = check_positive(scale, "scale")
    octaves = check_int(octaves, "octaves", minimum=1, maximum=24)
    lacunarity = check_range(lacunarity, "lacunarity", 1.0, 16.0)
    gain = check_range(gain, "gain", 0.0, 1.0)
    amplitude = check_positive(amplitude, "amplitude", allow_zero=True)
    return shape, scale, octaves, lacunarity, gain, amplitude


def fbm(
    size_or_shape: int | Sequence[int],
    *,
    scale: float = 128.0,
    octaves: int = 6,
    lacunarity: float = 2.0,
    gain: float = 0.5,
    amplitude: float = 1.0,
    seed: int | np.random.Generator | None = 0,
    spacing: float | Sequence[float] = 1.0,
) -> Heightmap:
    """Fractional-Brownian-motion heightmap from seeded gradient noise.

    Parameters
    ----------
    size_or_shape
        ``N`` or ``(rows, cols)``.
    scale
        Wavelength of the first octave in samples (``> 0``).
    octaves
        Number of octaves (1–24); 1 gives plain gradient noise.
    lacunarity
        Frequency ratio between octaves (``[1, 16]``).
    gain
        Amplitude ratio between octaves (``[0, 1]``; ``0.5`` ≈ Hurst exponent 1).
    amplitude
        Heights are ``amplitude · [-1, 1]`` (world units).
    seed, spacing
        As for every generator.

    Returns
    -------
    Heightmap
        float32 heights in ``[-amplitude, amplitude]``.
    """
    shape, scale, octaves, lacunarity, gain, amplitude = _common(
        size_or_shape, scale, octaves, lacunarity, gain, amplitude, "fbm")
    perm, grads, offsets = _tables(make_rng(seed), octaves)
    out = np.empty(shape, dtype=np.float64)
    _fbm_kernel(out, 1.0 / scale, octaves, lacunarity, gain, perm, grads, offsets)
    meta = {"generator": "fbm", "scale": scale, "octaves": octaves, "lacunarity": lacunarity,
            "gain": gain, "seed": seed_meta(seed)}
    return Heightmap((out * amplitude).astype(np.float32), spacing_pair(spacing), meta)


def ridged(
    size_or_shape: int | Sequence[int],
    *,
    scale: float = 128.0,
    octaves: int = 6,
    lacunarity: float = 2.0,
    gain: float = 0.5,
    offset: float = 1.0,
    amplitude: float = 1.0,
    seed: int | np.random.Generator | None = 0,
    spacing: float | Sequence[float] = 1.0,
) -> Heightmap:
    """Ridged multifractal heightmap (Musgrave) from seeded gradient noise.

    Parameters are those of :func:`fbm` plus ``offset`` (``[0.5, 2]``; 1 puts the ridge
    crests exactly on the noise's zero lines). Heights are ``amplitude · [0, 1]``.
    """
    shape, scale, octaves, lacunarity, gain, amplitude = _common(
        size_or_shape, scale, octaves, lacunarity, gain, amplitude, "ridged")
    offset = check_range(offset, "offset", 0.5, 2.0)
    perm, grads, offsets = _tables(make_rng(seed), octaves)
    out = np.empty(shape, dtype=np.float64)
    _ridged_kernel(out, 1.0 / scale, octaves, lacunarity, gain, offset, perm, grads, offsets)
    meta = {"generator": "ridged", "scale": scale, "octaves": octaves,
            "lacunarity": lacunarity, "gain": gain, "offset": offset, "seed": seed_meta(seed)}
    return Heightmap((out * amplitude).astype(np.float32), spacing_pair(spacing), meta)


def gradient_noise(
    x: np.ndarray, z: np.ndarray, *, seed: int | np.random.Generator | None = 0
) -> np.ndarray:
    """Single-octave gradient noise at arbitrary points (float64 arrays of equal shape).

    No octave offset is applied, so the value is exactly 0 at integer lattice points.
    """
    xa = np.asarray(x, dtype=np.float64)
    za = np.asarray(z, dtype=np.float64)
    if xa.shape != za.shape:
        from terrascape.errors import InvalidParameterError

        raise InvalidParameterError(f"x and z need the same shape, got {xa.shape}, {za.shape}")
    perm, grads, _ = _tables(make_rng(seed), 1)
    flat = _noise_points(xa.ravel(), za.ravel(), perm, grads)
    return flat.reshape(xa.shape)


@njit(cache=CACHE, fastmath=FASTMATH)
def _noise_points(xs, zs, perm, grads):  # pragma: no cover - compiled
    out = np.empty(xs.shape[0])
    for i in range(xs.shape[0]):
        out[i] = _noise2(xs[i], zs[i], perm, grads)
    return out


__all__ = ["fbm", "gradient_noise", "ridged"]
