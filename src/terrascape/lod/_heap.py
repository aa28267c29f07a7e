"""Binary max-heaps on parallel ``(key float64, id int64)`` arrays, for ROAM's queues.

numba kernels (no Python objects): the caller owns the arrays and the element count ``n``,
and every function returns the new count. The merge queue stores −priority, so both queues
are max-heaps. Equal keys are ordered by id (``tie``), which makes the pop sequence a
function of the queue's contents alone.
"""

from __future__ import annotations

from terrascape._numba import CACHE, FASTMATH, njit

# Equal keys are ordered by id (``tie = −1``: smaller id first, the split queue; ``tie = +1``:
# larger id first, the merge queue — finer diamonds of equal priority merge first). With a
# total order the pop sequence depends only on the queue's contents, never on the order the
# entries were inserted or heapified in, so the greedy loop's result is the same whatever
# order the per-frame refresh lists the leaves and diamonds in.
_TIE_S, _TIE_M = -1, 1


@njit(cache=CACHE, fastmath=FASTMATH)
def _above(k1, i1, k2, i2, tie):
    """True when entry ``(k1, i1)`` belongs above ``(k2, i2)`` in the heap."""
    return k1 > k2 or (k1 == k2 and i1 * tie > i2 * tie)


@njit(cache=CACHE, fastmath=FASTMATH)
def _sift_down(keys, ids, n, i, tie):
    k = keys[i]
    v = ids[i]
    while True:
        c = 2 * i + 1
        if c >= n:
            break
        if c + 1 < n and _above(keys[c + 1], ids[c + 1], keys[c], ids[c], tie):
            c += 1
        if not _above(keys[c], ids[c], k, v, tie):
            break
        keys[i] = keys[c]
        ids[i] = ids[c]
        i = c
    keys[i] = k
    ids[i] = v


@njit(cache=CACHE, fastmath=FASTMATH)
def _hpush(keys, ids, n, k, v, tie):
    i = n
    while i > 0:
        p = (i - 1) >> 1
        if not _above(k, v, keys[p], ids[p], tie):
            break
        keys[i] = keys[p]
        ids[i] = ids[p]
        i = p
    keys[i] = k
    ids[i] = v
    return n + 1


@njit(cache=CACHE, fastmath=FASTMATH)
def _hpop(keys, ids, n, tie):
    n -= 1
    if n > 0:
        keys[0] = keys[n]
        ids[0] = ids[n]
        _sift_down(keys, ids, n, 0, tie)
    return n


@njit(cache=CACHE, fastmath=FASTMATH)
def _heapify(keys, ids, n, tie):
    for i in range(n // 2 - 1, -1, -1):
        _sift_down(keys, ids, n, i, tie)
