"""Exact percentiles of values that are computed block by block and never held at once.

The texture passes that work in blocks of rows still need a few global order statistics
(the 90th percentile of the terrain's curvature, the 1st and 99th of a photo layer's
height). :func:`block_percentiles` finds them in two passes over the blocks with memory that
does not grow with the map: the first pass counts the values in 65536 buckets of their
float64 bit patterns (ordered like the numbers), the second keeps only the values of the
buckets that hold the ranks sought. The result is the float ``numpy.percentile`` (linear
method) returns for all the values in one array, bit for bit.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence

import numpy as np

_BUCKET_SHIFT = np.uint64(48)  # 16-bit buckets: sign, exponent and 4 mantissa bits
_SIGN = np.uint64(1 << 63)


def _order_keys(values: np.ndarray) -> np.ndarray:
    """uint64 keys that sort like the float64 ``values`` (negatives: bits inverted)."""
    bits = np.ascontiguousarray(values, dtype=np.float64).reshape(-1).view(np.uint64)
    return np.where(bits & _SIGN, ~bits, bits | _SIGN)


def _lerp(a: float, b: float, t: float) -> float:
    # numpy's own interpolation (lib/_function_base_impl._lerp): the far end for t ≥ 0.5,
    # so the result is the same float numpy.percentile gives.
    a64, b64, t64 = np.float64(a), np.float64(b), np.float64(t)
    diff = b64 - a64
    return float(b64 - diff * (1 - t64)) if t64 >= 0.5 else float(a64 + diff * t64)


def block_percentiles(blocks: Callable[[], Iterable[np.ndarray]],
                      q: Sequence[float]) -> list[float] | None:
    """``numpy.percentile(all values, q)`` of the values the blocks yield, in two passes.

    Parameters
    ----------
    blocks
        Called twice; each call returns an iterable of float arrays (any shape) that together
        are all the values, the same values both times (NaN not allowed).
    q
        Percentiles in [0, 100].

    Returns
    -------
    list of float or None
        One value per ``q``; ``None`` when the blocks hold no value.
    """
    counts = np.zeros(1 << 16, dtype=np.int64)
    n = 0
    for block in blocks():
        if block.size:
            counts += np.bincount((_order_keys(block) >> _BUCKET_SHIFT).astype(np.intp),
                                  minlength=1 << 16)
            n += block.size
    if n == 0:
        return None
    quantiles = np.true_divide(np.asarray(q, dtype=np.float64), 100)
    virtual = (n - 1) * quantiles
    below = np.floor(virtual)
    lower = np.where(virtual >= n - 1, n - 1, np.maximum(below, 0)).astype(np.int64)
    upper = np.where(virtual >= n - 1, n - 1, np.maximum(below + 1, 0)).astype(np.int64)
    gamma = virtual - below
    ends = np.cumsum(counts)
    wanted = np.unique(np.searchsorted(ends, np.r_[lower, upper], side="right"))
    kept: list[np.ndarray] = []
    for block in blocks():
        if block.size:
            flat = np.ascontiguousarray(block, dtype=np.float64).reshape(-1)
            bucket = (_order_keys(flat) >> _BUCKET_SHIFT).astype(np.intp)
            kept.append(flat[np.isin(bucket, wanted)])
    values = np.sort(np.concatenate(kept))
    starts = ends - counts
    # Kept values in the wanted buckets before each one: rank r of bucket b sits at
    # kept_before[b] + (r - starts[b]) in the sorted kept values.
    kept_before = dict(zip(wanted.tolist(),
                           np.cumsum(np.r_[0, counts[wanted[:-1]]]).tolist(), strict=True))

    def at(rank: int) -> float:
        b = int(np.searchsorted(ends, rank, side="right"))
        return float(values[kept_before[b] + rank - int(starts[b])])

    return [_lerp(at(int(lo)), at(int(hi)), float(g))
            for lo, hi, g in zip(lower, upper, gamma, strict=True)]


__all__ = ["block_percentiles"]
