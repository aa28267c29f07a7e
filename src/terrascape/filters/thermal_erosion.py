"""Thermal erosion (beyond the theses): material slides down slopes steeper than a
talus angle.

After Musgrave, Kolb & Mace, "The synthesis and rendering of eroded fractal terrains"
(SIGGRAPH 1989) in the form of Olsen, "Realtime procedural terrain generation" (2004):
for every cell and each lower neighbour ``i`` the excess over the talus is
``e_i = (h - h_i) - tan(talus) · dist_i``; if the largest excess ``E`` is positive, the cell
sends ``rate · E`` in total, split over the neighbours in proportion to ``e_i`` (``e_i > 0``).
``rate <= 0.5`` never overshoots (the pair's difference falls by at most ``E``).

All transfers of one iteration are computed from the same state (Jacobi update), so the
result does not depend on the visiting order and rows run in parallel: pass 1 stores, per
cell, the factor ``k = rate · E / Σ e``; pass 2 gives every cell
``Σ_in k_j · e_{j→cell} − Σ_out k · e_{cell→i}``, recomputing each ``e`` from the same old
heights with the same expression as the sender. Every amount leaves one cell and enters
another exactly once, and cells at the border have no outside neighbour (closed boundary),
so material is conserved up to float64 round-off (the sum changes by ~1e-16 relative per
iteration).
"""

from __future__ import annotations

import math

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, prange, stop_requested
from terrascape._stoppable import run_stoppable
from terrascape._validate import check_int, check_range
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap

_DZ8 = np.array([-1, -1, -1, 0, 0, 1, 1, 1], dtype=np.int64)
_DX8 = np.array([-1, 0, 1, -1, 1, -1, 0, 1], dtype=np.int64)
_DZ4 = np.array([-1, 0, 0, 1], dtype=np.int64)
_DX4 = np.array([0, -1, 1, 0], dtype=np.int64)
# Samples × iterations above which the run waits on a worker thread, so that Ctrl-C stops it
# at once (:func:`run_stoppable`): about 20 ms of work, against 0.1 ms for the hand-over.
_LONG_WORK = 1 << 20


@njit(cache=CACHE, fastmath=FASTMATH)
def _excess(h, z, x, zz, xx, t):  # pragma: no cover - compiled
    # One expression for sender and receiver, so both see bit-identical amounts; the
    # threshold is always the sender's (its material's talus).
    return (h[z, x] - h[zz, xx]) - t


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _thermal_run(a, b, k, iterations, dz, dx, dist, tan_map, rate,
                 stop):  # pragma: no cover - compiled
    """``iterations`` Jacobi steps ping-ponging between ``a`` and ``b``; returns the parity
    of the steps made.

    One compiled call for all iterations keeps the parallel regions back to back. Ends
    before the next iteration once ``stop[0]`` is set (:func:`run_stoppable`).
    """
    rows, cols = a.shape
    nn = dz.shape[0]
    for it in range(iterations):
        if stop_requested(stop):
            return it % 2
        src = a if it % 2 == 0 else b
        dst = b if it % 2 == 0 else a
        # Pass 1: each cell's outflow factor k = rate * E / sum(e).
        for z in prange(rows):
            for x in range(cols):
                emax = 0.0
                esum = 0.0
                for n in range(nn):
                    zz = z + dz[n]
                    xx = x + dx[n]
                    if zz < 0 or zz >= rows or xx < 0 or xx >= cols:
                        continue
                    e = _excess(src, z, x, zz, xx, tan_map[z, x] * dist[n])
                    if e > 0.0:
                        esum += e
                        if e > emax:
                            emax = e
                k[z, x] = rate * emax / esum if esum > 0.0 else 0.0
        # Pass 2: outflow along every direction, inflow from every neighbour that sends to us
        # (the opposite direction has the same length; the threshold is the sender's).
        for z in prange(rows):
            for x in range(cols):
                delta = 0.0
                kc = k[z, x]
                for n in range(nn):
                    zz = z + dz[n]
                    xx = x + dx[n]
                    if zz < 0 or zz >= rows or xx < 0 or xx >= cols:
                        continue
                    if kc > 0.0:
                        e = _excess(src, z, x, zz, xx, tan_map[z, x] * dist[n])
                        if e > 0.0:
                            delta -= kc * e
                    kn = k[zz, xx]
                    if kn > 0.0:
                        e = _excess(src, zz, xx, z, x, tan_map[zz, xx] * dist[n])
                        if e > 0.0:
                            delta += kn * e
                dst[z, x] = src[z, x] + delta
    return iterations % 2


def _thermal_f64(h: np.ndarray, iterations: int, thr: np.ndarray, rate: float,
                 dz: np.ndarray, dx: np.ndarray, tan_map: np.ndarray | None = None
                 ) -> np.ndarray:
    """float64 core (also used by tests to check conservation without float32 rounding).

    ``thr`` is ``tan(talus) · distance`` per direction for one material, or, with
    ``tan_map`` (per-sample ``tan(talus)``), the distances alone.
    """
    a = np.ascontiguousarray(h, dtype=np.float64).copy()
    b = np.empty_like(a)
    k = np.empty_like(a)
    if tan_map is None:  # one material on a unit grid: thr = tan(talus) · hypot(dx, dz)
        dist = np.hypot(dx, dz).astype(np.float64)
        tan_map = np.full(a.shape, float(thr[0]) / dist[0])
    else:
        dist = np.asarray(thr, dtype=np.float64)
    parity = run_stoppable(a.size * iterations > _LONG_WORK, _thermal_run, a, b, k,
                           iterations, dz, dx, dist,
                           np.ascontiguousarray(tan_map, dtype=np.float64), rate)
    return b if parity else a


def _tan_map(talus_angle: float | np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Per-sample tan(talus) from a scalar angle or an angle map (degrees)."""
    if np.ndim(talus_angle) == 0:
        angle = check_range(talus_angle, "talus_angle", 0.0, 89.0)
        return np.full(shape, math.tan(math.radians(angle)))
    angles = np.asarray(talus_angle, dtype=np.float64)
    if angles.shape != tuple(shape):
        raise InvalidParameterError(
            f"talus_angle map must have the heightmap's shape {tuple(shape)}, got {angles.shape}")
    if not np.isfinite(angles).all():
        raise InvalidParameterError("talus_angle map contains NaN/infinite values")
    if angles.min() < 0.0 or angles.max() > 89.0:
        raise InvalidParameterError(
            f"talus_angle map must be in [0, 89] degrees, got {angles.min():g} … {angles.max():g}")
    return np.tan(np.radians(angles))


def thermal_erosion(
    heightmap: Heightmap,
    *,
    iterations: int = 50,
    talus_angle: float | np.ndarray = 30.0,
    rate: float = 0.5,
    neighbourhood: int = 8,
) -> Heightmap:
    """Thermal (talus) erosion of a heightmap; conserves material.

    Parameters
    ----------
    heightmap
        Input map; its ``spacing`` turns the talus angle into height differences
        (``tan(angle) · distance``, diagonals ``√(dx² + dz²)``).
    iterations
        Number of Jacobi iterations (``>= 0``).
    talus_angle
        Steepest stable slope in degrees, ``[0, 89]``: one number, or a map of the input's
        shape (one angle per sample, e.g. from a hardness or material layer). Material
        leaving a sample uses that sample's angle, so amounts still balance exactly.
    rate
        Fraction of the largest excess moved per iteration, ``(0, 0.5]``.
    neighbourhood
        4 (von Neumann) or 8 (Moore).

    Returns
    -------
    Heightmap
        Same shape/spacing/metadata, float32 heights with the same total (to float32
        rounding; float64 internally).
    """
    if not isinstance(heightmap, Heightmap):
        raise InvalidParameterError(f"expected a Heightmap, got {type(heightmap).__name__}")
    iterations = check_int(iterations, "iterations", minimum=0, maximum=1_000_000)
    tan_map = _tan_map(talus_angle, heightmap.shape)
    rate = check_range(rate, "rate", 0.0, 0.5)
    if rate == 0.0:
        raise InvalidParameterError("rate must be in (0, 0.5], got 0")
    if neighbourhood not in (4, 8) or isinstance(neighbourhood, bool):
        raise InvalidParameterError(f"neighbourhood must be 4 or 8, got {neighbourhood!r}")
    dz, dx = (_DZ8, _DX8) if neighbourhood == 8 else (_DZ4, _DX4)
    sx, sz = heightmap.spacing
    dist = np.sqrt((dx * sx) ** 2 + (dz * sz) ** 2)
    out = _thermal_f64(heightmap.heights, iterations, dist, rate, dz, dx, tan_map)
    return heightmap.with_heights(out.astype(np.float32))


__all__ = ["thermal_erosion"]
