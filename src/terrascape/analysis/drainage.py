"""Drainage measured like real terrain: depression filling, D8 flow, drainage area, the
exceedance exponent β and the share of samples in closed depressions.

* **Depression filling** — Priority-Flood (Barnes, Lehman & Mulla 2014, Algorithm 2):
  every border sample is an outlet; samples are taken from a min-heap in order of their
  filled height, and a neighbour that is not higher than the sample that reaches it is
  raised to its level. Ties of level go to the lower original height (not Barnes's FIFO pit
  queue), so flow across a lake follows its drowned valley floor. The same input always
  runs the same heap operations, so the result is deterministic.
* **Flow directions** — D8 (O'Callaghan & Mark 1984) on the filled surface: a sample drains
  to the neighbour with the steepest strictly downward slope (diagonals at their true
  distance); samples on filled flats (lakes) drain to the neighbour that flooded them,
  which leads to the spill point. Every receiver was taken from the queue before its donor,
  so the flood order is a topological order (receivers first, the "stack" of Braun &
  Willett 2013) and drainage areas accumulate in one reverse sweep.
* **Exceedance exponent** — for river networks the probability that a sample drains at
  least ``a`` cells follows ``P(A ≥ a) ~ a^−β`` over a wide range; real basins give
  β ≈ 0.43–0.5 (Rodriguez-Iturbe & Rinaldo, *Fractal River Basins*, 1997, ch. 1), an
  uncorrelated noise surface a different value. β is the least-squares slope of
  ``log P`` against ``log a`` over log-spaced ``a`` between ``a_min`` and ``a_max`` (the
  straight part: above hillslope scale, below the finite-size cut-off).
* **Depression share** — samples whose filled height exceeds the original by more than
  ``epsilon``: the area that would hold lakes (raw fBm: about a third).

References
----------
.. [1] R. Barnes, C. Lehman, D. Mulla, "Priority-flood: An optimal depression-filling and
   watershed-labeling algorithm for digital elevation models", Computers & Geosciences 62
   (2014) 117–127.
.. [2] J. F. O'Callaghan, D. M. Mark, "The extraction of drainage networks from digital
   elevation data", CVGIP 28 (1984) 323–344.
.. [3] J. Braun, S. D. Willett, "A very efficient O(n), implicit and parallel method to solve
   the stream power equation governing fluvial incision and landscape evolution",
   Geomorphology 180–181 (2013) 170–179.
.. [4] I. Rodriguez-Iturbe, A. Rinaldo, *Fractal River Basins: Chance and
   Self-Organization*, Cambridge University Press (1997).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, stop_requested
from terrascape._stoppable import run_stoppable
from terrascape._validate import as_height_array, check_positive
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap

_DZ8 = np.array([-1, -1, -1, 0, 0, 1, 1, 1], dtype=np.int64)
_DX8 = np.array([-1, 0, 1, -1, 1, -1, 0, 1], dtype=np.int64)
# Samples above which the flood runs on a worker thread, so that Ctrl-C stops it at once
# (:func:`run_stoppable`): a 512² map takes a few tens of milliseconds, a 4097² one seconds.
_LONG_SAMPLES = 1 << 18


# --- binary min-heap on (level, height) keys; sift by moving holes (no swaps) -------------
# Ties need no extra key for determinism: the same input gives the same operation sequence.
@njit(cache=CACHE, fastmath=FASTMATH)
def _heap_push(hk, hh, hv, n, key, height, val):  # pragma: no cover - compiled
    j = n
    while j > 0:
        p = (j - 1) >> 1
        if hk[p] > key or (hk[p] == key and hh[p] > height):
            hk[j] = hk[p]
            hh[j] = hh[p]
            hv[j] = hv[p]
            j = p
        else:
            break
    hk[j] = key
    hh[j] = height
    hv[j] = val
    return n + 1


@njit(cache=CACHE, fastmath=FASTMATH)
def _heap_pop(hk, hh, hv, n):  # pragma: no cover - compiled
    top = hv[0]
    n -= 1
    key = hk[n]
    height = hh[n]
    val = hv[n]
    j = 0
    while True:
        a = 2 * j + 1
        if a >= n:
            break
        b = a + 1
        if b < n and (hk[b] < hk[a] or (hk[b] == hk[a] and hh[b] < hh[a])):
            a = b
        if hk[a] < key or (hk[a] == key and hh[a] < height):
            hk[j] = hk[a]
            hh[j] = hh[a]
            hv[j] = hv[a]
            j = a
        else:
            break
    hk[j] = key
    hh[j] = height
    hv[j] = val
    return top, n


@njit(cache=CACHE, fastmath=FASTMATH, nogil=True)  # its caller waits, handling signals
def _priority_flood(h, filled, parent, order, stop):  # pragma: no cover - compiled
    """Fill ``h`` into ``filled``; ``parent`` = flat index of the sample that reached each
    sample (-1 on the border); ``order`` = samples in the order they left the heap. Returns
    how many left it: fewer than all once ``stop[0]`` is set (read every 65,536 samples;
    :func:`run_stoppable`).

    The heap key is (filled level, original height): inside a lake the front first runs
    down the original slope to the pit bottom, so the flood tree (``parent``) follows the
    drowned valley floor instead of straight breadth-first lines.
    """
    rows, cols = h.shape
    n = rows * cols
    closed = np.zeros(n, dtype=np.bool_)
    hk = np.empty(n, dtype=np.float64)
    hh = np.empty(n, dtype=np.float64)
    hv = np.empty(n, dtype=np.int64)
    # int64, not the literal 0: a literal argument makes numba compile the heap functions a
    # second time for the constant.
    size = np.int64(0)
    for z in range(rows):
        for x in range(cols):
            if z == 0 or x == 0 or z == rows - 1 or x == cols - 1:
                i = z * cols + x
                filled[z, x] = h[z, x]
                parent[i] = -1
                closed[i] = True
                size = _heap_push(hk, hh, hv, size, h[z, x], h[z, x], i)
    done = 0
    while size > 0:
        if done & 0xFFFF == 0 and stop_requested(stop):
            break
        c, size = _heap_pop(hk, hh, hv, size)
        order[done] = c
        done += 1
        cz = c // cols
        cx = c - cz * cols
        level = filled[cz, cx]
        for k in range(8):
            zz = cz + _DZ8[k]
            xx = cx + _DX8[k]
            if zz < 0 or zz >= rows or xx < 0 or xx >= cols:
                continue
            j = zz * cols + xx
            if closed[j]:
                continue
            closed[j] = True
            parent[j] = c
            lv = max(h[zz, xx], level)
            filled[zz, xx] = lv
            size = _heap_push(hk, hh, hv, size, lv, h[zz, xx], j)
    return done


@njit(cache=CACHE, fastmath=FASTMATH)
def _steepest_neighbour(h, z, x, sx, sz, dd):
    """The D8 neighbour of interior sample (z, x) with the steepest strictly downward slope:
    ``(flat index, distance)``, or ``(-1, 1.0)`` when none is lower."""
    cols = h.shape[1]
    best = 0.0
    bj = -1
    bd = 1.0
    hc = h[z, x]
    for k in range(8):
        zz = z + _DZ8[k]
        xx = x + _DX8[k]
        d = dd if (_DZ8[k] != 0 and _DX8[k] != 0) else (sx if _DZ8[k] == 0 else sz)
        s = (hc - h[zz, xx]) / d
        if s > best:
            best = s
            bj = zz * cols + xx
            bd = d
    return bj, bd


@njit(cache=CACHE, fastmath=FASTMATH)
def _d8_receivers(filled, parent, receivers, dist, sx, sz):  # pragma: no cover - compiled
    rows, cols = filled.shape
    dd = math.sqrt(sx * sx + sz * sz)
    for z in range(rows):
        for x in range(cols):
            i = z * cols + x
            if z == 0 or x == 0 or z == rows - 1 or x == cols - 1:
                receivers[i] = -1
                dist[i] = 1.0
                continue
            bj, bd = _steepest_neighbour(filled, z, x, sx, sz, dd)
            if bj < 0:  # on a filled flat: follow the flood back to the spill point
                bj = parent[i]
                pz = bj // cols
                px = bj - pz * cols
                bd = dd if (pz != z and px != x) else (sx if pz == z else sz)
            receivers[i] = bj
            dist[i] = bd


@njit(cache=CACHE, fastmath=FASTMATH)
def _accumulate(order, receivers, weights):  # pragma: no cover - compiled
    """Sum ``weights`` down the tree: donors come after receivers in ``order``."""
    acc = weights.copy()
    for t in range(order.shape[0] - 1, -1, -1):
        i = order[t]
        r = receivers[i]
        if r >= 0:
            acc[r] += acc[i]
    return acc


@njit(cache=CACHE, fastmath=FASTMATH)
def _carve(order, receivers, h):  # pragma: no cover - compiled
    """Lower every receiver to at most the lowest of its donors (donors first)."""
    flat = h.ravel()
    for t in range(order.shape[0] - 1, -1, -1):
        i = order[t]
        r = receivers[i]
        if r >= 0 and flat[r] > flat[i]:
            flat[r] = flat[i]


@dataclass(frozen=True)
class FlowRouting:
    """D8 routing over a depression-filled surface.

    Attributes
    ----------
    filled
        Depression-filled heights (float64, same shape as the input).
    receivers
        Flat index (``row * cols + col``) of each sample's receiver; ``-1`` for outlets
        (the border).
    distance
        World distance from each sample to its receiver (1 for outlets).
    order
        Flat indices with every receiver before its donors (the flood order).
    """

    filled: np.ndarray
    receivers: np.ndarray
    distance: np.ndarray
    order: np.ndarray

    def accumulate(self, weights: np.ndarray | None = None) -> np.ndarray:
        """Sum of ``weights`` (default 1 per sample) over each sample's upstream area."""
        shape = self.filled.shape
        if weights is None:
            w = np.ones(shape[0] * shape[1], dtype=np.float64)
        else:
            w = np.ascontiguousarray(weights, dtype=np.float64).ravel()
            if w.shape[0] != shape[0] * shape[1]:
                raise InvalidParameterError(
                    f"weights must have shape {shape}, got {np.shape(weights)}")
        return _accumulate(self.order, self.receivers, w).reshape(shape)


def _heights_and_spacing(surface: Heightmap | np.ndarray) -> tuple[np.ndarray, float, float]:
    if isinstance(surface, Heightmap):
        return surface.heights.astype(np.float64), surface.spacing[0], surface.spacing[1]
    if isinstance(surface, np.ndarray):
        as_height_array(surface, allow_nan=True)  # shape and dtype checks
        return np.ascontiguousarray(surface, dtype=np.float64), 1.0, 1.0
    raise InvalidParameterError(
        f"expected a Heightmap or 2-D array, got {type(surface).__name__}")


def fill_depressions(surface: Heightmap | np.ndarray) -> np.ndarray:
    """Depression-filled heights (float64): the lowest surface ≥ the input that drains to
    the border everywhere (Priority-Flood, Barnes et al. 2014)."""
    return flow_routing(surface).filled


def breach_depressions(surface: Heightmap | np.ndarray, *, fill: float = 0.5) -> np.ndarray:
    """Drain every closed depression: fill it by the share ``fill`` of its depth, then cut
    the rest as a channel along the flood path to the spill point and beyond (float64).

    ``fill=1`` is plain filling (flat lakes); ``fill=0`` pure breaching (a trench as deep as
    the pit). In between is the hybrid of Lindsay (2016, "Efficient hybrid breaching-filling
    sink removal methods for flow path enforcement in digital elevation models",
    Hydrological Processes 30, 846–857): lakes keep a floor that slopes to a cut outlet.
    Every sample then has a non-increasing path to the border along
    :func:`flow_routing`'s receivers of the input.
    """
    h, sx, sz = _heights_and_spacing(surface)
    fill = float(fill)
    if not 0.0 <= fill <= 1.0:
        raise InvalidParameterError(f"fill must be in [0, 1], got {fill!r}")
    routing = _routing(h, sx, sz)
    out = h + fill * (routing.filled - h)
    _carve(routing.order, routing.receivers, out)
    return out


def flow_routing(surface: Heightmap | np.ndarray) -> FlowRouting:
    """Priority-flood fill plus D8 receivers and a receivers-first order.

    Parameters
    ----------
    surface
        A :class:`~terrascape.heightmap.Heightmap` (its spacing sets D8 distances) or a
        2-D array (unit spacing). NaN is refused.
    """
    return _routing(*_heights_and_spacing(surface))


def _routing(h: np.ndarray, sx: float, sz: float) -> FlowRouting:
    if not np.isfinite(h).all():
        raise InvalidParameterError("heights contain NaN/infinite values; fill them first")
    rows, cols = h.shape
    filled = np.empty_like(h)
    parent = np.empty(rows * cols, dtype=np.int64)
    order = np.empty(rows * cols, dtype=np.int64)
    run_stoppable(h.size > _LONG_SAMPLES, _priority_flood, h, filled, parent, order)
    receivers = np.empty(rows * cols, dtype=np.int64)
    dist = np.empty(rows * cols, dtype=np.float64)
    _d8_receivers(filled, parent, receivers, dist, float(sx), float(sz))
    return FlowRouting(filled, receivers, dist, order)


def drainage_area(surface: Heightmap | np.ndarray) -> np.ndarray:
    """Number of samples (itself included) that drain through each sample (float64)."""
    return flow_routing(surface).accumulate()


def depression_share(surface: Heightmap | np.ndarray, *, epsilon: float | None = None) -> float:
    """Share of samples in closed depressions: filled − original > ``epsilon``.

    ``epsilon`` defaults to 1e-6 of the height range (at least 1e-9 world units), so
    float32 round-off on flats does not count as a lake.
    """
    h, _sx, _sz = _heights_and_spacing(surface)
    if epsilon is None:
        epsilon = max(1e-6 * float(h.max() - h.min()), 1e-9)
    epsilon = check_positive(epsilon, "epsilon", allow_zero=True)
    filled = fill_depressions(h)
    return float(np.count_nonzero(filled - h > epsilon)) / h.size


def exceedance(area: np.ndarray, levels: np.ndarray) -> np.ndarray:
    """``P(A ≥ a)`` for every ``a`` in ``levels`` (share of samples)."""
    a = np.sort(np.asarray(area, dtype=np.float64).ravel())
    below = np.searchsorted(a, np.asarray(levels, dtype=np.float64), side="left")
    return (a.size - below) / a.size


def exceedance_exponent(
    area: np.ndarray, *, a_min: float = 10.0, a_max: float | None = None, bins: int = 24,
) -> float:
    """β of ``P(A ≥ a) ~ a^−β``: least-squares slope over log-spaced ``a`` in
    ``[a_min, a_max]``.

    Parameters
    ----------
    area
        Drainage areas (any unit; ``a_min``/``a_max`` in the same unit).
    a_min
        Lower end of the fit: above hillslope scale (default 10 samples).
    a_max
        Upper end; default 1 % of the largest possible area (the number of samples), which
        keeps the finite-size cut-off of the biggest basins out of the fit.
    bins
        Number of log-spaced levels.
    """
    a = np.asarray(area, dtype=np.float64)
    a_min = check_positive(a_min, "a_min")
    if a_max is None:
        a_max = max(a.size / 100.0, 10.0 * a_min)
    a_max = check_positive(a_max, "a_max")
    if a_max <= a_min:
        raise InvalidParameterError(f"a_max must be > a_min, got {a_max} <= {a_min}")
    levels = np.geomspace(a_min, a_max, int(bins))
    p = exceedance(a, levels)
    keep = p > 0
    if np.count_nonzero(keep) < 3:
        raise InvalidParameterError(
            f"too few samples drain more than {a_min:g} cells to fit an exponent")
    slope = np.polyfit(np.log(levels[keep]), np.log(p[keep]), 1)[0]
    return float(-slope)


@dataclass(frozen=True)
class DrainageStatistics:
    """Summary of a surface's drainage: β, the depression share and the flow concentration."""

    beta: float
    depression_share: float
    top1_flow_share: float

    def meets_targets(self, beta_range: tuple[float, float] = (0.40, 0.55),
                      max_depression_share: float = 0.10) -> bool:
        """True when β is in ``beta_range`` and at most ``max_depression_share`` is lake."""
        return (beta_range[0] <= self.beta <= beta_range[1]
                and self.depression_share <= max_depression_share)


def drainage_statistics(surface: Heightmap | np.ndarray, *, epsilon: float | None = None
                        ) -> DrainageStatistics:
    """β (areas in samples, default fit range), depression share and the share of the total
    drainage area carried by the top 1 % of samples.

    Parameters
    ----------
    surface
        Heightmap or 2-D array.
    epsilon
        Depression threshold as in :func:`depression_share`.
    """
    h, sx, sz = _heights_and_spacing(surface)
    routing = _routing(h, sx, sz)
    if epsilon is None:
        epsilon = max(1e-6 * float(h.max() - h.min()), 1e-9)
    share = float(np.count_nonzero(routing.filled - h > epsilon)) / h.size
    area = routing.accumulate()
    flat = np.sort(area.ravel())[::-1]
    top = max(1, flat.size // 100)
    return DrainageStatistics(
        beta=exceedance_exponent(area),
        depression_share=share,
        top1_flow_share=float(flat[:top].sum() / flat.sum()),
    )


__all__ = [
    "DrainageStatistics",
    "FlowRouting",
    "breach_depressions",
    "depression_share",
    "drainage_area",
    "drainage_statistics",
    "exceedance",
    "exceedance_exponent",
    "fill_depressions",
    "flow_routing",
]
