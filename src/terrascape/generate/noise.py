"""Seeded, tileable gradient noise, fBm and ridged multifractal heightmaps (beyond the theses).

Gradient noise after Perlin ("Improving Noise", SIGGRAPH 2002): every integer lattice point
carries a pseudo-random unit gradient, each corner of a cell contributes ``g · (p - corner)``,
and the four contributions are blended with the quintic fade ``6t⁵ - 15t⁴ + 10t³``. The value
is 0 at every lattice point and, scaled by ``√2``, lies in ``[-1, 1]``.

The lattice is a *hash* lattice, not a permutation table: the gradient of lattice point
``(i, k)`` (any 64-bit integers) is one of 256 evenly spaced unit directions, picked by the
top 8 bits of a splitmix64 finaliser (Steele, Lea & Flood 2014) of
``i · φ64 ⊕ k · c64 ⊕ seed``. There is no ``& 255`` wrap, so the noise does not repeat every
256 cells, and a sample's value depends only on its absolute position. Generating a window
with ``origin=(x0, z0)`` therefore gives, bit for bit, the same samples as the same window of
one big run: terrain can be made tile by tile.

(This is a new noise: values differ from the permutation-table noise of earlier versions,
whose 256 gradient angles were random per seed and which repeated every 256 cells.)

Fractal sums (Musgrave, *Texturing & Modeling*, ch. 16):

* :func:`fbm` — ``Σ_o gain^o · noise(lacunarity^o · p)``, normalised by ``Σ gain^o`` so the
  result stays in ``[-1, 1]``; every octave also gets a random lattice offset, which avoids
  the octaves sharing zeros at the origin.
* :func:`ridged` — Musgrave's ridged multifractal: ``s_o = (offset - |noise|)²``, weighted by
  the previous octave's signal (``w = clamp(s · 2, 0, 1)``), giving sharp ridges and
  smooth valleys; normalised to ``[0, 1]`` by the sum of the octave amplitudes.

Coordinates: sample ``(row z, col x)`` is at noise position ``((x0 + x), (z0 + z)) / scale``
(plus the octave offset), i.e. ``scale`` is the base wavelength in samples.

Speed: along a row, every run of samples that lies in one lattice cell shares its four
gradients, so per octave and row the kernel folds the gradients of each needed lattice
column (two lattice rows) with the row's ``fz`` and fade into per-cell constants, and each
sample of a run costs three multiply-adds in float32 — a loop LLVM vectorises. Octaves whose
cells are narrower than 8 samples take one look-up pass over the row instead. Rows go in
blocks of 16 to the threads (numba ``prange``; each row written by one thread, no
reductions); within a block the hashed gradients of a lattice row are kept while the sample
rows stay in it, and all octaves of a row are summed while the row stays in cache. No fused
multiply-add contraction or reassociation is allowed, so vector and scalar code give the
same bits on every machine.

References
----------
.. [1] K. Perlin, "Improving Noise", ACM Transactions on Graphics 21(3) (SIGGRAPH 2002).
.. [2] F. K. Musgrave, "Procedural fractal terrains", in D. Ebert et al., *Texturing &
   Modeling: A Procedural Approach*, 3rd ed., Morgan Kaufmann 2003, ch. 16.
.. [3] G. L. Steele, D. Lea, C. H. Flood, "Fast splittable pseudorandom number generators",
   OOPSLA 2014 (the splitmix64 finaliser).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, prange
from terrascape._validate import check_int, check_positive, check_range, make_rng
from terrascape.errors import InvalidParameterError
from terrascape.generate._common import grid_shape, seed_meta, spacing_pair
from terrascape.heightmap import Heightmap

_DIRECTIONS = 256
_SQRT2 = math.sqrt(2.0)
_ANGLES = 2.0 * np.pi * np.arange(_DIRECTIONS) / _DIRECTIONS
# Gradients pre-scaled by sqrt 2, so the interpolated value is already in [-1, 1].
_GRAD_X = (np.cos(_ANGLES) * _SQRT2).astype(np.float32)
_GRAD_Z = (np.sin(_ANGLES) * _SQRT2).astype(np.float32)
_MAX_ORIGIN = 1 << 40
_OFFSET_RANGE = 1024.0
_RUN_MIN = 8
_BLOCK_ROWS = 16

# splitmix64 constants (φ·2⁶⁴ and the two finaliser multipliers) and a second odd multiplier
# for the lattice row.
_K_COL = np.uint64(0x9E3779B97F4A7C15)
_K_ROW = np.uint64(0xC2B2AE3D27D4EB4F)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30 = np.uint64(30)
_S27 = np.uint64(27)
_S31 = np.uint64(31)
_S56 = np.uint64(56)


@njit(cache=CACHE, fastmath=FASTMATH)
def _direction(i, k, seed):  # pragma: no cover - compiled
    """Gradient index (0..255) of lattice point (i, k): top 8 bits of splitmix64."""
    h = (np.uint64(i) * _K_COL) ^ (np.uint64(k) * _K_ROW) ^ seed
    h = (h ^ (h >> _S30)) * _M1
    h = (h ^ (h >> _S27)) * _M2
    h = h ^ (h >> _S31)
    return np.int64(h >> _S56)


@njit(cache=CACHE, fastmath=FASTMATH)
def _fade32(t):  # pragma: no cover - compiled
    return t * t * t * (t * (t * np.float32(6.0) - np.float32(15.0)) + np.float32(10.0))


def _fade_array(t: np.ndarray) -> np.ndarray:
    """The same float32 operations as :func:`_fade32`, on a float32 array."""
    return t * t * t * (t * (t * np.float32(6.0) - np.float32(15.0)) + np.float32(10.0))


@njit(cache=CACHE, fastmath=FASTMATH)
def _lattice_row(lat, k, seed, gx, gz, out_x, out_z):  # pragma: no cover - compiled
    """Gradients ``(out_x[m], out_z[m])`` of the lattice points ``(lat[m], k)``."""
    for m in range(np.uint64(lat.shape[0])):
        d = _direction(lat[m], k, seed)
        out_x[m] = gx[d]
        out_z[m] = gz[d]


@njit(cache=CACHE, fastmath=FASTMATH)
def _row_octave(acc, weight, ridged, offset, amp, fx, u, runs, col_cell, by_run, e1, e0,
                g0x, g0z, g1x, g1z, pz):  # pragma: no cover - compiled
    """Add one octave of one row to ``acc`` (fBm) or the ridged sum (``ridged``); ``g0*``
    and ``g1*`` are the gradients of the needed lattice columns on the two lattice rows.

    Loops run over unsigned indices: numba then adds no negative-index wrap-around, which
    would keep LLVM from vectorising them.
    """
    czf = math.floor(pz)
    fz = np.float32(pz - czf)
    fz1 = fz - np.float32(1.0)
    v = _fade32(fz)
    n_lat = np.uint64(g0x.shape[0])
    # Per needed lattice column: the gradients of its two lattice rows, folded with v and fz
    # into e1 (slope in fx) and e0 (value at fx = 0) of the v-interpolated corner term.
    for m in range(n_lat):
        e1[m] = g0x[m] + v * (g1x[m] - g0x[m])
        b0 = g0z[m] * fz
        e0[m] = b0 + v * (g1z[m] * fz1 - b0)
    one = np.float32(1.0)
    two = np.float32(2.0)
    zero = np.float32(0.0)
    if by_run:
        # Long runs of samples in one lattice cell: the run's four constants are scalars and
        # the inner loop is three multiply-adds per sample, vectorised.
        for r in range(np.uint64(runs.shape[1])):
            m = runs[2, r]
            a1 = e1[m]
            a0 = e0[m]
            c1 = e1[m + np.uint64(1)]
            c0 = e0[m + np.uint64(1)]
            if ridged:
                for x in range(runs[0, r], runs[1, r]):
                    left = a1 * fx[x] + a0
                    right = c1 * (fx[x] - one) + c0
                    n = left + u[x] * (right - left)
                    s = offset - abs(n)
                    s = s * s * weight[x]
                    acc[x] += amp * s
                    # Musgrave: the next octave is weighted by this signal -> detail on ridges.
                    weight[x] = min(max(s * two, zero), one)
            else:
                for x in range(runs[0, r], runs[1, r]):
                    left = a1 * fx[x] + a0
                    right = c1 * (fx[x] - one) + c0
                    acc[x] += amp * (left + u[x] * (right - left))
        return
    # Fine octaves (cells of a few samples): one pass over the row, looking the cell up.
    for x in range(np.uint64(acc.shape[0])):
        m = col_cell[x]
        left = e1[m] * fx[x] + e0[m]
        right = e1[m + np.uint64(1)] * (fx[x] - one) + e0[m + np.uint64(1)]
        n = left + u[x] * (right - left)
        if ridged:
            s = offset - abs(n)
            s = s * s * weight[x]
            acc[x] += amp * s
            weight[x] = min(max(s * two, zero), one)
        else:
            acc[x] += amp * n


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _noise_rows(out, z0, freqs, offz, seeds, amps, out_scale, ridged, offset, fx, u,
                runs, run_ofs, col_cell, by_run, lats, lat_ofs, gx, gz):
    # pragma: no cover - compiled
    rows, cols = out.shape
    octaves = freqs.shape[0]
    max_lat = 0
    for o in range(octaves):
        max_lat = max(max_lat, lat_ofs[o + 1] - lat_ofs[o])
    blocks = (rows + _BLOCK_ROWS - 1) // _BLOCK_ROWS
    # Blocks of rows, each on one thread: the rows of a block that share a lattice row reuse
    # its hashed gradient indices (one slot per lattice-row parity and octave). The values
    # do not depend on the reuse, so any block split gives the same bits.
    # Gradients are kept per lattice row (not recomputed per sample row) and per slot.
    for b in prange(blocks):
        acc = np.empty(cols, dtype=np.float32)
        weight = np.empty(cols, dtype=np.float32)
        e1 = np.empty(max_lat, dtype=np.float32)
        e0 = np.empty(max_lat, dtype=np.float32)
        grad_x = np.empty((2, lat_ofs[octaves]), dtype=np.float32)
        grad_z = np.empty((2, lat_ofs[octaves]), dtype=np.float32)
        held = np.zeros((octaves, 2), dtype=np.int64)
        valid = np.zeros((octaves, 2), dtype=np.bool_)
        for z in range(b * _BLOCK_ROWS, min(rows, (b + 1) * _BLOCK_ROWS)):
            acc[:] = 0.0
            weight[:] = 1.0
            for o in range(octaves):
                l0, l1 = lat_ofs[o], lat_ofs[o + 1]
                lat = lats[l0:l1]
                pz = np.float64(z0 + z) * freqs[o] + offz[o]
                cz = np.int64(math.floor(pz))
                for k in (cz, cz + 1):
                    slot = k & 1
                    if not valid[o, slot] or held[o, slot] != k:
                        _lattice_row(lat, k, seeds[o], gx, gz, grad_x[slot, l0:l1],
                                     grad_z[slot, l0:l1])
                        held[o, slot] = k
                        valid[o, slot] = True
                _row_octave(acc, weight, ridged, offset, amps[o], fx[o], u[o],
                            runs[:, run_ofs[o]:run_ofs[o + 1]], col_cell[o], by_run[o],
                            e1, e0, grad_x[cz & 1, l0:l1], grad_z[cz & 1, l0:l1],
                            grad_x[(cz + 1) & 1, l0:l1], grad_z[(cz + 1) & 1, l0:l1], pz)
            for x in range(cols):
                out[z, x] = acc[x] * out_scale


@njit(cache=CACHE, fastmath=FASTMATH)
def _noise_points(xs, zs, seed, gx, gz):  # pragma: no cover - compiled
    """Single-octave noise at arbitrary points, with the grid kernel's float32 arithmetic."""
    out = np.empty(xs.shape[0], dtype=np.float32)
    one = np.float32(1.0)
    for i in range(xs.shape[0]):
        cxf = math.floor(xs[i])
        czf = math.floor(zs[i])
        cx = np.int64(cxf)
        cz = np.int64(czf)
        fx = np.float32(xs[i] - cxf)
        fz = np.float32(zs[i] - czf)
        fz1 = fz - one
        u = _fade32(fx)
        v = _fade32(fz)
        d00 = _direction(cx, cz, seed)
        d01 = _direction(cx, cz + 1, seed)
        d10 = _direction(cx + 1, cz, seed)
        d11 = _direction(cx + 1, cz + 1, seed)
        a1 = gx[d00] + v * (gx[d01] - gx[d00])
        b0 = gz[d00] * fz
        a0 = b0 + v * (gz[d01] * fz1 - b0)
        c1 = gx[d10] + v * (gx[d11] - gx[d10])
        b1 = gz[d10] * fz
        c0 = b1 + v * (gz[d11] * fz1 - b1)
        left = a1 * fx + a0
        right = c1 * (fx - one) + c0
        out[i] = left + u * (right - left)
    return out


# --- set-up ------------------------------------------------------------------------------------


def _octave_tables(rng: np.random.Generator, octaves: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-octave hash seeds (uint64) and lattice offsets (float64, ``(octaves, 2)``)."""
    seeds = rng.integers(0, np.iinfo(np.uint64).max, size=octaves, dtype=np.uint64,
                         endpoint=True)
    offsets = rng.random((octaves, 2)) * _OFFSET_RANGE
    return seeds, offsets


def _column_tables(cols: int, x0: int, freqs: np.ndarray, offx: np.ndarray):
    """Per-octave column data: fx and fade (float32), runs of equal lattice cell, lattice
    columns those runs need. Everything depends only on the absolute column ``x0 + x``."""
    octaves = freqs.shape[0]
    fx = np.empty((octaves, cols), dtype=np.float32)
    u = np.empty((octaves, cols), dtype=np.float32)
    col_cell = np.empty((octaves, cols), dtype=np.uint64)
    by_run = np.empty(octaves, dtype=np.bool_)
    run_parts, lat_parts = [], []
    run_ofs = np.zeros(octaves + 1, dtype=np.int64)
    lat_ofs = np.zeros(octaves + 1, dtype=np.int64)
    absx = np.arange(x0, x0 + cols, dtype=np.int64).astype(np.float64)
    for o in range(octaves):
        px = absx * freqs[o] + offx[o]
        cellf = np.floor(px)
        cell = cellf.astype(np.int64)
        fx[o] = (px - cellf).astype(np.float32)
        u[o] = _fade_array(fx[o])
        starts = np.concatenate([[0], np.flatnonzero(np.diff(cell)) + 1])
        ends = np.concatenate([starts[1:], [cols]])
        left_cells = cell[starts]
        lat = np.unique(np.concatenate([left_cells, left_cells + 1]))
        left = np.searchsorted(lat, left_cells)
        col_cell[o] = np.searchsorted(lat, cell)
        # Runs of >= 8 samples pay for their per-run set-up; shorter ones use the look-up pass.
        by_run[o] = cols >= _RUN_MIN * starts.size
        run_parts.append(np.stack([starts, ends, left]).astype(np.uint64))
        lat_parts.append(lat)
        run_ofs[o + 1] = run_ofs[o] + starts.size
        lat_ofs[o + 1] = lat_ofs[o] + lat.size
    return (fx, u, np.concatenate(run_parts, axis=1), run_ofs, col_cell, by_run,
            np.concatenate(lat_parts), lat_ofs)


def _check_origin(origin: Sequence[int]) -> tuple[int, int]:
    try:
        x0, z0 = origin
    except (TypeError, ValueError):
        raise InvalidParameterError(
            f"origin must be (x0, z0) in samples, got {origin!r}") from None
    out = []
    for v in (x0, z0):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
            raise InvalidParameterError(
                f"origin must be whole samples (x0, z0) so tiles line up exactly, got {origin!r}")
        if abs(int(v)) > _MAX_ORIGIN:
            raise InvalidParameterError(f"origin entries must be within ±2**40, got {origin!r}")
        out.append(int(v))
    return out[0], out[1]


def _common(size_or_shape, scale, octaves, lacunarity, gain, amplitude, origin, name):
    shape = grid_shape(size_or_shape, algorithm=name)
    scale = check_positive(scale, "scale")
    octaves = check_int(octaves, "octaves", minimum=1, maximum=24)
    lacunarity = check_range(lacunarity, "lacunarity", 1.0, 16.0)
    gain = check_range(gain, "gain", 0.0, 1.0)
    amplitude = check_positive(amplitude, "amplitude", allow_zero=True)
    return shape, scale, octaves, lacunarity, gain, amplitude, _check_origin(origin)


def _run(shape, scale, octaves, lacunarity, gain, origin, seed, *, ridged_offset=None,
         amplitude=1.0):
    """Evaluate the fractal sum on the grid; float32 ``(rows, cols)``."""
    rows, cols = shape
    x0, z0 = origin
    seeds, offsets = _octave_tables(make_rng(seed), octaves)
    freqs = (1.0 / scale) * lacunarity ** np.arange(octaves, dtype=np.float64)
    amps64 = gain ** np.arange(octaves, dtype=np.float64)
    norm = float(amps64.sum())
    ridged = ridged_offset is not None
    offset = float(ridged_offset) if ridged else 0.0
    if ridged:
        norm *= offset * offset
    fx, u, runs, run_ofs, col_cell, by_run, lats, lat_ofs = _column_tables(
        cols, x0, freqs, offsets[:, 0])
    out = np.empty((rows, cols), dtype=np.float32)
    _noise_rows(out, np.int64(z0), freqs, offsets[:, 1].copy(), seeds,
                amps64.astype(np.float32), np.float32(amplitude / norm), ridged,
                np.float32(offset), fx, u, runs, run_ofs, col_cell, by_run, lats, lat_ofs,
                _GRAD_X, _GRAD_Z)
    return out


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
    origin: Sequence[int] = (0, 0),
) -> Heightmap:
    """Fractional-Brownian-motion heightmap from seeded, tileable gradient noise.

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
    origin
        ``(x0, z0)``: the absolute sample (column, row) of this map's first sample. A map at
        ``origin=(x0, z0)`` equals, bit for bit, the same window of a bigger map at
        ``(0, 0)`` with the same parameters and seed — generate tiles independently.

    Returns
    -------
    Heightmap
        float32 heights in ``[-amplitude, amplitude]``.
    """
    shape, scale, octaves, lacunarity, gain, amplitude, origin = _common(
        size_or_shape, scale, octaves, lacunarity, gain, amplitude, origin, "fbm")
    heights = _run(shape, scale, octaves, lacunarity, gain, origin, seed, amplitude=amplitude)
    meta = {"generator": "fbm", "scale": scale, "octaves": octaves, "lacunarity": lacunarity,
            "gain": gain, "origin": origin, "seed": seed_meta(seed)}
    return Heightmap(heights, spacing_pair(spacing), meta)


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
    origin: Sequence[int] = (0, 0),
) -> Heightmap:
    """Ridged multifractal heightmap (Musgrave) from seeded, tileable gradient noise.

    Parameters are those of :func:`fbm` plus ``offset`` (``[0.5, 2]``; 1 puts the ridge
    crests exactly on the noise's zero lines). Heights are ``amplitude · [0, 1]``; tiles made
    with ``origin`` match a single run bit for bit, as for :func:`fbm`.
    """
    shape, scale, octaves, lacunarity, gain, amplitude, origin = _common(
        size_or_shape, scale, octaves, lacunarity, gain, amplitude, origin, "ridged")
    offset = check_range(offset, "offset", 0.5, 2.0)
    heights = _run(shape, scale, octaves, lacunarity, gain, origin, seed,
                   ridged_offset=offset, amplitude=amplitude)
    meta = {"generator": "ridged", "scale": scale, "octaves": octaves,
            "lacunarity": lacunarity, "gain": gain, "offset": offset, "origin": origin,
            "seed": seed_meta(seed)}
    return Heightmap(heights, spacing_pair(spacing), meta)


def gradient_noise(
    x: np.ndarray, z: np.ndarray, *, seed: int | np.random.Generator | None = 0
) -> np.ndarray:
    """Single-octave gradient noise at arbitrary points (arrays of equal shape) → float32.

    It is the first octave of :func:`fbm` without the octave's lattice offset, so the value
    is exactly 0 at integer lattice points; it never repeats.
    """
    xa = np.asarray(x, dtype=np.float64)
    za = np.asarray(z, dtype=np.float64)
    if xa.shape != za.shape:
        raise InvalidParameterError(f"x and z need the same shape, got {xa.shape}, {za.shape}")
    seeds, _ = _octave_tables(make_rng(seed), 1)
    flat = _noise_points(xa.ravel(), za.ravel(), seeds[0], _GRAD_X, _GRAD_Z)
    return flat.reshape(xa.shape)


def _directions_numpy(i: np.ndarray, k: np.ndarray, seed: np.uint64) -> np.ndarray:
    h = (i.astype(np.uint64) * _K_COL) ^ (k.astype(np.uint64) * _K_ROW) ^ seed
    h = (h ^ (h >> _S30)) * _M1
    h = (h ^ (h >> _S27)) * _M2
    h = h ^ (h >> _S31)
    return (h >> _S56).astype(np.intp)


def reference_fbm(
    size_or_shape: int | Sequence[int],
    *,
    scale: float = 128.0,
    octaves: int = 6,
    lacunarity: float = 2.0,
    gain: float = 0.5,
    seed: int | np.random.Generator | None = 0,
    origin: Sequence[int] = (0, 0),
) -> np.ndarray:
    """The same fBm as :func:`fbm` (amplitude 1) written as plain whole-array numpy, four
    corner hashes per sample — the reference the tests and ``terrascape bench generate``
    compare the numba kernel with. float32 ``(rows, cols)``; agrees to float32 rounding."""
    shape, scale, octaves, lacunarity, gain, _, (x0, z0) = _common(
        size_or_shape, scale, octaves, lacunarity, gain, 1.0, origin, "fbm")
    rows, cols = shape
    seeds, offsets = _octave_tables(make_rng(seed), octaves)
    total = np.zeros(shape, dtype=np.float32)
    one = np.float32(1.0)
    absx = np.arange(x0, x0 + cols, dtype=np.int64).astype(np.float64)
    absz = np.arange(z0, z0 + rows, dtype=np.int64).astype(np.float64)
    amps = gain ** np.arange(octaves, dtype=np.float64)
    for o in range(octaves):
        freq = (1.0 / scale) * lacunarity ** float(o)
        px = absx * freq + offsets[o, 0]
        pz = absz * freq + offsets[o, 1]
        cx, cz = np.floor(px), np.floor(pz)
        fx = (px - cx).astype(np.float32)[None, :]
        fz = (pz - cz).astype(np.float32)[:, None]
        ix, iz = cx.astype(np.int64)[None, :], cz.astype(np.int64)[:, None]
        u, v = _fade_array(fx), _fade_array(fz)
        d00 = _directions_numpy(ix, iz, seeds[o])
        d01 = _directions_numpy(ix, iz + 1, seeds[o])
        d10 = _directions_numpy(ix + 1, iz, seeds[o])
        d11 = _directions_numpy(ix + 1, iz + 1, seeds[o])
        a1 = _GRAD_X[d00] + v * (_GRAD_X[d01] - _GRAD_X[d00])
        b0 = _GRAD_Z[d00] * fz
        a0 = b0 + v * (_GRAD_Z[d01] * (fz - one) - b0)
        c1 = _GRAD_X[d10] + v * (_GRAD_X[d11] - _GRAD_X[d10])
        b1 = _GRAD_Z[d10] * fz
        c0 = b1 + v * (_GRAD_Z[d11] * (fz - one) - b1)
        left = a1 * fx + a0
        right = c1 * (fx - one) + c0
        total += np.float32(amps[o]) * (left + u * (right - left))
    return total * np.float32(1.0 / amps.sum())


__all__ = ["fbm", "gradient_noise", "reference_fbm", "ridged"]
