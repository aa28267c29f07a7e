"""Record sets for ROAM: dense per-element records found through an open-addressing hash
table (linear probing, backward-shift deletion), so a record is added, replaced and removed
in O(1) and a per-frame pass reads only the records, never the bintree.

A record set is the tuple ``(ids, co, fl, ht, keys)`` described below; :func:`_alloc_records`
makes one and :func:`_grow_records` enlarges it. What the float values ``fl`` mean (leaf or
diamond) is the caller's (:mod:`terrascape.lod.roam`).

References
----------
- D. Filipović, "Generiranje i prikaz terena" (Terrain generation and display), BSc thesis 221,
  Faculty of Electrical Engineering and Computing, University of Zagreb, 2008, §5.3.
"""

from __future__ import annotations

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit

# The per-frame refresh must not touch the bintree: at 4097² its node array (4·S² bytes) and
# the height/error grids (67 MB each) are far larger than the caches, and a walk over them
# costs a cache miss per node — the refresh then grows with the map although the mesh does
# not (the map size must not matter). Every leaf and every mergeable diamond
# therefore has a record in a dense array — its id, corner coordinates, wedgie thickness
# and corner heights — created and deleted by the split/merge operations themselves. The
# refresh reads only these O(triangles) contiguous records.
#
# A record set is the tuple ``(ids, co, fl, ht, keys)``: ``ids[s]`` int64, ``co[s] = (ar, ac,
# r0, c0, r1, c1)`` int32, ``fl[s]`` float32 values (leaves: ``e, y_a, y_0, y_1`` and a
# bounding sphere ``c_x, c_y, c_z, r`` of the wedgie, world units, see :func:`_leaf_add`;
# diamonds: ``e, y_a, y_0, y_1, y_b``, ``y_b`` the height at the base neighbour's apex), for
# slots ``s < n``; ``ht`` an open-addressing hash table (linear probing, load <= 1/2) of
# ``(key, slot)`` pairs and ``keys[s]`` each record's key (a leaf's id; a diamond's split
# vertex ``row·(S+1) + col``, which both its triangles and their children know without a
# neighbour search), so a record is found and deleted (swap with the last one) in O(1). The
# memory grows with the mesh, not with the map. The counts live in ``cnt = [leaves,
# diamonds]``.
_FIB = np.uint64(0x9E3779B97F4A7C15)  # Fibonacci hashing (Knuth): spreads structured ids


@njit(cache=CACHE, fastmath=FASTMATH)
def _hslot(key, mask):
    # keys 2k and 2k + 1 (sibling leaves, which a split creates and a merge removes
    # together) get adjacent home slots, usually in one cache line
    hk = np.int64((np.uint64(key >> 1) * _FIB) >> np.uint64(32))
    return ((hk << 1) | (key & 1)) & mask


@njit(cache=CACHE, fastmath=FASTMATH)
def _hfind(ht, key):
    """Table index of ``key``, or −1 when absent."""
    mask = ht.shape[0] - 1
    i = _hslot(key, mask)
    while True:
        k = ht[i, 0]
        if k == key:
            return i
        if k < 0:
            return -1
        i = (i + 1) & mask


@njit(cache=CACHE, fastmath=FASTMATH)
def _hput(ht, key, val):
    """Insert ``key`` (absent) with value ``val``."""
    mask = ht.shape[0] - 1
    i = _hslot(key, mask)
    while ht[i, 0] >= 0:
        i = (i + 1) & mask
    ht[i, 0] = key
    ht[i, 1] = val


@njit(cache=CACHE, fastmath=FASTMATH)
def _hdel_at(ht, i):
    """Delete table entry ``i`` by backward shifting (no tombstones, so probe chains stay as
    short as the load allows)."""
    mask = ht.shape[0] - 1
    j = i
    while True:
        j = (j + 1) & mask
        k = ht[j, 0]
        if k < 0:
            break
        # the entry at j may move to the hole i unless its home slot lies in (i, j]
        if ((j - _hslot(k, mask)) & mask) >= ((j - i) & mask):
            ht[i, 0] = k
            ht[i, 1] = ht[j, 1]
            i = j
    ht[i, 0] = -1


@njit(cache=CACHE, fastmath=FASTMATH)
def _rehash(ids, n, ht):
    ht[:, 0] = -1
    for s in range(n):
        _hput(ht, ids[s], s)


@njit(cache=CACHE, fastmath=FASTMATH)
def _rec_add(rec, n, key, tid, ar, ac, r0, c0, r1, c1):
    """Append a record with hash key ``key`` and triangle id ``tid`` at slot ``n``
    (returned); the caller fills ``fl[n]``."""
    ids, co, _, ht, keys = rec
    ids[n] = tid
    keys[n] = key
    co[n, 0], co[n, 1], co[n, 2] = ar, ac, r0
    co[n, 3], co[n, 4], co[n, 5] = c0, r1, c1
    _hput(ht, key, n)
    return n


@njit(cache=CACHE, fastmath=FASTMATH)
def _rec_replace(rec, i, key, tid, ar, ac, r0, c0, r1, c1):
    """Give the record of table entry ``i`` the new key ``key`` (absent) and triangle id
    ``tid``, keeping its slot (returned); the caller fills ``fl``."""
    ids, co, _, ht, keys = rec
    s = ht[i, 1]
    _hdel_at(ht, i)
    _hput(ht, key, s)
    ids[s] = tid
    keys[s] = key
    co[s, 0], co[s, 1], co[s, 2] = ar, ac, r0
    co[s, 3], co[s, 4], co[s, 5] = c0, r1, c1
    return s


@njit(cache=CACHE, fastmath=FASTMATH)
def _rec_remove_at(rec, n, i):
    """Delete the record of table entry ``i``; the last record fills its slot. Returns the
    new count."""
    ids, co, fl, ht, keys = rec
    s = ht[i, 1]
    _hdel_at(ht, i)
    n -= 1
    if s != n:
        last = keys[n]
        keys[s] = last
        ids[s] = ids[n]
        for k in range(6):
            co[s, k] = co[n, k]
        for k in range(fl.shape[1]):
            fl[s, k] = fl[n, k]
        ht[_hfind(ht, last), 1] = s
    return n


def _alloc_records(cap: int, width: int, key_dtype=np.int64):
    """An empty record set (see "per-entry records") for ``cap`` records of ``width`` float
    values; the hash table has a power-of-two size >= 2·cap (load <= 1/2) and holds
    ``key_dtype`` (key, slot) pairs (int32 when the keys fit: half the table's cache
    footprint, and the table is read at random places by every split and merge)."""
    hcap = 1 << max(4, (2 * cap - 1).bit_length())
    return (
        np.zeros(cap, np.int64),
        np.zeros((cap, 6), np.int32),
        np.zeros((cap, width), np.float32),
        np.full((hcap, 2), -1, key_dtype),  # (key, slot) pairs: one cache line per probe
        np.zeros(cap, np.int64),  # each record's hash key (leaves: the id)
    )


def _grow_records(rec, n: int, extra: int):
    """``rec`` itself when it has room for ``extra`` more records, else a copy with at least
    twice the capacity (records kept in their slots, hash table rebuilt)."""
    if rec[0].size >= n + extra:
        return rec
    new = _alloc_records(max(n + extra, 2 * rec[0].size), rec[2].shape[1], rec[3].dtype)
    for k in range(3):
        new[k][:n] = rec[k][:n]
    new[4][:n] = rec[4][:n]
    _rehash(new[4], np.int64(n), new[3])
    return new
