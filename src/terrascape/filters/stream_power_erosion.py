"""Fluvial erosion by the stream-power law, solved implicitly (Braun & Willett 2013).

Rivers cut down at the rate ``∂h/∂t = U − K A^m S`` (detachment-limited stream power;
``A`` drainage area, ``S`` slope towards the receiver, ``n = 1``). With D8 receivers and a
receivers-first order (the "stack"), the implicit Euler step is exact in one sweep:

``h_i ← (h_i + U·dt + F_i · h_r) / (1 + F_i)``,  ``F_i = K·dt · a_i^m · W / L_i``

where ``h_r`` is the receiver's already updated height, ``L_i`` the distance to it, and,
so that one ``strength = K·dt`` gives the same landscape at any resolution, ``a_i`` is the
drainage area as a share of the map and slopes are measured per map width ``W``. The
step is unconditionally stable. Border samples are the base level (fixed).

The first step drains the input's closed depressions (Priority-Flood, as in
:mod:`terrascape.analysis.drainage`): each is filled by the share ``fill`` of its depth,
as lakes fill with sediment, and the rest is cut as a channel from its bottom along the
drowned valley floor to the spill point (hybrid breaching-filling,
:func:`~terrascape.analysis.drainage.breach_depressions`); the later steps deepen those
channels into valleys. Each later step keeps the surface drained — every new height is a
weighted mean of the sample's old height (plus uplift) and its receiver's new height, so
it never sinks below the receiver (the update is written as ``h_r + (h − h_r)/(1 + F)`` so
rounding cannot break that) — which lets the receivers be updated locally (steepest
strictly downward neighbour, or the previous receiver on a flat) and the stack be rebuilt
by a depth-first walk from the outlets in O(n), with no flood per step (Braun & Willett
§2). Uniform uplift keeps that property; the outlets do not uplift.

Cordonnier et al. (2016) use the same solver for large-scale terrain from an uplift map;
here it erodes an existing map (uplift 0 by default): valleys grow headward from the
border into the input's relief, ridges keep their shape.

Deposition (Yuan et al. 2019): rivers drop part of their load where they cannot carry it,
``∂h/∂t = U − K A^m S + (G/A) Q_s`` with ``Q_s = ∫_A (U − ∂h/∂t) dA`` the sediment flux
(net material eroded upstream, this sample included) and ``G`` a dimensionless deposition
coefficient (0: detachment-limited, as above). Where a river leaves steep ground its slope
term drops while its load stays, so the load settles: alluvial fans at the slope break.
The sample's own share of ``Q_s`` is implicit, the load arriving from upstream is that of
the previous step (Yuan et al. iterate the same update to convergence within a step; one
lagged update per step keeps the O(n) sweep). With ``g = G/A_i`` and ``Q_in`` the load from
the donors:

``h_i ← (h_i + U + g·Q_in/(1 + g))·(1 + g)/(1 + F + g) + h_r·F/(1 + F + g)``

— again a weighted mean of a height at or above the old one and the receiver's new height,
so the sample never sinks below its receiver. A deposit may raise a receiver above a
donor's new height; the donor is then levelled with it (a flat that keeps its receiver),
which keeps the map drained.

References
----------
.. [1] J. Braun, S. D. Willett, "A very efficient O(n), implicit and parallel method to
   solve the stream power equation governing fluvial incision and landscape evolution",
   Geomorphology 180–181 (2013) 170–179.
.. [2] G. Cordonnier, J. Braun, M.-P. Cani, B. Benes, É. Galin, A. Peytavie, É. Guérin,
   "Large Scale Terrain Generation from Tectonic Uplift and Fluvial Erosion", Computer
   Graphics Forum 35(2) (2016) 165–175.
.. [3] X. P. Yuan, J. Braun, L. Guerit, D. Rouby, G. Cordonnier, "A new efficient method
   to solve the stream power law model taking into account sediment deposition", Journal
   of Geophysical Research: Earth Surface 124(6) (2019) 1346–1365.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit
from terrascape._validate import check_int, check_positive, check_range
from terrascape.analysis.drainage import _accumulate, _carve, _routing, _steepest_neighbour
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap


@njit(cache=CACHE, fastmath=FASTMATH)
def _update_receivers(h, receivers, dist, sx, sz):  # pragma: no cover - compiled
    """Steepest strictly downward neighbour; a sample on a flat keeps its receiver."""
    rows, cols = h.shape
    dd = math.sqrt(sx * sx + sz * sz)
    for z in range(1, rows - 1):
        for x in range(1, cols - 1):
            bj, bd = _steepest_neighbour(h, z, x, sx, sz, dd)
            if bj >= 0:
                i = z * cols + x
                receivers[i] = bj
                dist[i] = bd


@njit(cache=CACHE, fastmath=FASTMATH)
def _build_stack(receivers, order):  # pragma: no cover - compiled
    """Receivers-first order by depth-first walks from the outlets (Braun & Willett §2.2)."""
    n = receivers.shape[0]
    count = np.zeros(n + 1, dtype=np.int64)
    for i in range(n):
        r = receivers[i]
        if r >= 0:
            count[r + 1] += 1
    for i in range(n):
        count[i + 1] += count[i]
    donors = np.empty(max(count[n], 1), dtype=np.int64)
    fill = count[:n].copy()
    for i in range(n):
        r = receivers[i]
        if r >= 0:
            donors[fill[r]] = i
            fill[r] += 1
    todo = np.empty(n, dtype=np.int64)
    k = 0
    for root in range(n):
        if receivers[root] >= 0:
            continue
        top = 0
        todo[0] = root
        top = 1
        while top > 0:
            top -= 1
            c = todo[top]
            order[k] = c
            k += 1
            for d in range(count[c], count[c + 1]):
                todo[top] = donors[d]
                top += 1
    return k


@njit(cache=CACHE, fastmath=FASTMATH)
def _implicit_step(h, order, receivers, coef, uplift):  # pragma: no cover - compiled
    flat = h.ravel()
    for t in range(order.shape[0]):
        i = order[t]
        r = receivers[i]
        if r < 0:
            continue
        f = coef[i]
        # Same value as (h + U + F·h_r) / (1 + F), written so that rounding can never put a
        # sample below its receiver (which would close a loop of receivers).
        hr = flat[r]
        flat[i] = hr + (flat[i] + uplift[i] - hr) / (1.0 + f)


@njit(cache=CACHE, fastmath=FASTMATH)
def _implicit_step_deposit(h, order, receivers, coef, uplift, g, qin, net):  # pragma: no cover
    """One implicit step with deposition (Yuan et al. 2019, ``n = 1``): ``g`` = G/A per
    sample, ``qin`` the load arriving from the donors (height × samples); writes each
    sample's net loss ``h + U − h'`` into ``net``."""
    flat = h.ravel()
    for t in range(order.shape[0]):
        i = order[t]
        r = receivers[i]
        if r < 0:
            net[i] = 0.0
            continue
        f = coef[i]
        gi = g[i]
        hr = flat[r]
        raised = flat[i] + uplift[i]
        top = raised + gi * qin[i] / (1.0 + gi)
        # weighted mean of `top` (>= the old height) and the receiver's new height
        new = hr + (top - hr) * (1.0 + gi) / (1.0 + f + gi)
        if new < hr:  # the receiver got a deposit above this sample: level it
            new = hr
        flat[i] = new
        net[i] = raised - new


def _uplift_map(uplift: float | np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Flat float64 uplift per sample (outlets 0), from a scalar or a map."""
    if np.ndim(uplift) == 0:
        up = np.full(shape, check_positive(uplift, "uplift", allow_zero=True))
    else:
        up = np.asarray(uplift, dtype=np.float64)
        if up.shape != shape:
            raise InvalidParameterError(f"uplift map must have shape {shape}, got {up.shape}")
        if not np.isfinite(up).all() or (up < 0).any():
            raise InvalidParameterError("uplift map must be finite and >= 0 everywhere")
        up = up.copy()
    up[0, :] = up[-1, :] = up[:, 0] = up[:, -1] = 0.0
    return up.ravel()


@dataclass(frozen=True)
class StreamPowerResult:
    """Eroded map plus the drainage it ended with.

    Attributes
    ----------
    heightmap
        The eroded map (float32).
    flow
        Drainage area in samples of the last step (float32).
    sediment_flux
        Load each sample passed on to its receiver in the last step, ``Q_s`` (world units ×
        samples, float32; zeros without deposition).
    """

    heightmap: Heightmap
    flow: np.ndarray
    sediment_flux: np.ndarray | None = None


def stream_power_erosion(
    heightmap: Heightmap,
    *,
    iterations: int = 40,
    strength: float = 2e-3,
    m: float = 0.5,
    uplift: float | np.ndarray = 0.0,
    fill: float = 0.5,
    routing_interval: int = 1,
    deposition: float = 0.0,
) -> StreamPowerResult:
    """Erode ``heightmap`` with the implicit stream-power solver.

    Parameters
    ----------
    heightmap
        Input map (at least 3×3); border samples are the base level.
    iterations
        Time steps (``>= 0``; 0 returns the drained input).
    strength
        ``K·dt`` per step, dimensionless (area as a share of the map, slope per map
        width), ``> 0``; larger cuts deeper. Unconditionally stable.
    m
        Area exponent, ``[0.1, 1]`` (``m/n = 0.5`` is typical of real rivers).
    uplift
        Uplift per step in world units (``>= 0``): a number, or a map of the input's shape
        (Cordonnier et al.: rock uplift shapes the ranges); outlets excluded. Where the
        uplift varies, new depressions are drained again by a flood.
    fill
        Share of each closed depression's depth that is filled before the rest is cut as a
        channel, ``[0, 1]`` (1 = flat lakes, 0 = pure breaching).
    routing_interval
        Recompute receivers, stack and drainage area every this many steps (``>= 1``).
        Between updates the steps reuse the last routing — still exact for the implicit
        scheme (heights never sink below their receivers), only the receivers lag the
        steepest descent by a few steps; 2–3 saves about half the time.
    deposition
        Yuan et al.'s ``G`` (``[0, 10]``): the share of the load per unit drainage area
        that settles; 0 erodes only (detachment-limited), about 1 builds fans where
        rivers leave steep ground.

    Returns
    -------
    StreamPowerResult
        Eroded map and its drainage area.
    """
    if not isinstance(heightmap, Heightmap):
        raise InvalidParameterError(f"expected a Heightmap, got {type(heightmap).__name__}")
    iterations = check_int(iterations, "iterations", minimum=0, maximum=100_000)
    strength = check_positive(strength, "strength")
    m = check_range(m, "m", 0.1, 1.0)
    up = _uplift_map(uplift, heightmap.shape)
    fill = check_range(fill, "fill", 0.0, 1.0)
    routing_interval = check_int(routing_interval, "routing_interval", minimum=1)
    deposition = check_range(deposition, "deposition", 0.0, 10.0)
    sx, sz = heightmap.spacing
    h0 = heightmap.heights.astype(np.float64)
    routing = _routing(h0, sx, sz)
    h = h0 + fill * (routing.filled - h0)
    _carve(routing.order, routing.receivers, h)
    receivers = routing.receivers.copy()
    dist = routing.distance.copy()
    order = routing.order.copy()
    n = h.size
    width = max((heightmap.cols - 1) * sx, (heightmap.rows - 1) * sz)
    ones = np.ones(n, dtype=np.float64)
    area = _accumulate(order, receivers, ones)
    floods = 1
    coef = strength * width * (area / n) ** m / dist
    net = np.zeros(n, dtype=np.float64)  # last step's net loss per sample
    qin = np.zeros(n, dtype=np.float64)
    for it in range(iterations):
        if it > 0 and it % routing_interval == 0:
            _update_receivers(h, receivers, dist, float(sx), float(sz))
            if _build_stack(receivers, order) < n:
                # A loop of receivers (possible where uplift varies): route over the
                # filled surface again.
                routing = _routing(h, sx, sz)
                h = h + fill * (routing.filled - h)
                _carve(routing.order, routing.receivers, h)
                receivers = routing.receivers.copy()
                dist = routing.distance.copy()
                order = routing.order.copy()
                floods += 1
            area = _accumulate(order, receivers, ones)
            coef = strength * width * (area / n) ** m / dist
        if deposition > 0.0:
            # the load arriving from upstream: last step's net loss summed over the donors
            qin = np.maximum(_accumulate(order, receivers, net) - net, 0.0)
            _implicit_step_deposit(h, order, receivers, coef, up, deposition / area, qin, net)
        else:
            _implicit_step(h, order, receivers, coef, up)
    flux = (np.maximum(_accumulate(order, receivers, net), 0.0) if deposition > 0.0
            else np.zeros(n))
    return StreamPowerResult(heightmap.with_heights(h.astype(np.float32)),
                             area.reshape(h.shape).astype(np.float32),
                             flux.reshape(h.shape).astype(np.float32))


__all__ = ["StreamPowerResult", "stream_power_erosion"]
