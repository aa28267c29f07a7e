"""ROAM — Real-time Optimally Adapting Meshes (Duchaineau et al. 1997).

A binary triangle tree over a ``(2**n + 1)²`` heightmap (two root triangles,
:mod:`terrascape.lod.bintree`) is kept as a triangulation that changes from frame to frame
by *splits* (with recursive forced splits of the base neighbour, §4.1.2, Figure 21) and
*merges* of mergeable diamonds. Two priority queues drive it (§4.1.3):

* the split queue ``Q_s`` holds every leaf triangle, keyed by its priority;
* the merge queue ``Q_m`` holds every mergeable diamond ``(T, T_B)`` — both split, all four
  children leaves — keyed by ``max{p(T), p(T_B)}``.

Each frame starts from the previous triangulation (frame coherence); the priorities of all
queue elements are refreshed for the new camera (the thesis's "osvježi prioritete za sve
elemente Q_s, Q_m") and the greedy loop splits the highest-priority triangle or merges the
lowest-priority diamond until the targets are met: a screen-space error tolerance (pixels),
a triangle count, and a time budget, whichever comes first. With a triangle budget the loop
keeps swapping (merge the lowest diamond, split the highest triangle) while the highest
split priority exceeds the lowest merge priority, as in the thesis's pseudocode. A split is
taken only when it fits the budget together with its forced splits (otherwise the swap
merges first): an overshoot would have to be merged back regardless of priority, which can
undo the split and make the loop flip between the same splits and merges.

Per-frame cost independent of the map size
-----------------------------------------------------
The refresh never walks the bintree nor reads the height/error grids (at 4097² far larger
than the caches): every leaf and mergeable diamond has a compact record (corners, heights,
error bound, bounding sphere) kept up to date by the splits and merges, and the refresh
reads only these O(triangles) records. The split queue is partial: a leaf whose cheap
sphere bound is below θ (a fraction of the previous frame's maximum priority) is left out,
and the queue is rebuilt in full in the rare frame where it runs empty — every left-out
leaf is below every queued one, so the greedy loop makes exactly the same decisions. Equal
priorities are ordered by id, so the meshes do not depend on the order of the records.

Priority (projected wedgie, conservative)
-----------------------------------------
Every triangle has a nested wedgie thickness ``e_T`` (world units, a true bound on its
vertical error, :func:`terrascape.lod.bintree.wedgie_errors`). The wedgie is the prism of
the triangle's plane ±``e_T`` and wedgies are nested, so a child's wedgie lies inside the
parent's. Its priority is the largest possible screen size of a vertical segment of length
``e_T`` inside the wedgie:

    p(T) = e_T · K / max(z_min, near),   K = k_px · sqrt(1 + tan²(fov_y/2)·(1 + aspect²)),

where ``z_min`` is the smallest view-axis depth over the six wedgie corners, ``k_px`` the
larger of the horizontal and vertical pixels per unit of tangent (``v_res / (2·tan(fov/2))``)
and the square root bounds the off-axis magnification of the perspective divide. A wedgie
entirely outside one frustum plane gets priority 0 (the thesis's "outside → lowest"). Because
the wedgies are nested, ``p`` is monotonic (a child never has a higher priority than its
parent), as the greedy queues require. A sample with vertical error δ at distance d inside
the view therefore has ``δ·K'/d <= p(T)`` for the metric of
:func:`terrascape.lod.mesh_checks.max_screen_error` (``K' = v_res / (2·tan(fov_y/2))``).

Output: ``uint32 (M, 3)`` grid vertex indices ``row·cols + col`` into the full-resolution
grid, counter-clockwise seen from above (+Y), the winding of the full-resolution mesh.

References
----------
- D. Filipović, "Generiranje i prikaz terena" (Terrain generation and display), BSc thesis 221,
  Faculty of Electrical Engineering and Computing, University of Zagreb, 2008, §4.1, §4.1.3,
  §5.3.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit
from terrascape._validate import check_finite, check_int, check_positive
from terrascape.camera import Camera
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.lod._heap import _TIE_M, _TIE_S, _heapify, _hpop, _hpush
from terrascape.lod._records import (
    _alloc_records,
    _grow_records,
    _hfind,
    _rec_add,
    _rec_remove_at,
    _rec_replace,
)
from terrascape.lod.bintree import (
    _level,
    _partner,
    _partner_from_coords,
    _tri_coords,
    wedgie_errors,
)

__all__ = ["Roam", "RoamStats", "roam_mesh"]

ABSENT, LEAF, SPLIT = 0, 1, 2

# The kernels take small named bundles instead of long positional lists:
#
# * ``view``: one record of :data:`VIEW` (a length-1 structured array; kernels read
#   ``view[0]``) — the camera packed by :func:`camera_params` plus the grid spacing, the
#   static flag (priorities in world units, for :func:`roam_mesh`) and the split queue's
#   threshold θ (see :func:`_fill_split`);
# * ``tree = (state, h, err, size, max_lvl)``: the bintree node states, heights, nested
#   wedgie errors, cells per side and finest level;
# * ``co = (ar, ac, r0, c0, r1, c1)``: a triangle's apex, v0 and v1 (row, col);
# * ``split_q = (keys, ids)``, ``merge_q = (keys, ids)``: the queues' heap arrays (their
#   lengths travel separately: the kernels return the new ones);
# * ``recs = (leaves, diamonds, cnt)``: the two record sets (:mod:`terrascape.lod._records`)
#   and their counts ``cnt = [leaves, diamonds, kept per operation]``.
VIEW = np.dtype([
    ("eye", np.float64, 3), ("forward", np.float64, 3), ("planes", np.float64, (6, 4)),
    ("near", np.float64), ("k", np.float64), ("static", np.float64), ("dx", np.float64),
    ("dz", np.float64), ("theta", np.float64), ("omni", np.float64),
])  # fmt: skip

# the per-frame split queue holds the leaves with priority >= a fraction of the previous
# frame's maximum (_fill_split). Any fraction gives the same meshes; it only trades per-frame
# work against the chance of a full rebuild, so it adapts: it backs off after a frame that
# needed a rebuild (a fast turn) and creeps back up while none is needed.
_THETA_MAX, _THETA_MIN, _THETA_STEP_UP, _THETA_BACKOFF = 0.97, 0.5, 0.005, 0.1
# a frame that starts from at most this many triangles keeps no records per operation
_BUILD_FROM = 64

# loop status codes returned by _roam_ops
_MORE, _TOLERANCE, _TRIANGLES, _NO_MERGE, _REFILL = 0, 1, 2, 3, 4
_STOP_NAMES = {_TOLERANCE: "tolerance", _TRIANGLES: "triangles", _NO_MERGE: "triangles"}


# --------------------------------------------------------------------------------------------
# priorities
# --------------------------------------------------------------------------------------------
@njit(cache=CACHE, fastmath=FASTMATH)
def _wedgie_sphere(e, pts):
    """Bounding sphere ``(cx, cy, cz, r)`` of the wedgie of thickness ``e`` over the triangle
    with world corners ``pts = (xa, ya, za, x0, y0, z0, x1, y1, z1)``: centred on the
    hypotenuse midpoint in x/z and on the wedgie's height range in y. The priority's frustum
    short-cut and the leaf records' refresh bound (:func:`_leaf_fill`) use the same sphere."""
    xa, ya, za, x0, y0, z0, x1, y1, z1 = pts
    cx = 0.5 * (x0 + x1)
    cz = 0.5 * (z0 + z1)
    ylo = min(ya, y0, y1) - e
    yhi = max(ya, y0, y1) + e
    cy = 0.5 * (ylo + yhi)
    r2 = max(
        (xa - cx) ** 2 + (za - cz) ** 2,
        (x0 - cx) ** 2 + (z0 - cz) ** 2,
        (x1 - cx) ** 2 + (z1 - cz) ** 2,
    )
    return cx, cy, cz, math.sqrt(r2 + (0.5 * (yhi - ylo)) ** 2)


@njit(cache=CACHE, fastmath=FASTMATH)
def _corners(co, ya, y0, y1, dx, dz):
    """World corners ``(xa, ya, za, x0, y0, z0, x1, y1, z1)`` of a triangle ``co`` with the
    given corner heights."""
    ar, ac, r0, c0, r1, c1 = co
    return (ac * dx, ya, ar * dz, c0 * dx, y0, r0 * dz, c1 * dx, y1, r1 * dz)


@njit(cache=CACHE, fastmath=FASTMATH)
def _wedgie_priority(v, e, pts):
    """Screen-space priority for the view record ``v`` of a wedgie of thickness ``e > 0``
    over the triangle with world corners ``pts``.

    Frustum: exact "all six wedgie corners outside one plane" test, short-cut by the
    wedgie's bounding sphere (a sphere inside a plane needs no corner test). Exactness
    matters: culling must be nested like the wedgies so priorities stay monotonic. Depth:
    the exact minimum over the six wedgie corners.
    """
    xa, ya, za, x0, y0, z0, x1, y1, z1 = pts
    if v.omni > 0.0:
        return e * v.k / _box_distance(v, e, pts)
    cx, cy, cz, rad = _wedgie_sphere(e, pts)
    planes = v.planes
    for k in range(6):
        a, b, c, d = planes[k, 0], planes[k, 1], planes[k, 2], planes[k, 3]
        if a * cx + b * cy + c * cz + d >= rad:
            continue  # sphere inside this plane, so is the wedgie
        # straddling sphere: exact test on the wedgie corners (a triangle corner ± e along
        # Y), which keeps culling nested (a child of a culled wedgie is culled)
        best = max(a * xa + b * ya + c * za, a * x0 + b * y0 + c * z0, a * x1 + b * y1 + c * z1)
        if best + d + e * abs(b) < 0.0:
            return 0.0  # entirely outside one plane: lowest priority
    eye, fwd = v.eye, v.forward
    ex, ey, ez = eye[0], eye[1], eye[2]
    fx, fy, fz = fwd[0], fwd[1], fwd[2]
    da = (xa - ex) * fx + (ya - ey) * fy + (za - ez) * fz
    d0 = (x0 - ex) * fx + (y0 - ey) * fy + (z0 - ez) * fz
    d1 = (x1 - ex) * fx + (y1 - ey) * fy + (z1 - ez) * fz
    zmin = min(da, d0, d1) - e * abs(fy)
    if zmin < v.near:
        zmin = v.near
    return e * v.k / zmin


@njit(cache=CACHE, fastmath=FASTMATH)
def _box_distance(v, e, pts):
    """Distance from the eye to the axis-aligned box around the wedgie of thickness ``e``
    (at least ``near``): the no-culling priority's distance. Nested wedgies have nested
    boxes, so the priority stays monotonic, and every point of the wedgie is at least this
    far from the eye."""
    xa, ya, za, x0, y0, z0, x1, y1, z1 = pts
    ex, ey, ez = v.eye[0], v.eye[1], v.eye[2]
    gx = max(min(xa, x0, x1) - ex, 0.0, ex - max(xa, x0, x1))
    gy = max(min(ya, y0, y1) - e - ey, 0.0, ey - max(ya, y0, y1) - e)
    gz = max(min(za, z0, z1) - ez, 0.0, ez - max(za, z0, z1))
    return max(math.sqrt(gx * gx + gy * gy + gz * gz), v.near)


@njit(cache=CACHE, fastmath=FASTMATH)
def _priority(view, tree, level, co):
    """Projected wedgie thickness in pixels (module docstring) of the level-``level``
    triangle ``co``; 0 outside the frustum or for an exact triangle. In static mode
    (``static > 0``) the world-unit bound itself."""
    _, h, err, _, max_lvl = tree
    if level >= max_lvl:
        return 0.0
    ar, ac, r0, c0, r1, c1 = co
    e = np.float64(err[(r0 + r1) >> 1, (c0 + c1) >> 1])
    if e <= 0.0:
        return 0.0
    v = view[0]
    if v.static > 0.0:
        return e
    pts = _corners(co, np.float64(h[ar, ac]), np.float64(h[r0, c0]), np.float64(h[r1, c1]),
                   v.dx, v.dz)
    return _wedgie_priority(v, e, pts)


@njit(cache=CACHE, fastmath=FASTMATH)
def _mirrored(co):
    """The base neighbour's corners of a triangle ``co``: mirrored apex, v0 and v1 swapped."""
    ar, ac, r0, c0, r1, c1 = co
    return (r0 + r1 - ar, c0 + c1 - ac, r1, c1, r0, c0)


@njit(cache=CACHE, fastmath=FASTMATH)
def _diamond_priority_at(view, tree, lvl, co):
    """``max{p(T), p(T_B)}`` of the diamond of the level-``lvl`` triangle ``co`` (either
    triangle of the pair: the maximum is symmetric)."""
    size = tree[3]
    p = _priority(view, tree, lvl, co)
    bco = _mirrored(co)
    if 0 <= bco[0] <= size and 0 <= bco[1] <= size:
        q = _priority(view, tree, lvl, bco)
        if q > p:
            p = q
    return p


# --------------------------------------------------------------------------------------------
# leaf and diamond records (record sets: terrascape.lod._records)
# --------------------------------------------------------------------------------------------
# Leaves: ``fl[s] = e, y_a, y_0, y_1`` and the wedgie's bounding sphere ``c_x, c_y, c_z, r``
# (world units, :func:`_leaf_fill`), keyed by the leaf id. Mergeable diamonds: ``fl[s] = e,
# y_a, y_0, y_1, y_b`` (``y_b`` the height at the base neighbour's apex), keyed by the split
# vertex ``row·(S+1) + col``, which both triangles and their children know without a
# neighbour search.
_LEAF_FIELDS, _DIAMOND_FIELDS = 8, 5  # float32 values per record (widths of ``fl``)


@njit(cache=CACHE, fastmath=FASTMATH)
def _leaf_add(recs, t, lvl, tree, view, co):
    """Record leaf ``t`` (level ``lvl``, corners ``co``): corners, heights, its wedgie
    thickness (0 at the finest level, whose hypotenuse midpoint is not a grid vertex) and a
    bounding sphere of its wedgie (grid spacing from ``view``).

    The sphere is the one :func:`_wedgie_priority` uses, stored in float32 with its radius
    enlarged by the centre's rounding and rounded up, so it still contains the wedgie: the
    refresh bounds the priority with it (:func:`_fill_split`)."""
    leaves, _, cnt = recs
    ar, ac, r0, c0, r1, c1 = co
    s = _rec_add(leaves, cnt[0], t, t, ar, ac, r0, c0, r1, c1)
    cnt[0] = s + 1
    _leaf_fill(leaves[2], s, lvl, tree, view, co)


@njit(cache=CACHE, fastmath=FASTMATH)
def _leaf_replace(recs, old, t, lvl, tree, view, co):
    """Turn the record of leaf ``old`` into one of leaf ``t`` in the same slot (a split's
    first child, a merge's parent): cheaper than a removal (which moves the last record)
    plus an append. Record order is free: the queues order ties by id."""
    leaves = recs[0]
    ar, ac, r0, c0, r1, c1 = co
    s = _rec_replace(leaves, _hfind(leaves[3], old), t, t, ar, ac, r0, c0, r1, c1)
    _leaf_fill(leaves[2], s, lvl, tree, view, co)


@njit(cache=CACHE, fastmath=FASTMATH)
def _leaf_fill(fl, s, lvl, tree, view, co):
    """The float values of leaf record ``s`` (see :func:`_leaf_add`)."""
    _, h, err, _, max_lvl = tree
    v = view[0]
    ar, ac, r0, c0, r1, c1 = co
    e = np.float64(err[(r0 + r1) >> 1, (c0 + c1) >> 1]) if lvl < max_lvl else 0.0
    ya = np.float64(h[ar, ac])
    y0 = np.float64(h[r0, c0])
    y1 = np.float64(h[r1, c1])
    fl[s, 0] = e
    fl[s, 1] = ya
    fl[s, 2] = y0
    fl[s, 3] = y1
    cx, cy, cz, rad = _wedgie_sphere(e, _corners(co, ya, y0, y1, v.dx, v.dz))
    fl[s, 4] = cx
    fl[s, 5] = cy
    fl[s, 6] = cz
    slack = abs(fl[s, 4] - cx) + abs(fl[s, 5] - cy) + abs(fl[s, 6] - cz)
    fl[s, 7] = (rad + slack) * (1.0 + 1e-6)  # float32 rounding is < 1e-7 relative


@njit(cache=CACHE, fastmath=FASTMATH)
def _leaf_remove(recs, t):
    leaves, _, cnt = recs
    cnt[0] = _rec_remove_at(leaves, cnt[0], _hfind(leaves[3], t))


@njit(cache=CACHE, fastmath=FASTMATH)
def _vertex_key(r, c, size):
    """Hash key of a diamond: its split vertex (the shared hypotenuse midpoint), which both
    triangles know without a neighbour search."""
    return r * (size + 1) + c


@njit(cache=CACHE, fastmath=FASTMATH)
def _diamond_drop(r, c, size, recs):
    """Delete the record of the diamond split at vertex ``(r, c)``, if any."""
    _, diamonds, cnt = recs
    i = _hfind(diamonds[3], _vertex_key(r, c, size))
    if i >= 0:
        cnt[1] = _rec_remove_at(diamonds, cnt[1], i)


@njit(cache=CACHE, fastmath=FASTMATH)
def _diamond_sync(t, tree, recs):
    """Make the diamond record of the diamond containing ``t`` agree with the bintree: present
    exactly when the diamond is mergeable (``t`` and its base neighbour split, all four
    children leaves). Found by its split vertex; its id is, as in the merge queue, the
    canonical (smaller) one."""
    if t < 2:
        return
    size = tree[3]
    co = _tri_coords(t, size)
    ar, ac, r0, c0, r1, c1 = co
    b = _partner_from_coords(_level(t), ar, ac, r0, c0, r1, c1, size)
    _diamond_sync_known(t, b, co, tree, recs, False)


@njit(cache=CACHE, fastmath=FASTMATH)
def _diamond_sync_known(t, b, co, tree, recs, absent):
    """:func:`_diamond_sync` with ``t``'s corners ``co`` and base neighbour ``b`` already
    known. ``absent``: the caller knows the diamond has no record (it was not mergeable
    before the operation), which saves the hash lookup when it is not mergeable now
    either."""
    state, h, err, size, _ = tree
    _, diamonds, cnt = recs
    mergeable = (
        state[t] == SPLIT
        and state[2 * t] == LEAF
        and state[2 * t + 1] == LEAF
        and (b < 0 or (state[b] == SPLIT and state[2 * b] == LEAF and state[2 * b + 1] == LEAF))
    )
    if absent and not mergeable:
        return
    c = t if (b < 0 or t < b) else b
    ar, ac, r0, c0, r1, c1 = co
    key = _vertex_key((r0 + r1) >> 1, (c0 + c1) >> 1, size)
    i = -1 if absent else _hfind(diamonds[3], key)
    if mergeable and i < 0:
        if c != t:  # the base neighbour
            ar, ac, r0, c0, r1, c1 = _mirrored(co)
        s = _rec_add(diamonds, cnt[1], key, c, ar, ac, r0, c0, r1, c1)
        cnt[1] = s + 1
        fl = diamonds[2]
        fl[s, 0] = err[(r0 + r1) >> 1, (c0 + c1) >> 1]
        fl[s, 1] = h[ar, ac]
        fl[s, 2] = h[r0, c0]
        fl[s, 3] = h[r1, c1]
        br = r0 + r1 - ar
        bc = c0 + c1 - ac
        fl[s, 4] = h[br, bc] if (0 <= br <= size and 0 <= bc <= size) else 0.0
    elif not mergeable and i >= 0:
        cnt[1] = _rec_remove_at(diamonds, cnt[1], i)


@njit(cache=CACHE, fastmath=FASTMATH)
def _records_reset(recs, tree, view):
    """Empty both record sets and record the two root triangles (the base mesh)."""
    leaves, diamonds, cnt = recs
    size = tree[3]
    leaves[3][:, 0] = -1
    diamonds[3][:, 0] = -1
    cnt[0] = 0
    cnt[1] = 0
    _leaf_add(recs, 2, 0, tree, view, (size, 0, size, size, 0, 0))
    _leaf_add(recs, 3, 0, tree, view, (0, size, 0, 0, size, size))


@njit(cache=CACHE, fastmath=FASTMATH)
def _walk_roots(stack, size):
    """Start a depth-first walk of the bintree: push the two root triangles (id, -, apex,
    v0, v1 as row/col pairs); returns the stack height."""
    stack[0, 0] = 2
    stack[0, 2], stack[0, 3], stack[0, 4] = size, 0, size
    stack[0, 5], stack[0, 6], stack[0, 7] = size, 0, 0
    stack[1, 0] = 3
    stack[1, 2], stack[1, 3], stack[1, 4] = 0, size, 0
    stack[1, 5], stack[1, 6], stack[1, 7] = 0, size, size
    return 2


@njit(cache=CACHE, fastmath=FASTMATH)
def _walk_children(stack, sp, x, co):
    """Push split triangle ``x``'s children ``T0 = (v_c, v_a, v_0)``, ``T1 = (v_c, v_1, v_a)``
    with their corners; returns the new stack height."""
    ar, ac, r0, c0, r1, c1 = co
    mr = (r0 + r1) >> 1
    mc = (c0 + c1) >> 1
    stack[sp, 0] = 2 * x
    stack[sp, 2], stack[sp, 3], stack[sp, 4] = mr, mc, ar
    stack[sp, 5], stack[sp, 6], stack[sp, 7] = ac, r0, c0
    stack[sp + 1, 0] = 2 * x + 1
    stack[sp + 1, 2], stack[sp + 1, 3], stack[sp + 1, 4] = mr, mc, r1
    stack[sp + 1, 5], stack[sp + 1, 6], stack[sp + 1, 7] = c1, ar, ac
    return sp + 2


@njit(cache=CACHE, fastmath=FASTMATH)
def _popped(stack, sp):
    """``(id, corners)`` of stack entry ``sp``."""
    return stack[sp, 0], (stack[sp, 2], stack[sp, 3], stack[sp, 4], stack[sp, 5],
                          stack[sp, 6], stack[sp, 7])


@njit(cache=CACHE, fastmath=FASTMATH)
def _records_rebuild(tree, view, recs, stack):
    """Rebuild both record sets from the bintree in one walk (after a frame that ran with
    ``cnt[2] = 0``: building a mesh from the base triangulation takes tens of thousands of
    splits, and one walk at the end is cheaper than keeping the records per split)."""
    state, size = tree[0], tree[3]
    leaves, diamonds, cnt = recs
    leaves[3][:, 0] = -1
    diamonds[3][:, 0] = -1
    cnt[0] = 0
    cnt[1] = 0
    sp = _walk_roots(stack, size)
    while sp > 0:
        sp -= 1
        x, co = _popped(stack, sp)
        st = state[x]
        if st == LEAF:
            _leaf_add(recs, x, _level(x), tree, view, co)
        elif st == SPLIT:
            if state[2 * x] == LEAF and state[2 * x + 1] == LEAF:
                _diamond_sync(x, tree, recs)
            sp = _walk_children(stack, sp, x, co)


# --------------------------------------------------------------------------------------------
# split / merge
# --------------------------------------------------------------------------------------------
@njit(cache=CACHE, fastmath=FASTMATH)
def _mergeable(d, state, size):
    """True when the diamond of split triangle ``d`` can merge: ``d`` and its base neighbour
    are split and all four children are leaves."""
    if d < 2 or state[d] != SPLIT or state[2 * d] != LEAF or state[2 * d + 1] != LEAF:
        return False
    b = _partner(d, size)
    if b < 0:
        return True
    return state[b] == SPLIT and state[2 * b] == LEAF and state[2 * b + 1] == LEAF


@njit(cache=CACHE, fastmath=FASTMATH)
def _canonical(t, size):
    """The diamond's key: the smaller id of the pair (the triangle itself on the border)."""
    b = _partner(t, size)
    if b >= 0 and b < t:
        return b
    return t


@njit(cache=CACHE, fastmath=FASTMATH)
def _split_one(t, b, co, tree, view, split_q, ns, recs):
    """Replace leaf ``t`` (corners ``co``, base neighbour ``b``, −1 on the border) by its
    children ``T0 = (v_c, v_a, v_0)``, ``T1 = (v_c, v_1, v_a)``, queue them and update the
    records (the leaf's, and the diamonds of ``t`` and its parent, the only ones whose
    mergeability a split of ``t`` can change). Callers know ``co``: an O(level)
    :func:`_tri_coords` per triangle is a large part of an operation's cost. Returns the
    split queue's length."""
    state, size = tree[0], tree[3]
    sk, si = split_q
    cnt = recs[2]
    ar, ac, r0, c0, r1, c1 = co
    state[t] = SPLIT
    state[2 * t] = LEAF
    state[2 * t + 1] = LEAF
    mr = (r0 + r1) >> 1
    mc = (c0 + c1) >> 1
    lvl = _level(t) + 1
    child0 = (mr, mc, ar, ac, r0, c0)
    child1 = (mr, mc, r1, c1, ar, ac)
    if cnt[2]:  # records kept per operation (else rebuilt after the frame)
        _leaf_replace(recs, t, 2 * t, lvl, tree, view, child0)
        _leaf_add(recs, 2 * t + 1, lvl, tree, view, child1)
        # t was a leaf: its diamond had no record
        _diamond_sync_known(t, b, co, tree, recs, True)
        # the parent's diamond (split at t's apex) is no longer mergeable; it had a record
        # only if both its children were leaves
        if t >= 4 and state[t ^ 1] == LEAF:
            _diamond_drop(ar, ac, size, recs)
    # the split queue holds the leaves with p > 0 and p >= theta (see _fill_split)
    theta = view[0].theta
    p = _priority(view, tree, lvl, child0)
    if p > 0.0 and p >= theta:
        ns = _hpush(sk, si, ns, p, 2 * t, _TIE_S)
    p = _priority(view, tree, lvl, child1)
    if p > 0.0 and p >= theta:
        ns = _hpush(sk, si, ns, p, 2 * t + 1, _TIE_S)
    return ns


@njit(cache=CACHE, fastmath=FASTMATH)
def _force_split(t, tree, view, split_q, ns, merge_q, nm, stack, recs):
    """Split leaf ``t`` together with its base neighbour; a coarser base neighbour is force
    split first, recursively (explicit stack). Returns ``(ns, nm, leaves_added)``."""
    state, size = tree[0], tree[3]
    mk, mi = merge_q
    added = 0
    stack[0] = t
    sp = 1
    while sp > 0:
        x = stack[sp - 1]
        st = state[x]
        if st == SPLIT:
            sp -= 1
            continue
        if st == ABSENT:  # never in a conforming mesh; create the triangle first
            stack[sp] = x >> 1
            sp += 1
            continue
        co = _tri_coords(x, size)
        ar, ac, r0, c0, r1, c1 = co
        lvl = _level(x)
        b = _partner_from_coords(lvl, ar, ac, r0, c0, r1, c1, size)
        if b >= 0 and state[b] == ABSENT:  # T_B is coarser: its parent must split first
            stack[sp] = b >> 1
            sp += 1
            continue
        ns = _split_one(x, b, co, tree, view, split_q, ns, recs)
        added += 1
        if b >= 0 and state[b] == LEAF:
            ns = _split_one(b, x, _mirrored(co), tree, view, split_q, ns, recs)
            added += 1
        d = x if (b < 0 or x < b) else b
        p = _diamond_priority_at(view, tree, lvl, co)
        nm = _hpush(mk, mi, nm, -p, d, _TIE_M)
        sp -= 1
    return ns, nm, added


@njit(cache=CACHE, fastmath=FASTMATH)
def _split_cost(t, state, size):
    """Triangles a forced split of leaf ``t`` adds (what :func:`_force_split` would return),
    without changing the mesh: ``t`` and its base neighbour, plus the forced split of the
    neighbour's parent when the neighbour is coarser, recursively (§4.1.2, Figure 21)."""
    need = 0
    x = t
    while True:
        b = _partner(x, size)
        if b < 0:
            return need + 1
        need += 2
        if state[b] != ABSENT:
            return need
        x = b >> 1


@njit(cache=CACHE, fastmath=FASTMATH)
def _merge(d, tree, view, split_q, ns, merge_q, nm, recs):
    """Merge the (mergeable) diamond of ``d``; queue the parents and any diamond one level up
    that became mergeable. Returns ``(ns, nm, leaves_removed)``."""
    state, size = tree[0], tree[3]
    sk, si = split_q
    mk, mi = merge_q
    cnt = recs[2]
    lvl = _level(d)
    dco = _tri_coords(d, size)
    ar, ac, r0, c0, r1, c1 = dco
    b = _partner_from_coords(lvl, ar, ac, r0, c0, r1, c1, size)
    theta = view[0].theta
    removed = 0
    for k in range(2):
        x = d if k == 0 else b
        if x < 0:
            continue
        state[2 * x] = ABSENT
        state[2 * x + 1] = ABSENT
        state[x] = LEAF
        removed += 1
        co = dco if k == 0 else _mirrored(dco)
        if cnt[2]:
            _leaf_replace(recs, 2 * x, x, lvl, tree, view, co)
            _leaf_remove(recs, 2 * x + 1)
        p = _priority(view, tree, lvl, co)
        if p > 0.0 and p >= theta:
            ns = _hpush(sk, si, ns, p, x, _TIE_S)
    # the merged diamond's record goes; the parents' diamonds may have become mergeable
    if cnt[2]:
        _diamond_drop((dco[2] + dco[4]) >> 1, (dco[3] + dco[5]) >> 1, size, recs)
    for k in range(2):
        x = d if k == 0 else b
        if x < 4:  # roots have no parent
            continue
        par = x >> 1
        ar, ac, r0, c0, r1, c1 = dco if k == 0 else _mirrored(dco)
        # the parent's corners from its child's: x = T0 = (v_c, v_a, v_0) or
        # T1 = (v_c, v_1, v_a) of the parent, and v_c is the midpoint of v_0 and v_1
        if x & 1 == 0:
            pco = (r0, c0, r1, c1, 2 * ar - r1, 2 * ac - c1)
        else:
            pco = (r1, c1, 2 * ar - r0, 2 * ac - c0, r0, c0)
        bp = _partner_from_coords(lvl - 1, pco[0], pco[1], pco[2], pco[3], pco[4], pco[5],
                                  size)
        if cnt[2]:
            # x was split: the parent's diamond had no record
            _diamond_sync_known(par, bp, pco, tree, recs, True)
        if (
            state[2 * par] == LEAF
            and state[2 * par + 1] == LEAF
            and (
                bp < 0
                or (state[bp] == SPLIT and state[2 * bp] == LEAF and state[2 * bp + 1] == LEAF)
            )
        ):  # mergeable (par itself is split)
            dd = par if (bp < 0 or par < bp) else bp
            p = _diamond_priority_at(view, tree, lvl - 1, pco)
            nm = _hpush(mk, mi, nm, -p, dd, _TIE_M)
    return ns, nm, removed


# --------------------------------------------------------------------------------------------
# per-frame refresh, greedy loop, output
# --------------------------------------------------------------------------------------------
@njit(cache=CACHE, fastmath=FASTMATH)
def _fill_split(view, recs, split_q):
    """Build the split queue for ``cam`` from the leaf records alone (no bintree walk, no
    height or error lookups). Returns its length.

    Partial queue: only leaves with ``p > 0`` and ``p >= θ = view.theta`` are queued (θ = 0:
    all with ``p > 0``). A leaf is skipped without computing its priority when the cheap
    bound ``e·K / max(near, depth(centre) − r)`` of its bounding sphere (which contains the
    wedgie, so no wedgie corner is nearer than that) is below θ. Every left-out leaf has a
    priority below every queued one, so while the queue has a valid entry its top is the
    true maximum; the greedy loop asks for a full rebuild (θ = 0, status ``_REFILL``) only
    if it empties. The greedy loop typically pops a few dozen leaves per frame, so θ near
    the previous frame's maximum avoids computing and heapifying tens of thousands of exact
    priorities. The exact priorities are those of :func:`_priority` (same formula, same
    float32 inputs).
    """
    v = view[0]
    leaves, _, cnt = recs
    sk, si = split_q
    static = v.static > 0.0
    theta = v.theta
    # a relative margin far above the float64 rounding of the bound's few operations
    theta_b = theta * (1.0 - 1e-9)
    dx, dz, near, kpx = v.dx, v.dz, v.near, v.k
    ex, ey, ez = v.eye[0], v.eye[1], v.eye[2]
    fx, fy, fz = v.forward[0], v.forward[1], v.forward[2]
    lid, lco, lfl = leaves[0], leaves[1], leaves[2]
    ns = 0
    for i in range(cnt[0]):
        e = np.float64(lfl[i, 0])
        if e <= 0.0:
            continue
        if static:
            p = e
        else:
            # the sphere bound holds for the view-depth priority only (a box can reach
            # outside the sphere), so without culling every leaf gets its exact priority
            if theta > 0.0 and v.omni == 0.0:
                zb = (
                    (np.float64(lfl[i, 4]) - ex) * fx
                    + (np.float64(lfl[i, 5]) - ey) * fy
                    + (np.float64(lfl[i, 6]) - ez) * fz
                    - np.float64(lfl[i, 7])
                )
                if zb < near:
                    zb = near
                if e * kpx / zb < theta_b:
                    continue
            co = (lco[i, 0], lco[i, 1], lco[i, 2], lco[i, 3], lco[i, 4], lco[i, 5])
            pts = _corners(co, np.float64(lfl[i, 1]), np.float64(lfl[i, 2]),
                           np.float64(lfl[i, 3]), dx, dz)
            p = _wedgie_priority(v, e, pts)
        if p > 0.0 and p >= theta:
            sk[ns] = p
            si[ns] = lid[i]
            ns += 1
    _heapify(sk, si, ns, _TIE_S)
    return ns


@njit(cache=CACHE, fastmath=FASTMATH)
def _fill_merge(view, size, recs, merge_q):
    """Build the merge queue for ``view`` from the diamond records: every mergeable diamond
    keyed by ``−max{p(T), p(T_B)}`` (as :func:`_diamond_priority_at`). Returns its length."""
    v = view[0]
    _, diamonds, cnt = recs
    mk, mi = merge_q
    static = v.static > 0.0
    dx, dz = v.dx, v.dz
    did, dco, dfl = diamonds[0], diamonds[1], diamonds[2]
    nm = 0
    for j in range(cnt[1]):
        e = np.float64(dfl[j, 0])
        p = 0.0
        if e > 0.0:
            if static:
                p = e
            else:
                co = (dco[j, 0], dco[j, 1], dco[j, 2], dco[j, 3], dco[j, 4], dco[j, 5])
                y0 = np.float64(dfl[j, 2])
                y1 = np.float64(dfl[j, 3])
                p = _wedgie_priority(v, e, _corners(co, np.float64(dfl[j, 1]), y0, y1, dx, dz))
                bco = _mirrored(co)
                if 0 <= bco[0] <= size and 0 <= bco[1] <= size:  # T_B
                    q = _wedgie_priority(
                        v, e, _corners(bco, np.float64(dfl[j, 4]), y1, y0, dx, dz))
                    if q > p:
                        p = q
        mk[nm] = -p
        mi[nm] = did[j]
        nm += 1
    _heapify(mk, mi, nm, _TIE_M)
    return nm


@njit(cache=CACHE, fastmath=FASTMATH)
def _roam_ops(tree, view, split_q, merge_q, stack, recs, ivars, tau, max_ops, per_op):
    """Greedy split/merge loop of, at most ``max_ops`` operations.

    ``ivars`` = [ns, nm, count, max_triangles, splits, merges, ops] is updated in place.
    Returns a status code (``_MORE`` when the operation budget ran out, or when a queue or
    record array has less than ``per_op`` free entries — the caller grows it and resumes;
    ``_REFILL`` when a partial split queue ran empty — the caller rebuilds it with θ = 0).
    """
    state, size = tree[0], tree[3]
    sk, si = split_q
    mk, mi = merge_q
    leaves, diamonds, cnt = recs
    theta = view[0].theta
    ns, nm, count, nmax = ivars[0], ivars[1], ivars[2], ivars[3]
    status = _MORE
    ops = 0
    while ops < max_ops:
        if (
            ns + per_op > sk.shape[0]
            or nm + per_op > mk.shape[0]
            or (cnt[2] and cnt[0] + per_op > leaves[0].shape[0])
            or (cnt[2] and cnt[1] + per_op > diamonds[0].shape[0])
        ):
            break
        # lazy deletion: drop entries that are no longer leaves / mergeable diamonds
        while ns > 0 and state[si[0]] != LEAF:
            ns = _hpop(sk, si, ns, _TIE_S)
        if ns == 0 and theta > 0.0:  # leaves were left out: need the full queue
            status = _REFILL
            break
        while nm > 0 and not _mergeable(mi[0], state, size):
            nm = _hpop(mk, mi, nm, _TIE_M)
        ps = sk[0] if ns > 0 else 0.0
        pm = -mk[0] if nm > 0 else np.inf
        do_merge = False
        if count > nmax:  # too large: merge the lowest diamond
            if nm == 0:
                status = _NO_MERGE
                break
            do_merge = True
        elif ps > tau:  # too coarse somewhere
            # at the triangle budget (counting the forced splits): swap only if it lowers
            # the max. A split must never overshoot the budget: the overshoot would be
            # merged back regardless of priority — typically the diamond just created, which
            # makes the forced diamonds below it mergeable again, and merging those to make
            # room undoes the split, which the next pass repeats (an endless split/merge
            # flip). With every merge here below the top split priority, the top priority
            # never rises within the frame and no merged diamond is re-created and merged
            # again, so the loop ends after O(triangles changed) operations.
            if count + _split_cost(si[0], state, size) > nmax:
                if pm < ps:
                    do_merge = True
                else:
                    status = _TRIANGLES
                    break
        elif pm <= tau:  # fine enough everywhere: drop detail that is not needed
            do_merge = True
        else:
            status = _TOLERANCE
            break
        if do_merge:
            d = mi[0]
            nm = _hpop(mk, mi, nm, _TIE_M)
            ns, nm, removed = _merge(d, tree, view, split_q, ns, merge_q, nm, recs)
            count -= removed
            ivars[5] += 1
        else:
            t = si[0]
            ns = _hpop(sk, si, ns, _TIE_S)
            ns, nm, added = _force_split(t, tree, view, split_q, ns, merge_q, nm, stack, recs)
            count += added
            ivars[4] += 1
        ops += 1
    ivars[0], ivars[1], ivars[2] = ns, nm, count
    ivars[6] += ops
    return status


@njit(cache=CACHE, fastmath=FASTMATH)
def _roam_collect(state, size, out, stack):
    """Write the leaves as ``(apex, v0, v1)`` grid indices; returns the count."""
    n = size + 1
    m = 0
    sp = _walk_roots(stack, size)
    while sp > 0:
        sp -= 1
        x, co = _popped(stack, sp)
        st = state[x]
        if st == LEAF:
            ar, ac, r0, c0, r1, c1 = co
            out[m, 0] = ar * n + ac
            out[m, 1] = r0 * n + c0
            out[m, 2] = r1 * n + c1
            m += 1
        elif st == SPLIT:
            sp = _walk_children(stack, sp, x, co)
    return m


@njit(cache=CACHE, fastmath=FASTMATH)
def _leaf_ids(state, size, out):
    m = 0
    for t in range(2, state.shape[0]):
        if state[t] == LEAF:
            out[m] = t
            m += 1
    return m


@njit(cache=CACHE, fastmath=FASTMATH)
def _mergeable_ids(state, size, out):
    m = 0
    for t in range(2, state.shape[0] // 2):
        if state[t] == SPLIT and _mergeable(t, state, size) and _canonical(t, size) == t:
            out[m] = t
            m += 1
    return m


# --------------------------------------------------------------------------------------------
# public API
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RoamStats:
    """What one :meth:`Roam.update` did.

    Attributes
    ----------
    frame
        Frame number (1 for the first update).
    triangles
        Triangles in the mesh after the update.
    splits, merges
        Split operations (each including its forced splits) and diamond merges this frame.
    max_screen_error
        Largest priority over the leaves after the update: a conservative bound, in pixels,
        of the screen-space error of every visible part of the mesh (0 when exact).
    update_ms
        Wall time of the update (queue refresh + split/merge loop), milliseconds.
    stopped_by
        ``"tolerance"`` (every leaf within the pixel tolerance), ``"triangles"`` (triangle
        budget reached and no swap would lower the maximum error), ``"time"`` (time budget),
        or ``"operations"`` (safety limit on operations per frame).
    """

    frame: int
    triangles: int
    splits: int
    merges: int
    max_screen_error: float
    update_ms: float
    stopped_by: str

    @property
    def settled(self) -> bool:
        """False when the time budget stopped the update (the next one continues it)."""
        return self.stopped_by != "time"

    @property
    def summary(self) -> str:
        return f"max error {self.max_screen_error:.2f} px ({self.stopped_by})"


def _check_camera(camera):
    if not isinstance(camera, Camera):
        raise InvalidParameterError(
            f"camera must be a terrascape.camera.Camera, got {type(camera).__name__}"
        )
    for name in ("yaw", "pitch", "fov_y", "aspect", "near", "far"):
        check_finite(getattr(camera, name), f"camera {name}")
    if not np.isfinite(np.asarray(camera.position, dtype=np.float64)).all():
        raise InvalidParameterError(f"camera position must be finite, got {camera.position!r}")
    return camera


def _check_viewport(viewport) -> tuple[int, int]:
    try:
        width, height = viewport
        width = check_int(width, "viewport width (pixels)", minimum=1)
        height = check_int(height, "viewport height (pixels)", minimum=1)
    except (TypeError, ValueError) as exc:
        if isinstance(exc, InvalidParameterError):
            raise
        raise InvalidParameterError(
            f"viewport must be (width, height) in pixels, got {viewport!r}"
        ) from None
    return width, height


def _static_view(spacing) -> np.ndarray:
    """A :data:`VIEW` record for world-unit priorities (no camera)."""
    view = np.zeros(1, VIEW)
    view["static"] = 1.0
    view["dx"], view["dz"] = spacing  # for the records' bounding spheres
    return view


def camera_params(camera, viewport, spacing, *, cull: bool = True) -> np.ndarray:
    """Pack a camera for the kernels: a :data:`VIEW` record with eye, forward, frustum
    planes, near, ``K`` (see the module docstring) and spacing. Raises
    :class:`InvalidParameterError` for NaN cameras.

    ``cull=False`` packs a view without a frustum: priorities use the distance from the eye
    to each wedgie's bounding box instead of the view depth, so the mesh meets the tolerance
    in every direction (``K`` is then ``k_px``: a distance needs no off-axis factor)."""
    camera = _check_camera(camera)
    width, height = _check_viewport(viewport)
    view = np.zeros(1, VIEW)
    view["eye"] = camera.eye
    view["forward"] = camera.forward
    planes = camera.frustum_planes()
    if not np.isfinite(planes).all():
        raise InvalidParameterError("camera frustum planes are not finite (check the camera)")
    view["planes"] = planes
    view["near"] = camera.near
    tan_y = math.tan(math.radians(camera.fov_y) / 2.0)
    k_px = max(height / (2.0 * tan_y), width / (2.0 * tan_y * camera.aspect))
    view["k"] = k_px * math.sqrt(1.0 + tan_y * tan_y * (1.0 + camera.aspect**2))
    if not cull:
        view["k"] = k_px
        view["omni"] = 1.0
    view["dx"], view["dz"] = spacing
    return view


class Roam:
    """Duchaineau's ROAM with split and merge queues kept across frames.

    Parameters
    ----------
    heightmap
        Square ``(2**n + 1)²`` :class:`~terrascape.Heightmap` (pad others with
        ``Heightmap.to_pow2_plus1()`` / ``--pad``).

    Notes
    -----
    Memory: one byte per bintree node (``4·S²`` for ``S = 2**n`` cells per side) plus one
    float32 error per grid vertex, and per leaf / mergeable diamond a record (~60 bytes) and
    queue entries, which grow with the mesh. The per-frame refresh reads only the records,
    so its time depends on the triangle count, not on the map size.
    """

    def __init__(self, heightmap: Heightmap) -> None:
        if not isinstance(heightmap, Heightmap):
            raise InvalidParameterError(f"expected a Heightmap, got {type(heightmap).__name__}")
        n = heightmap.require_pow2_plus1("ROAM")
        self.heightmap = heightmap
        self.size = n - 1
        self.max_level = 2 * (self.size.bit_length() - 1)
        # entries one operation (a split with its forced splits, or a merge) can add to a
        # queue or a record set
        self._per_op = 4 * (self.max_level + 2)
        self._h = heightmap.heights
        self._err = wedgie_errors(self._h)
        self._state = np.zeros(4 * self.size * self.size, np.uint8)
        self._stack1 = np.zeros(4 * self.max_level + 16, np.int64)
        self._stack8 = np.zeros((2 * self.max_level + 8, 11), np.int64)
        self._sk = np.zeros(0, np.float64)
        self._si = np.zeros(0, np.int64)
        self._mk = np.zeros(0, np.float64)
        self._mi = np.zeros(0, np.int64)
        # records: [leaves, mergeable diamonds, kept per operation (1) or rebuilt (0)]
        self._cnt = np.array([0, 0, 1], np.int64)
        # hash keys: leaf ids < 4·S², diamond split vertices < (S + 1)²
        key_dtype = np.int32 if 4 * self.size * self.size < 2**31 else np.int64
        self._leaves = _alloc_records(1024, _LEAF_FIELDS, key_dtype)
        self._diamonds = _alloc_records(1024, _DIAMOND_FIELDS, key_dtype)
        self.frame = 0
        self.max_screen_error = math.inf
        self._theta_frac = _THETA_MAX
        self.rebuilds = 0  # full split-queue rebuilds after a partial one ran empty (stats)
        self._planes: np.ndarray | None = None  # last update's frustum (triangles())
        self.reset()

    # --- state -------------------------------------------------------------------------
    def reset(self) -> None:
        """Back to the base triangulation (the two root triangles)."""
        self._state[:] = ABSENT
        self._state[2] = self._state[3] = LEAF
        self._count = 2
        _records_reset(self._recs(), self._tree(), _static_view(self.heightmap.spacing))
        self.max_screen_error = math.inf

    # the kernels' bundles (see "The kernels take small named bundles" above)
    def _tree(self):
        return (self._state, self._h, self._err, np.int64(self.size), np.int64(self.max_level))

    def _recs(self):
        return (self._leaves, self._diamonds, self._cnt)

    @property
    def triangle_count(self) -> int:
        return self._count

    @property
    def error_bounds(self) -> np.ndarray:
        """Per-vertex nested wedgie thickness (world units), read-only."""
        v = self._err.view()
        v.flags.writeable = False
        return v

    def _ensure(self, split_extra: int, merge_extra: int, ns: int = 0, nm: int = 0) -> None:
        """Room for ``split_extra`` / ``merge_extra`` more queue entries than ``ns`` / ``nm``
        and for 64 operations' worth of new records, with doubling growth."""
        need_s = ns + split_extra
        if self._sk.size < need_s:
            cap = max(need_s, 2 * self._sk.size, 1024)
            sk, si = np.zeros(cap, np.float64), np.zeros(cap, np.int64)
            sk[:ns], si[:ns] = self._sk[:ns], self._si[:ns]
            self._sk, self._si = sk, si
        need_m = nm + merge_extra
        if self._mk.size < need_m:
            cap = max(need_m, 2 * self._mk.size, 1024)
            mk, mi = np.zeros(cap, np.float64), np.zeros(cap, np.int64)
            mk[:nm], mi[:nm] = self._mk[:nm], self._mi[:nm]
            self._mk, self._mi = mk, mi
        extra = 64 * self._per_op
        self._leaves = _grow_records(self._leaves, int(self._cnt[0]), extra)
        self._diamonds = _grow_records(self._diamonds, int(self._cnt[1]), extra)

    def _record_ids(self) -> tuple[np.ndarray, np.ndarray]:
        """Sorted ids of the leaf and diamond records (tests: they must equal
        :meth:`leaf_ids` and :meth:`mergeable_diamonds`)."""
        nl, nd = int(self._cnt[0]), int(self._cnt[1])
        return np.sort(self._leaves[0][:nl]), np.sort(self._diamonds[0][:nd])

    def _rebuild_split_queue(self, cam, nm: int) -> int:
        """Full split queue (θ = 0) for ``cam`` after a partial one ran empty; keeps the first
        ``nm`` merge queue entries. Returns the split queue's length."""
        cam["theta"] = 0.0
        self._ensure(int(self._cnt[0]) + 64 * self._per_op, 0, 0, nm)
        self.rebuilds += 1
        return int(_fill_split(cam, self._recs(), (self._sk, self._si)))

    def _run(self, cam, tau: float, nmax: int, budget_s: float | None, t0: float):
        """Refresh queues for ``cam`` and run the greedy loop. Returns (splits, merges, stop)."""
        per_op = self._per_op
        if int(self._cnt[0]) != self._count:  # pragma: no cover - internal consistency
            raise RuntimeError(f"ROAM leaf records drifted: {self._cnt[0]} != {self._count}")
        self._ensure(int(self._cnt[0]) + 64 * per_op, int(self._cnt[1]) + 64 * per_op)
        # partial split queue (see _fill_split): the leaves that can still be split this
        # frame are, by frame coherence, near the top of last frame's queue
        prev = self.max_screen_error
        dynamic = cam[0]["static"] == 0.0
        # from a (nearly) base mesh the frame is a build of many splits: records are rebuilt
        # once after it instead of per split (then the split queue must be full: a rebuild
        # of it would read the records)
        keep = self._count > _BUILD_FROM
        cam["theta"] = (self._theta_frac * prev if keep and dynamic and 0.0 < prev < math.inf
                        else 0.0)
        partial = cam[0]["theta"] > 0.0
        ns = _fill_split(cam, self._recs(), (self._sk, self._si))
        nm = _fill_merge(cam, np.int64(self.size), self._recs(), (self._mk, self._mi))
        ivars = np.array([ns, nm, self._count, nmax, 0, 0, 0], np.int64)
        self._cnt[2] = 1 if keep else 0
        try:
            stop = self._loop(cam, tau, budget_s, t0, ivars)
        finally:
            self._count = int(ivars[2])
            if not keep:
                self._leaves = _grow_records(self._leaves, 0, self._count + 64 * per_op)
                self._diamonds = _grow_records(self._diamonds, 0, self._count + 64 * per_op)
                _records_rebuild(self._tree(), cam, self._recs(), self._stack8)
                self._cnt[2] = 1
        # the split queue holds every leaf with a priority > max(0, θ), and left-out leaves
        # are below θ: its valid top is the maximum unless it ran empty
        ns = int(ivars[0])
        while ns > 0 and self._state[self._si[0]] != LEAF:
            ns = _hpop(self._sk, self._si, ns, _TIE_S)
        if ns == 0 and cam[0]["theta"] > 0.0:
            ns = self._rebuild_split_queue(cam, int(ivars[1]))
        if partial:
            if cam[0]["theta"] == 0.0:  # rebuilt this frame
                self._theta_frac = max(_THETA_MIN, self._theta_frac - _THETA_BACKOFF)
            else:
                self._theta_frac = min(_THETA_MAX, self._theta_frac + _THETA_STEP_UP)
        self.max_screen_error = float(self._sk[0]) if ns > 0 else 0.0
        return int(ivars[4]), int(ivars[5]), stop

    def _loop(self, cam, tau: float, budget_s: float | None, t0: float, ivars) -> str:
        """The greedy loop in chunks of operations; returns the stop reason."""
        per_op = self._per_op
        nmax = int(ivars[3])
        chunk = 64 if budget_s is not None else 4096
        finite_target = min(nmax, 2 * self.size * self.size)
        op_cap = 4 * (self._count + finite_target) + 10_000
        op_cap = chunk * -(-op_cap // chunk)  # whole chunks: the limit does not depend on
        # how often the kernel returns early to grow an array or rebuild the split queue
        stop = "operations"
        while ivars[6] < op_cap:
            # the kernel stops early (status _MORE) when a queue or record array is nearly
            # full; growing here and resuming is invisible to the result
            self._ensure(64 * per_op, 64 * per_op, int(ivars[0]), int(ivars[1]))
            status = _roam_ops(
                self._tree(), cam, (self._sk, self._si), (self._mk, self._mi), self._stack1,
                self._recs(), ivars, float(tau), np.int64(min(chunk, op_cap - int(ivars[6]))),
                np.int64(per_op),
            )
            if status == _REFILL:
                ivars[0] = self._rebuild_split_queue(cam, int(ivars[1]))
            elif status != _MORE:
                stop = _STOP_NAMES[status]
                break
            # also after a queue rebuild: a frame far from its converged mesh refills often
            if budget_s is not None and time.perf_counter() - t0 >= budget_s:
                stop = "time"
                break
        return stop

    # --- per frame -----------------------------------------------------------------------
    def update(
        self,
        camera,
        viewport: tuple[int, int],
        *,
        tolerance_px: float | None = None,
        max_triangles: int | None = None,
        time_budget_ms: float | None = None,
        cull: bool = True,
    ) -> RoamStats:
        """Adapt the mesh to a new view, starting from the previous frame's mesh.

        Parameters
        ----------
        camera
            :class:`~terrascape.camera.Camera`.
        viewport
            ``(width, height)`` in pixels.
        tolerance_px
            Screen-space error tolerance τ in pixels (> 0): refine until every leaf's
            priority is <= τ, and merge diamonds whose merge priority is <= τ. Default 1 px
            when ``max_triangles`` is not given either; otherwise 0 (refine as far as the
            triangle budget allows).
        max_triangles
            Triangle budget (>= 2): never exceed it at the end of the update; at the budget,
            keep swapping merges for splits while that lowers the maximum priority.
        time_budget_ms
            Stop splitting/merging after this much wall time (> 0, milliseconds; checked
            every 64 operations). The mesh is always valid when the update returns.
        cull
            Leave what is outside the view frustum coarse (default). ``False`` meets the
            tolerance in every direction, as a mesh built for all views around the eye
            (the like-for-like comparison with LOD schemes that do not cull).

        Returns
        -------
        RoamStats
        """
        t0 = time.perf_counter()
        if tolerance_px is not None:
            tau = check_positive(tolerance_px, "tolerance_px (pixels)")
        else:
            tau = 1.0 if max_triangles is None else 0.0
        nmax = _check_max_triangles(max_triangles)
        budget = None
        if time_budget_ms is not None:
            budget = check_positive(time_budget_ms, "time_budget_ms (milliseconds)") / 1000.0
        cam = camera_params(camera, viewport, self.heightmap.spacing, cull=bool(cull))
        self._planes = cam[0]["planes"].copy()
        splits, merges, stop = self._run(cam, tau, nmax, budget, t0)
        self.frame += 1
        return RoamStats(
            frame=self.frame,
            triangles=self._count,
            splits=splits,
            merges=merges,
            max_screen_error=self.max_screen_error,
            update_ms=(time.perf_counter() - t0) * 1000.0,
            stopped_by=stop,
        )

    def triangles(self, *, visible_only: bool = False) -> np.ndarray:
        """The current mesh: uint32 ``(M, 3)`` grid vertex indices ``row·cols + col``,
        counter-clockwise seen from above (+Y).

        ROAM keeps the whole map (leaves outside the view stay coarse); ``visible_only``
        leaves out the triangles whose three corners are all outside one plane of the last
        update's view frustum (such a triangle cannot be seen).
        """
        out = np.empty((self._count, 3), np.uint32)
        m = _roam_collect(self._state, np.int64(self.size), out, self._stack8)
        tris = out[:m]
        if visible_only and self._planes is not None:
            tris = tris[_in_frustum(self.heightmap, tris, self._planes)]
        return tris

    # --- direct bintree operations (tools, tests) ------------------------------------------
    def leaf_ids(self) -> np.ndarray:
        """Heap ids of the current leaf triangles (see :mod:`terrascape.lod.bintree`)."""
        out = np.empty(self._count, np.int64)
        m = _leaf_ids(self._state, np.int64(self.size), out)
        return out[:m]

    def mergeable_diamonds(self) -> np.ndarray:
        """Canonical ids (smaller of the pair) of the diamonds that can be merged."""
        out = np.empty(self._count, np.int64)
        m = _mergeable_ids(self._state, np.int64(self.size), out)
        return out[:m]

    def _static_cam(self) -> np.ndarray:
        return _static_view(self.heightmap.spacing)

    def force_split(self, tri: int) -> int:
        """Split leaf ``tri`` with the forced splits that keep the mesh conforming.
        Returns the number of triangles added."""
        tri = check_int(tri, "triangle id", minimum=2, maximum=self._state.size - 1)
        if self._state[tri] != LEAF:
            raise InvalidParameterError(f"triangle {tri} is not a leaf of the current mesh")
        if _level(tri) >= self.max_level:
            raise InvalidParameterError(f"triangle {tri} is at the finest level; cannot split")
        self._ensure(self._per_op, self._per_op)
        _, _, added = _force_split(
            np.int64(tri), self._tree(), self._static_cam(), (self._sk, self._si), 0,
            (self._mk, self._mi), 0, self._stack1, self._recs(),
        )
        self._count += int(added)
        return int(added)

    def merge(self, diamond: int) -> int:
        """Merge a mergeable diamond (either triangle's id). Returns triangles removed."""
        diamond = check_int(diamond, "diamond id", minimum=2, maximum=self._state.size // 2 - 1)
        if not _mergeable(np.int64(diamond), self._state, np.int64(self.size)):
            raise InvalidParameterError(f"diamond {diamond} is not mergeable in the current mesh")
        self._ensure(8, 8)
        _, _, removed = _merge(
            np.int64(diamond), self._tree(), self._static_cam(), (self._sk, self._si), 0,
            (self._mk, self._mi), 0, self._recs(),
        )
        self._count -= int(removed)
        return int(removed)


def _in_frustum(heightmap: Heightmap, tris: np.ndarray, planes: np.ndarray) -> np.ndarray:
    """bool per triangle: False when its three corners are all outside one frustum plane."""
    cols = heightmap.cols
    dx, dz = heightmap.spacing
    flat = tris.astype(np.int64)
    h = heightmap.heights.reshape(-1).astype(np.float64)
    x, z, y = (flat % cols) * dx, (flat // cols) * dz, h[flat]
    outside = np.zeros(len(tris), np.bool_)
    for a, b, c, d in planes:
        outside |= np.all(a * x + b * y + c * z + d < 0.0, axis=1)
    return ~outside


def _check_max_triangles(max_triangles) -> int:
    if max_triangles is None:
        return np.iinfo(np.int64).max // 4
    return check_int(max_triangles, "max_triangles", minimum=2)


def roam_mesh(
    heightmap: Heightmap, *, max_error: float | None = None, max_triangles: int | None = None
) -> np.ndarray:
    """Static ROAM mesh: greedy top-down refinement by the nested wedgie bound.

    Starting from the two root triangles, the leaf with the largest wedgie thickness is split
    (with forced splits) until every leaf's thickness is <= ``max_error`` or the next split
    would exceed ``max_triangles``. The thickness is a TRUE bound (see
    :mod:`terrascape.lod.bintree`), so when the error target is reached every grid sample is
    within ``max_error`` of the mesh, measured vertically.

    Parameters
    ----------
    heightmap
        Square ``(2**n + 1)²`` :class:`~terrascape.Heightmap`.
    max_error
        Vertical error bound in world units (>= 0; 0 keeps every non-coplanar vertex).
        Defaults to 0 when ``max_triangles`` is not given.
    max_triangles
        Triangle budget (>= 2).

    Returns
    -------
    numpy.ndarray
        uint32 ``(M, 3)`` grid vertex indices, counter-clockwise seen from above (+Y).
    """
    if max_error is not None:
        tau = check_positive(max_error, "max_error (world units)", allow_zero=True)
    else:
        tau = 0.0
    nmax = _check_max_triangles(max_triangles)
    roam = Roam(heightmap)
    roam._run(roam._static_cam(), tau, nmax, None, time.perf_counter())
    return roam.triangles()
