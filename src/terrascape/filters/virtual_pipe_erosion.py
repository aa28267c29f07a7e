"""Grid hydraulic erosion with the virtual-pipe water model (Mei, Decaudin & Hu 2007;
Št'ava et al. 2008).

Every sample holds terrain ``b``, water depth ``d`` and suspended sediment ``s``, and four
outflow fluxes ``f_L, f_R, f_T, f_B`` through virtual pipes to its neighbours. One step of
length ``dt``:

1. **rain** — ``d₁ = d + dt · r``;
2. **outflow flux** — ``f ← max(0, f + dt · A · g · Δh / l)`` per pipe, with ``Δh`` the
   water-surface drop to the neighbour and pipe cross-section ``A = l²``; all four are
   scaled by ``K = min(1, d₁ · lx · ly / (Σf · dt))`` so a sample never sends more water than
   it holds;
3. **water and velocity** — ``d₂ = d₁ + dt · (Σ f_in − Σ f_out) / (lx · ly)``; the velocity is
   the mean flux through the sample divided by the mean depth and the cross-width;
4. **erosion / deposition** — capacity ``C = K_c · max(sin α, α_min) · |v| · min(d₂ /
   d_max, 1)`` (Mei's ``K_c sin α |v|`` with Št'ava's depth ramp, which keeps shallow sheet
   flow from scouring hilltops); below capacity the bed loses ``K_s · (C − s)`` to the
   water, above it the water drops ``K_d · (s − C)``;
5. **transport** — sediment moves with the water: each pipe carries the share
   ``f · dt / (d₁ · lx · ly)`` of the sample's sediment (upwind, conservative). Mei's
   semi-Lagrangian step ``s(x) ← s₁(x − v · dt)`` was tried first: on the thin sheet flow of
   rain on slopes its clamped back-trace lost about a fifth of the suspended sediment per
   step, so it was replaced by this flux form, which moves the same sediment the same way
   along channels and conserves it;
6. **evaporation** — ``d ← d₂ · (1 − K_e · dt)``.

The map border is open: water leaves through it as if the outside were dry ground at the
border sample's height, carrying its sediment with it. Every step reads only samples within
:data:`HALO_PER_ITERATION` of the one it writes, and each sample is written by exactly one
thread with no reductions, so the result is bit-identical on one or many threads, and a
window run with a halo of ``HALO_PER_ITERATION · iterations`` samples equals the same window
of the full run (tested), which lets a tiled (dask ``map_overlap``) run be exact.

Stability: the pipe model is explicit; its fastest mode (a checkerboard of water columns)
is stable for ``dt ≤ √(l / (2 g))`` (with ``A = l²``), which :func:`virtual_pipe_erosion`
enforces and reports.

References
----------
.. [1] X. Mei, P. Decaudin, B.-G. Hu, "Fast Hydraulic Erosion Simulation and Visualization
   on GPU", Pacific Graphics 2007, 47–56.
.. [2] O. Št'ava, B. Beneš, M. Brisbin, J. Křivánek, "Interactive Terrain Modeling Using
   Hydraulic Erosion", Symposium on Computer Animation 2008, 201–210.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, prange, stop_requested
from terrascape._stoppable import run_stoppable
from terrascape._validate import check_int, check_positive, check_range
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap

#: Samples one step reads on each side of the sample it writes (flux 1, water/velocity 1,
#: transport 1).
HALO_PER_ITERATION = 3

GRAVITY = 9.81
# Samples × steps above which the run waits on a worker thread, so that Ctrl-C stops it at
# once (:func:`run_stoppable`): some tens of milliseconds, against 0.1 ms for the hand-over.
_LONG_WORK = 1 << 20


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _flux(b, d, fl, fr, ft, fb, rain, dt, coef, cell_area):  # pragma: no cover - compiled
    """Steps 1–2: rain into ``d`` (in place) and the scaled outflow fluxes."""
    rows, cols = b.shape
    for z in prange(rows):
        for x in range(cols):
            d[z, x] += dt * rain[z, x]
    for z in prange(rows):
        for x in range(cols):
            w = b[z, x] + d[z, x]
            # Outside the map: dry ground at this sample's height (open border).
            wl = b[z, x] if x == 0 else b[z, x - 1] + d[z, x - 1]
            wr = b[z, x] if x == cols - 1 else b[z, x + 1] + d[z, x + 1]
            wt = b[z, x] if z == 0 else b[z - 1, x] + d[z - 1, x]
            wb = b[z, x] if z == rows - 1 else b[z + 1, x] + d[z + 1, x]
            a = max(0.0, fl[z, x] + coef * (w - wl))
            c = max(0.0, fr[z, x] + coef * (w - wr))
            e = max(0.0, ft[z, x] + coef * (w - wt))
            g = max(0.0, fb[z, x] + coef * (w - wb))
            total = (a + c + e + g) * dt
            k = 1.0
            if total > 0.0:
                k = min(1.0, d[z, x] * cell_area / total)
            fl[z, x] = a * k
            fr[z, x] = c * k
            ft[z, x] = e * k
            fb[z, x] = g * k


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _water_erode(b, d, s, fl, fr, ft, fb, d_out, s_out, vx, vz, flow, dt, sx, sz, kc,
                 min_tilt, d_max, ks, kd):  # pragma: no cover - compiled
    """Steps 3–4: new depth and velocity, then erosion/deposition into ``b``/``s_out``."""
    rows, cols = b.shape
    cell_area = sx * sz
    for z in prange(rows):
        for x in range(cols):
            fin_l = fr[z, x - 1] if x > 0 else 0.0
            fin_r = fl[z, x + 1] if x < cols - 1 else 0.0
            fin_t = fb[z - 1, x] if z > 0 else 0.0
            fin_b = ft[z + 1, x] if z < rows - 1 else 0.0
            out = fl[z, x] + fr[z, x] + ft[z, x] + fb[z, x]
            d1 = d[z, x]
            d2 = max(d1 + dt * (fin_l + fin_r + fin_t + fin_b - out) / cell_area, 0.0)
            d_out[z, x] = d2
            mean_d = 0.5 * (d1 + d2)
            qx = 0.5 * (fin_l - fl[z, x] + fr[z, x] - fin_r)
            qz = 0.5 * (fin_t - ft[z, x] + fb[z, x] - fin_b)
            flow[z, x] += dt * math.sqrt(qx * qx + qz * qz)
            u = 0.0
            v = 0.0
            if mean_d > 1e-6:
                u = qx / (sz * mean_d)
                v = qz / (sx * mean_d)
            vx[z, x] = u
            vz[z, x] = v
    for z in prange(rows):
        for x in range(cols):
            # Local tilt from central differences of the old terrain (one-sided at borders).
            x0 = max(x - 1, 0)
            x1 = min(x + 1, cols - 1)
            z0 = max(z - 1, 0)
            z1 = min(z + 1, rows - 1)
            gx = (b[z, x1] - b[z, x0]) / ((x1 - x0) * sx)
            gz = (b[z1, x] - b[z0, x]) / ((z1 - z0) * sz)
            g2 = gx * gx + gz * gz
            sin_a = math.sqrt(g2 / (1.0 + g2))
            speed = math.sqrt(vx[z, x] * vx[z, x] + vz[z, x] * vz[z, x])
            depth_ramp = min(d_out[z, x] / d_max, 1.0)
            cap = kc * max(sin_a, min_tilt) * speed * depth_ramp
            sed = s[z, x]
            if cap > sed:
                amount = ks * (cap - sed)
            else:
                amount = -kd * (sed - cap)
            s_out[z, x] = sed + amount
    # The bed change is applied after every tilt has been read from the old terrain.
    for z in prange(rows):
        for x in range(cols):
            b[z, x] -= s_out[z, x] - s[z, x]


@njit(cache=CACHE, fastmath=FASTMATH)
def _share(s1, d1, f, dt, cell_area):  # pragma: no cover - compiled
    """Sediment carried by flux ``f`` out of a sample holding ``s1`` in ``d1`` of water."""
    return s1 * min(dt * f / (d1 * cell_area), 1.0) if d1 > 0.0 else 0.0


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _transport(s1, fl, fr, ft, fb, d1, s_out, d2, dt, cell_area, evaporation):
    # pragma: no cover - compiled
    """Steps 5–6: sediment moves with the water through the same pipes, then ``d2``
    evaporates. Sender and receiver evaluate the same expression, so every amount that
    leaves one sample enters its neighbour exactly (or leaves the map)."""
    rows, cols = s1.shape
    for z in prange(rows):
        for x in range(cols):
            kept = s1[z, x]
            kept -= _share(s1[z, x], d1[z, x], fl[z, x], dt, cell_area)
            kept -= _share(s1[z, x], d1[z, x], fr[z, x], dt, cell_area)
            kept -= _share(s1[z, x], d1[z, x], ft[z, x], dt, cell_area)
            kept -= _share(s1[z, x], d1[z, x], fb[z, x], dt, cell_area)
            gain = 0.0
            if x > 0:
                gain += _share(s1[z, x - 1], d1[z, x - 1], fr[z, x - 1], dt, cell_area)
            if x < cols - 1:
                gain += _share(s1[z, x + 1], d1[z, x + 1], fl[z, x + 1], dt, cell_area)
            if z > 0:
                gain += _share(s1[z - 1, x], d1[z - 1, x], fb[z - 1, x], dt, cell_area)
            if z < rows - 1:
                gain += _share(s1[z + 1, x], d1[z + 1, x], ft[z + 1, x], dt, cell_area)
            s_out[z, x] = max(kept, 0.0) + gain
    for z in prange(rows):
        for x in range(cols):
            d2[z, x] *= 1.0 - evaporation * dt


@njit(cache=CACHE, fastmath=FASTMATH, nogil=True)  # its caller waits, handling signals
def _run(b, d, s, fl, fr, ft, fb, rain, iterations, dt, coef, sx, sz, kc, min_tilt, d_max,
         ks, kd, evaporation, flow, stop):  # pragma: no cover - compiled
    """``iterations`` time steps; ends before the next one once ``stop[0]`` is set
    (:func:`run_stoppable`)."""
    d2 = np.empty_like(d)
    s1 = np.empty_like(s)
    vx = np.empty_like(d)
    vz = np.empty_like(d)
    for _ in range(iterations):
        if stop_requested(stop):
            break
        _flux(b, d, fl, fr, ft, fb, rain, dt, coef, sx * sz)
        _water_erode(b, d, s, fl, fr, ft, fb, d2, s1, vx, vz, flow, dt, sx, sz, kc, min_tilt,
                     d_max, ks, kd)
        _transport(s1, fl, fr, ft, fb, d, s, d2, dt, sx * sz, evaporation)
        d[:, :] = d2


def stable_time_step(spacing: tuple[float, float], gravity: float = GRAVITY) -> float:
    """Largest stable ``dt`` of the explicit pipe model: ``√(l / (2 g))``, ``l`` the smaller
    spacing (pipe cross-section ``l²``)."""
    return math.sqrt(min(spacing) / (2.0 * gravity))


@dataclass(frozen=True)
class GridErosionResult:
    """Eroded map plus float32 masks of the same shape.

    Attributes
    ----------
    heightmap
        Eroded terrain (suspended sediment still in the water is dropped where it is).
    flow
        Water discharge integrated over the run (m³ per metre of width, summed ``|q| dt``).
    water
        Water depth left standing at the end (world units).
    sediment
        Suspended sediment at the end, before it was dropped (world units).
    """

    heightmap: Heightmap
    flow: np.ndarray
    water: np.ndarray
    sediment: np.ndarray


def _rain_map(rain: float | np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    if np.ndim(rain) == 0:
        return np.full(shape, check_positive(rain, "rain", allow_zero=True))
    r = np.asarray(rain, dtype=np.float64)
    if r.shape != shape:
        raise InvalidParameterError(f"rain map must have shape {shape}, got {r.shape}")
    if not np.isfinite(r).all():
        raise InvalidParameterError("rain map contains NaN/infinite values")
    if (r < 0).any():
        raise InvalidParameterError("rain must be >= 0 everywhere (negative rain in the map)")
    return np.ascontiguousarray(r)


def virtual_pipe_erosion(
    heightmap: Heightmap,
    *,
    iterations: int = 300,
    dt: float | None = None,
    rain: float | np.ndarray = 0.01,
    capacity: float = 0.05,
    min_tilt: float = 0.02,
    max_depth: float = 0.5,
    dissolving: float = 0.3,
    deposition: float = 0.3,
    evaporation: float = 0.01,
) -> GridErosionResult:
    """Hydraulic erosion on the grid with the virtual-pipe water model.

    Parameters
    ----------
    heightmap
        Input terrain in world units (spacing in the same unit, e.g. metres).
    iterations
        Time steps (``>= 0``).
    dt
        Step in seconds; default half the stable limit :func:`stable_time_step`. A larger
        value than the limit is refused.
    rain
        Rain per second in world units (``>= 0``), a number or a map of the input's shape.
    capacity
        ``K_c``: sediment carried per unit of speed and tilt (``>= 0``).
    min_tilt
        Floor of ``sin α`` in the capacity, so flat beds still carry (``[0, 1]``).
    max_depth
        Depth at which the capacity reaches its full value (``> 0``).
    dissolving, deposition
        ``K_s`` and ``K_d``: share of the capacity gap taken up / dropped per step
        (``[0, 1]``).
    evaporation
        ``K_e`` per second; ``K_e · dt`` must be below 1.

    Returns
    -------
    GridErosionResult
        Eroded map (float32) and masks.
    """
    if not isinstance(heightmap, Heightmap):
        raise InvalidParameterError(f"expected a Heightmap, got {type(heightmap).__name__}")
    iterations = check_int(iterations, "iterations", minimum=0, maximum=1_000_000)
    limit = stable_time_step(heightmap.spacing)
    if dt is None:
        dt = 0.5 * limit
    dt = check_positive(dt, "dt")
    if dt > limit:
        raise InvalidParameterError(
            f"dt {dt:g} s is above the stable limit {limit:.4g} s of the pipe model for "
            f"spacing {min(heightmap.spacing):g} (√(spacing / 2g))")
    rain_map = _rain_map(rain, heightmap.shape)
    capacity = check_positive(capacity, "capacity", allow_zero=True)
    min_tilt = check_range(min_tilt, "min_tilt", 0.0, 1.0)
    max_depth = check_positive(max_depth, "max_depth")
    dissolving = check_range(dissolving, "dissolving", 0.0, 1.0)
    deposition = check_range(deposition, "deposition", 0.0, 1.0)
    evaporation = check_positive(evaporation, "evaporation", allow_zero=True)
    if evaporation * dt >= 1.0:
        raise InvalidParameterError(
            f"evaporation × dt must be below 1 (all water gone in one step), got "
            f"{evaporation:g} × {dt:g} = {evaporation * dt:g}")
    sx, sz = (float(v) for v in heightmap.spacing)
    b = heightmap.heights.astype(np.float64)
    zeros = [np.zeros_like(b) for _ in range(7)]
    d, s, fl, fr, ft, fb, flow = zeros
    pipe_length = min(sx, sz)
    coef = dt * pipe_length * pipe_length * GRAVITY / pipe_length
    run_stoppable(b.size * iterations > _LONG_WORK, _run, b, d, s, fl, fr, ft, fb, rain_map,
                  iterations, dt, coef, sx, sz, capacity, min_tilt, max_depth, dissolving,
                  deposition, evaporation, flow)
    sediment = s.copy()
    b += s  # what the water still carries settles where it is
    return GridErosionResult(
        heightmap=heightmap.with_heights(b.astype(np.float32)),
        flow=flow.astype(np.float32),
        water=d.astype(np.float32),
        sediment=sediment.astype(np.float32),
    )


__all__ = ["HALO_PER_ITERATION", "GridErosionResult", "stable_time_step",
           "virtual_pipe_erosion"]
