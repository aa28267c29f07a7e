"""ROAM — Real-time Optimally Adapting Meshes (Duchaineau et al. 1997; seed 001 §4.1).

A binary triangle tree over a ``(2**n + 1)²`` heightmap (two root triangles,
:mod:`terrascape.lod.bintree`) is kept as a triangulation that changes from frame to frame
by *splits* (with recursive forced splits of the base neighbour, §4.1.2, Slika 21) and
*merges* of mergeable diamonds. Two priority queues drive it (§4.1.3):

* the split queue ``Q_s`` holds every leaf triangle, keyed by its priority;
* the merge queue ``Q_m`` holds every mergeable diamond ``(T, T_B)`` — both split, all four
  children leaves — keyed by ``max{p(T), p(T_B)}``.

Each frame starts from the previous triangulation (frame coherence); the priorities of all
queue elements are refreshed for the new camera (the seed's "osvježi prioritete za sve
elemente Q_s, Q_m") and the greedy loop splits the highest-priority triangle or merges the
lowest-priority diamond until the targets are met: a screen-space error tolerance (pixels),
a triangle count, and a time budget, whichever comes first. With a triangle budget the loop
keeps swapping (merge the lowest diamond, split the highest triangle) while the highest
split priority exceeds the lowest merge priority, as in the seed's pseudocode.

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
entirely outside one frustum plane gets priority 0 (the seed's "outside → lowest"). Because
the wedgies are nested, ``p`` is monotonic (a child never has a higher priority than its
parent), as the greedy queues require. A sample with vertical error δ at distance d inside
the view therefore has ``δ·K'/d <= p(T)`` for the metric of
:func:`terrascape.lod.mesh_checks.max_screen_error` (``K' = v_res / (2·tan(fov_y/2))``).

Output: ``uint32 (M, 3)`` grid vertex indices ``row·cols + col`` into the full-resolution
grid, counter-clockwise seen from above (+Y), the winding of the full-resolution mesh.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit
from terrascape._validate import check_finite, check_int, check_positive
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.lod.bintree import (
    _level,
    _partner,
    _tri_coords,
    wedgie_errors,
)

__all__ = ["Roam", "RoamStats", "roam_mesh"]

ABSENT, LEAF, SPLIT = 0, 1, 2

# camera parameter vector layout (one float64 array keeps the kernels' signatures short)
_EYE, _FWD, _PLANES, _NEAR, _K, _STATIC, _DX, _DZ, _NCAM = 0, 3, 6, 30, 31, 32, 33, 34, 35

# loop status codes returned by _roam_ops
_MORE, _TOLERANCE, _TRIANGLES, _NO_MERGE = 0, 1, 2, 3
_STOP_NAMES = {_TOLERANCE: "tolerance", _TRIANGLES: "triangles", _NO_MERGE: "triangles"}


# --------------------------------------------------------------------------------------------
# binary max-heaps on (key float64, id int64) arrays; the merge queue stores −priority
# --------------------------------------------------------------------------------------------
@njit(cache=CACHE, fastmath=FASTMATH)
def _sift_down(keys, ids, n, i):
    k = keys[i]
    v = ids[i]
    while True:
        c = 2 * i + 1
        if c >= n:
            break
        if c + 1 < n and keys[c + 1] > keys[c]:
            c += 1
        if keys[c] <= k:
            break
        keys[i] = keys[c]
        ids[i] = ids[c]
        i = c
    keys[i] = k
    ids[i] = v


@njit(cache=CACHE, fastmath=FASTMATH)
def _hpush(keys, ids, n, k, v):
    i = n
    while i > 0:
        p = (i - 1) >> 1
        if keys[p] >= k:
            break
        keys[i] = keys[p]
        ids[i] = ids[p]
        i = p
    keys[i] = k
    ids[i] = v
    return n + 1


@njit(cache=CACHE, fastmath=FASTMATH)
def _hpop(keys, ids, n):
    n -= 1
    if n > 0:
        keys[0] = keys[n]
        ids[0] = ids[n]
        _sift_down(keys, ids, n, 0)
    return n


@njit(cache=CACHE, fastmath=FASTMATH)
def _heapify(keys, ids, n):
    for i in range(n // 2 - 1, -1, -1):
        _sift_down(keys, ids, n, i)


# --------------------------------------------------------------------------------------------
# priorities
# --------------------------------------------------------------------------------------------
@njit(cache=CACHE, fastmath=FASTMATH)
def _wedgie_priority(e, xa, ya, za, x0, y0, z0, x1, y1, z1,
                     planes, ex, ey, ez, fx, fy, fz, near, kpx):  # fmt: skip
    """Screen-space priority of a wedgie of thickness ``e > 0`` over the triangle with the
    given world corners.

    Frustum: exact "all six wedgie corners outside one plane" test, short-cut by the
    wedgie's bounding sphere (a sphere inside a plane needs no corner test). Exactness
    matters: culling must be nested like the wedgies so priorities stay monotonic. Depth:
    the exact minimum over the six wedgie corners.
    """
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
    rad = math.sqrt(r2 + (0.5 * (yhi - ylo)) ** 2)
    for k in range(6):
        a, b, c, d = planes[k, 0], planes[k, 1], planes[k, 2], planes[k, 3]
        if a * cx + b * cy + c * cz + d >= rad:
            continue  # sphere inside this plane, so is the wedgie
        # straddling sphere: exact test on the wedgie corners (a triangle corner ± e along
        # Y), which keeps culling nested (a child of a culled wedgie is culled)
        best = max(a * xa + b * ya + c * za, a * x0 + b * y0 + c * z0, a * x1 + b * y1 + c * z1)
        if best + d + e * abs(b) < 0.0:
            return 0.0  # entirely outside one plane: lowest priority
    da = (xa - ex) * fx + (ya - ey) * fy + (za - ez) * fz
    d0 = (x0 - ex) * fx + (y0 - ey) * fy + (z0 - ez) * fz
    d1 = (x1 - ex) * fx + (y1 - ey) * fy + (z1 - ez) * fz
    zmin = min(da, d0, d1) - e * abs(fy)
    if zmin < near:
        zmin = near
    return e * kpx / zmin


@njit(cache=CACHE, fastmath=FASTMATH)
def _priority(cam, h, err, level, max_lvl, ar, ac, r0, c0, r1, c1):
    """Projected wedgie thickness in pixels (module docstring); 0 outside the frustum or for
    an exact triangle. In static mode (``cam[_STATIC] > 0``) the world-unit bound itself."""
    if level >= max_lvl:
        return 0.0
    e = np.float64(err[(r0 + r1) >> 1, (c0 + c1) >> 1])
    if e <= 0.0:
        return 0.0
    if cam[_STATIC] > 0.0:
        return e
    dx = cam[_DX]
    dz = cam[_DZ]
    planes = cam[_PLANES : _PLANES + 24].reshape((6, 4))
    return _wedgie_priority(
        e, ac * dx, np.float64(h[ar, ac]), ar * dz, c0 * dx, np.float64(h[r0, c0]), r0 * dz,
        c1 * dx, np.float64(h[r1, c1]), r1 * dz, planes, cam[_EYE], cam[_EYE + 1],
        cam[_EYE + 2], cam[_FWD], cam[_FWD + 1], cam[_FWD + 2], cam[_NEAR], cam[_K],
    )  # fmt: skip


@njit(cache=CACHE, fastmath=FASTMATH)
def _diamond_priority(t, cam, h, err, size, max_lvl):
    """``max{p(T), p(T_B)}`` of the diamond containing ``t`` (T_B's corners are mirrored)."""
    ar, ac, r0, c0, r1, c1 = _tri_coords(t, size)
    lvl = _level(t)
    p = _priority(cam, h, err, lvl, max_lvl, ar, ac, r0, c0, r1, c1)
    br = r0 + r1 - ar
    bc = c0 + c1 - ac
    if 0 <= br <= size and 0 <= bc <= size:
        q = _priority(cam, h, err, lvl, max_lvl, br, bc, r1, c1, r0, c0)
        if q > p:
            p = q
    return p


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
def _split_one(t, state, h, err, cam, size, max_lvl, sk, si, ns):
    """Replace leaf ``t`` by its children ``T0 = (v_c, v_a, v_0)``, ``T1 = (v_c, v_1, v_a)``
    and queue them."""
    state[t] = SPLIT
    state[2 * t] = LEAF
    state[2 * t + 1] = LEAF
    ar, ac, r0, c0, r1, c1 = _tri_coords(t, size)
    mr = (r0 + r1) >> 1
    mc = (c0 + c1) >> 1
    lvl = _level(t) + 1
    p = _priority(cam, h, err, lvl, max_lvl, mr, mc, ar, ac, r0, c0)
    if p > 0.0:
        ns = _hpush(sk, si, ns, p, 2 * t)
    p = _priority(cam, h, err, lvl, max_lvl, mr, mc, r1, c1, ar, ac)
    if p > 0.0:
        ns = _hpush(sk, si, ns, p, 2 * t + 1)
    return ns


@njit(cache=CACHE, fastmath=FASTMATH)
def _force_split(t, state, h, err, cam, size, max_lvl, sk, si, ns, mk, mi, nm, stack):
    """Split leaf ``t`` together with its base neighbour; a coarser base neighbour is force
    split first, recursively (explicit stack). Returns ``(ns, nm, leaves_added)``."""
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
        b = _partner(x, size)
        if b >= 0 and state[b] == ABSENT:  # T_B is coarser: its parent must split first
            stack[sp] = b >> 1
            sp += 1
            continue
        ns = _split_one(x, state, h, err, cam, size, max_lvl, sk, si, ns)
        added += 1
        if b >= 0 and state[b] == LEAF:
            ns = _split_one(b, state, h, err, cam, size, max_lvl, sk, si, ns)
            added += 1
        d = x if (b < 0 or x < b) else b
        nm = _hpush(mk, mi, nm, -_diamond_priority(d, cam, h, err, size, max_lvl), d)
        sp -= 1
    return ns, nm, added


@njit(cache=CACHE, fastmath=FASTMATH)
def _merge(d, state, h, err, cam, size, max_lvl, sk, si, ns, mk, mi, nm):
    """Merge the (mergeable) diamond of ``d``; queue the parents and any diamond one level up
    that became mergeable. Returns ``(ns, nm, leaves_removed)``."""
    b = _partner(d, size)
    removed = 0
    lvl = _level(d)
    for k in range(2):
        x = d if k == 0 else b
        if x < 0:
            continue
        state[2 * x] = ABSENT
        state[2 * x + 1] = ABSENT
        state[x] = LEAF
        removed += 1
        ar, ac, r0, c0, r1, c1 = _tri_coords(x, size)
        p = _priority(cam, h, err, lvl, max_lvl, ar, ac, r0, c0, r1, c1)
        if p > 0.0:
            ns = _hpush(sk, si, ns, p, x)
    for k in range(2):
        x = d if k == 0 else b
        if x < 4:  # roots have no parent
            continue
        par = x >> 1
        if _mergeable(par, state, size):
            dd = _canonical(par, size)
            nm = _hpush(mk, mi, nm, -_diamond_priority(dd, cam, h, err, size, max_lvl), dd)
    return ns, nm, removed


# --------------------------------------------------------------------------------------------
# per-frame refresh, greedy loop, output
# --------------------------------------------------------------------------------------------
@njit(cache=CACHE, fastmath=FASTMATH)
def _push_node(stack, sp, x, lvl, ar, ac, r0, c0, r1, c1, b, lf, rt):
    stack[sp, 0], stack[sp, 1] = x, lvl
    stack[sp, 2], stack[sp, 3], stack[sp, 4] = ar, ac, r0
    stack[sp, 5], stack[sp, 6], stack[sp, 7] = c0, r1, c1
    stack[sp, 8], stack[sp, 9], stack[sp, 10] = b, lf, rt
    return sp + 1


@njit(cache=CACHE, fastmath=FASTMATH)
def _priorities(cam, h, err, max_lvl, tasks, n, out):
    """``out[i]`` = priority of the triangle ``tasks[i] = (level, ar, ac, r0, c0, r1, c1)``.

    The same computation as :func:`_priority`, as one flat loop for the per-frame refresh.
    """
    static = cam[_STATIC] > 0.0
    dx, dz, near, kpx = cam[_DX], cam[_DZ], cam[_NEAR], cam[_K]
    ex, ey, ez = cam[_EYE], cam[_EYE + 1], cam[_EYE + 2]
    fx, fy, fz = cam[_FWD], cam[_FWD + 1], cam[_FWD + 2]
    planes = cam[_PLANES : _PLANES + 24].reshape((6, 4))
    for i in range(n):
        lvl, ar, ac, r0, c0 = tasks[i, 0], tasks[i, 1], tasks[i, 2], tasks[i, 3], tasks[i, 4]
        r1, c1 = tasks[i, 5], tasks[i, 6]
        p = 0.0
        if lvl < max_lvl:
            e = np.float64(err[(r0 + r1) >> 1, (c0 + c1) >> 1])
            if e > 0.0:
                if static:
                    p = e
                else:
                    xa, ya, za = ac * dx, np.float64(h[ar, ac]), ar * dz
                    x0, y0, z0 = c0 * dx, np.float64(h[r0, c0]), r0 * dz
                    x1, y1, z1 = c1 * dx, np.float64(h[r1, c1]), r1 * dz
                    p = _wedgie_priority(
                        e, xa, ya, za, x0, y0, z0, x1, y1, z1,
                        planes, ex, ey, ez, fx, fy, fz, near, kpx,
                    )  # fmt: skip
        out[i] = p


@njit(cache=CACHE, fastmath=FASTMATH)
def _push_node(stack, sp, x, lvl, ar, ac, r0, c0, r1, c1, b, lf, rt):
    stack[sp, 0], stack[sp, 1] = x, lvl
    stack[sp, 2], stack[sp, 3], stack[sp, 4] = ar, ac, r0
    stack[sp, 5], stack[sp, 6], stack[sp, 7] = c0, r1, c1
    stack[sp, 8], stack[sp, 9], stack[sp, 10] = b, lf, rt
    return sp + 1


@njit(cache=CACHE, fastmath=FASTMATH)
def _add_task(tasks, n, lvl, ar, ac, r0, c0, r1, c1):
    tasks[n, 0], tasks[n, 1], tasks[n, 2], tasks[n, 3] = lvl, ar, ac, r0
    tasks[n, 4], tasks[n, 5], tasks[n, 6] = c0, r1, c1
    return n + 1


@njit(cache=CACHE, fastmath=FASTMATH)
def _roam_refresh(state, h, err, cam, size, max_lvl, sk, si, mk, mi, stack, tasks, pri):
    """Rebuild both queues from the current triangulation with priorities for ``cam``.

    1. Depth-first walk carrying each node's corners and its same-level neighbours (base,
       left, right) in the uniform bintree, so no node needs a coordinate walk or a
       neighbour search. The neighbours follow from the parent's: with T = (v_a, v_0, v_1),
       base B, left neighbour L and right neighbour R (a shared leg is always one
       triangle's left and the other's right edge),

           T0: base 2L + 1, left 2T + 1, right 2B + 1;   T1: base 2R, left 2B, right 2T.

       Leaves, and both triangles of every mergeable diamond, go to a task list.
    2. One flat loop computes all priorities (:func:`_priorities`).
    3. Both queues are filled and heapified.

    ``tasks`` needs ``leaves + 2·diamonds`` rows. Returns ``(ns, nm, leaves)``.
    """
    nt = 0
    leaves = 0
    ndia = 0
    sp = _push_node(stack, 0, 2, 0, size, 0, size, size, 0, 0, 3, -1, -1)
    sp = _push_node(stack, sp, 3, 0, 0, size, 0, 0, size, size, 2, -1, -1)
    # task ids: leaf x as x, diamond canonical x as -x (two consecutive tasks)
    while sp > 0:
        sp -= 1
        x, lvl = stack[sp, 0], stack[sp, 1]
        ar, ac, r0, c0 = stack[sp, 2], stack[sp, 3], stack[sp, 4], stack[sp, 5]
        r1, c1 = stack[sp, 6], stack[sp, 7]
        b, lf, rt = stack[sp, 8], stack[sp, 9], stack[sp, 10]
        st = state[x]
        if st == LEAF:
            leaves += 1
            si[nt] = x
            nt = _add_task(tasks, nt, lvl, ar, ac, r0, c0, r1, c1)
        elif st == SPLIT:
            mr = (r0 + r1) >> 1
            mc = (c0 + c1) >> 1
            sp = _push_node(
                stack, sp, 2 * x, lvl + 1, mr, mc, ar, ac, r0, c0,
                2 * lf + 1 if lf >= 0 else -1, 2 * x + 1, 2 * b + 1 if b >= 0 else -1,
            )  # fmt: skip
            sp = _push_node(
                stack, sp, 2 * x + 1, lvl + 1, mr, mc, r1, c1, ar, ac,
                2 * rt if rt >= 0 else -1, 2 * b if b >= 0 else -1, 2 * x,
            )  # fmt: skip
            if (
                state[2 * x] == LEAF
                and state[2 * x + 1] == LEAF
                and (
                    b < 0
                    or (
                        b > x
                        and state[b] == SPLIT
                        and state[2 * b] == LEAF
                        and state[2 * b + 1] == LEAF
                    )
                )
            ):
                ndia += 1
                si[nt] = -x
                nt = _add_task(tasks, nt, lvl, ar, ac, r0, c0, r1, c1)
                # the partner (mirrored apex); a border diamond repeats its single triangle
                if b >= 0:
                    si[nt] = 0
                    nt = _add_task(tasks, nt, lvl, r0 + r1 - ar, c0 + c1 - ac, r1, c1, r0, c0)
                else:
                    si[nt] = 0
                    nt = _add_task(tasks, nt, lvl, ar, ac, r0, c0, r1, c1)
    _priorities(cam, h, err, max_lvl, tasks, nt, pri)
    ns = 0
    nm = 0
    i = 0
    while i < nt:
        x = si[i]
        if x > 0:
            if pri[i] > 0.0:
                sk[ns] = pri[i]
                si[ns] = x  # ns <= i: compacting in place is safe
                ns += 1
            i += 1
        else:
            mk[nm] = -max(pri[i], pri[i + 1])
            mi[nm] = -x
            nm += 1
            i += 2
    _heapify(sk, si, ns)
    _heapify(mk, mi, nm)
    return ns, nm, leaves


@njit(cache=CACHE, fastmath=FASTMATH)
def _roam_ops(state, h, err, cam, size, max_lvl, sk, si, mk, mi, stack, ivars, tau, max_ops):
    """Greedy split/merge loop of seed §4.1.3, at most ``max_ops`` operations.

    ``ivars`` = [ns, nm, count, max_triangles, splits, merges] is updated in place.
    Returns a status code (``_MORE`` when the operation budget ran out).
    """
    ns, nm, count, nmax = ivars[0], ivars[1], ivars[2], ivars[3]
    status = _MORE
    ops = 0
    while ops < max_ops:
        # lazy deletion: drop entries that are no longer leaves / mergeable diamonds
        while ns > 0 and state[si[0]] != LEAF:
            ns = _hpop(sk, si, ns)
        while nm > 0 and not _mergeable(mi[0], state, size):
            nm = _hpop(mk, mi, nm)
        ps = sk[0] if ns > 0 else 0.0
        pm = -mk[0] if nm > 0 else np.inf
        do_merge = False
        if count > nmax:  # too large: merge the lowest diamond
            if nm == 0:
                status = _NO_MERGE
                break
            do_merge = True
        elif ps > tau:  # too coarse somewhere
            if count + 2 > nmax:  # at the triangle budget: swap only if it lowers the max
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
            nm = _hpop(mk, mi, nm)
            ns, nm, removed = _merge(d, state, h, err, cam, size, max_lvl, sk, si, ns, mk, mi, nm)
            count -= removed
            ivars[5] += 1
        else:
            t = si[0]
            ns = _hpop(sk, si, ns)
            ns, nm, added = _force_split(
                t, state, h, err, cam, size, max_lvl, sk, si, ns, mk, mi, nm, stack
            )
            count += added
            ivars[4] += 1
        ops += 1
    ivars[0], ivars[1], ivars[2] = ns, nm, count
    return status


@njit(cache=CACHE, fastmath=FASTMATH)
def _roam_collect(state, size, out, stack):
    """Write the leaves as ``(apex, v0, v1)`` grid indices; returns the count."""
    n = size + 1
    m = 0
    sp = 0
    for root in range(2, 4):
        stack[sp, 0] = root
        if root == 2:
            stack[sp, 2], stack[sp, 3], stack[sp, 4] = size, 0, size
            stack[sp, 5], stack[sp, 6], stack[sp, 7] = size, 0, 0
        else:
            stack[sp, 2], stack[sp, 3], stack[sp, 4] = 0, size, 0
            stack[sp, 5], stack[sp, 6], stack[sp, 7] = 0, size, size
        sp += 1
    while sp > 0:
        sp -= 1
        x = stack[sp, 0]
        ar, ac, r0, c0 = stack[sp, 2], stack[sp, 3], stack[sp, 4], stack[sp, 5]
        r1, c1 = stack[sp, 6], stack[sp, 7]
        st = state[x]
        if st == LEAF:
            out[m, 0] = ar * n + ac
            out[m, 1] = r0 * n + c0
            out[m, 2] = r1 * n + c1
            m += 1
        elif st == SPLIT:
            mr = (r0 + r1) >> 1
            mc = (c0 + c1) >> 1
            stack[sp, 0] = 2 * x
            stack[sp, 2], stack[sp, 3], stack[sp, 4] = mr, mc, ar
            stack[sp, 5], stack[sp, 6], stack[sp, 7] = ac, r0, c0
            sp += 1
            stack[sp, 0] = 2 * x + 1
            stack[sp, 2], stack[sp, 3], stack[sp, 4] = mr, mc, r1
            stack[sp, 5], stack[sp, 6], stack[sp, 7] = c1, ar, ac
            sp += 1
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


def _check_camera(camera):
    from terrascape.camera import Camera

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


def camera_params(camera, viewport, spacing) -> np.ndarray:
    """Pack a camera for the kernels: eye, forward, frustum planes, near, ``K`` (see the
    module docstring), spacing. Raises :class:`InvalidParameterError` for NaN cameras."""
    camera = _check_camera(camera)
    width, height = _check_viewport(viewport)
    cam = np.zeros(_NCAM, np.float64)
    cam[_EYE : _EYE + 3] = camera.eye
    cam[_FWD : _FWD + 3] = camera.forward
    planes = camera.frustum_planes()
    if not np.isfinite(planes).all():
        raise InvalidParameterError("camera frustum planes are not finite (check the camera)")
    cam[_PLANES : _PLANES + 24] = planes.reshape(-1)
    cam[_NEAR] = camera.near
    tan_y = math.tan(math.radians(camera.fov_y) / 2.0)
    k_px = max(height / (2.0 * tan_y), width / (2.0 * tan_y * camera.aspect))
    cam[_K] = k_px * math.sqrt(1.0 + tan_y * tan_y * (1.0 + camera.aspect**2))
    cam[_DX], cam[_DZ] = spacing
    return cam


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
    float32 error per grid vertex; the queues grow with the mesh. Nothing is allocated per
    triangle.
    """

    def __init__(self, heightmap: Heightmap) -> None:
        if not isinstance(heightmap, Heightmap):
            raise InvalidParameterError(f"expected a Heightmap, got {type(heightmap).__name__}")
        n = heightmap.require_pow2_plus1("ROAM")
        self.heightmap = heightmap
        self.size = n - 1
        self.max_level = 2 * (self.size.bit_length() - 1)
        self._h = heightmap.heights
        self._err = wedgie_errors(self._h)
        self._state = np.zeros(4 * self.size * self.size, np.uint8)
        self._stack1 = np.zeros(4 * self.max_level + 16, np.int64)
        self._stack8 = np.zeros((2 * self.max_level + 8, 11), np.int64)
        self._sk = np.zeros(0, np.float64)
        self._si = np.zeros(0, np.int64)
        self._mk = np.zeros(0, np.float64)
        self._mi = np.zeros(0, np.int64)
        self._tasks = np.zeros((0, 7), np.int32)
        self._pri = np.zeros(0, np.float64)
        self.frame = 0
        self.max_screen_error = math.inf
        self.reset()

    # --- state -------------------------------------------------------------------------
    def reset(self) -> None:
        """Back to the base triangulation (the two root triangles)."""
        self._state[:] = ABSENT
        self._state[2] = self._state[3] = LEAF
        self._count = 2
        self.max_screen_error = math.inf

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

    def _run(self, cam, tau: float, nmax: int, budget_s: float | None, t0: float):
        """Refresh queues for ``cam`` and run the greedy loop. Returns (splits, merges, stop)."""
        size, lvl = np.int64(self.size), np.int64(self.max_level)
        self._ensure(2 * self._count + 16, self._count // 2 + 16)
        if self._tasks.shape[0] < 2 * self._count + 16:
            self._tasks = np.zeros((4 * self._count + 64, 7), np.int32)
            self._pri = np.zeros(4 * self._count + 64, np.float64)
        ns, nm, leaves = _roam_refresh(
            self._state, self._h, self._err, cam, size, lvl, self._sk, self._si,
            self._mk, self._mi, self._stack8, self._tasks, self._pri,
        )  # fmt: skip
        if leaves != self._count:  # pragma: no cover - internal consistency
            raise RuntimeError(f"ROAM leaf count drifted: {leaves} != {self._count}")
        ivars = np.array([ns, nm, self._count, nmax, 0, 0], np.int64)
        chunk = 64 if budget_s is not None else 4096
        per_op = 4 * (self.max_level + 2)
        finite_target = min(nmax, 2 * self.size * self.size)
        op_cap = 4 * (self._count + finite_target) + 10_000
        ops_done = 0
        stop = "operations"
        while ops_done < op_cap:
            self._ensure(chunk * per_op, chunk * per_op, int(ivars[0]), int(ivars[1]))
            status = _roam_ops(
                self._state, self._h, self._err, cam, size, lvl, self._sk, self._si,
                self._mk, self._mi, self._stack1, ivars, float(tau), np.int64(chunk),
            )  # fmt: skip
            ops_done += chunk
            if status != _MORE:
                stop = _STOP_NAMES[status]
                break
            if budget_s is not None and time.perf_counter() - t0 >= budget_s:
                stop = "time"
                break
        self._count = int(ivars[2])
        # the split queue holds every leaf with a non-zero priority: its valid top is the max
        ns = int(ivars[0])
        while ns > 0 and self._state[self._si[0]] != LEAF:
            ns = _hpop(self._sk, self._si, ns)
        self.max_screen_error = float(self._sk[0]) if ns > 0 else 0.0
        return int(ivars[4]), int(ivars[5]), stop

    # --- per frame -----------------------------------------------------------------------
    def update(
        self,
        camera,
        viewport: tuple[int, int],
        *,
        tolerance_px: float | None = None,
        max_triangles: int | None = None,
        time_budget_ms: float | None = None,
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
        cam = camera_params(camera, viewport, self.heightmap.spacing)
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

    def triangles(self) -> np.ndarray:
        """The current mesh: uint32 ``(M, 3)`` grid vertex indices ``row·cols + col``,
        counter-clockwise seen from above (+Y)."""
        out = np.empty((self._count, 3), np.uint32)
        m = _roam_collect(self._state, np.int64(self.size), out, self._stack8)
        return out[:m]

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
        cam = np.zeros(_NCAM, np.float64)
        cam[_STATIC] = 1.0
        return cam

    def force_split(self, tri: int) -> int:
        """Split leaf ``tri`` with the forced splits that keep the mesh conforming.
        Returns the number of triangles added."""
        tri = check_int(tri, "triangle id", minimum=2, maximum=self._state.size - 1)
        if self._state[tri] != LEAF:
            raise InvalidParameterError(f"triangle {tri} is not a leaf of the current mesh")
        if _level(tri) >= self.max_level:
            raise InvalidParameterError(f"triangle {tri} is at the finest level; cannot split")
        per = 4 * (self.max_level + 2)
        self._ensure(per, per)
        _, _, added = _force_split(
            np.int64(tri), self._state, self._h, self._err, self._static_cam(),
            np.int64(self.size), np.int64(self.max_level), self._sk, self._si, 0,
            self._mk, self._mi, 0, self._stack1,
        )  # fmt: skip
        self._count += int(added)
        return int(added)

    def merge(self, diamond: int) -> int:
        """Merge a mergeable diamond (either triangle's id). Returns triangles removed."""
        diamond = check_int(diamond, "diamond id", minimum=2, maximum=self._state.size // 2 - 1)
        if not _mergeable(np.int64(diamond), self._state, np.int64(self.size)):
            raise InvalidParameterError(f"diamond {diamond} is not mergeable in the current mesh")
        self._ensure(8, 8)
        _, _, removed = _merge(
            np.int64(diamond), self._state, self._h, self._err, self._static_cam(),
            np.int64(self.size), np.int64(self.max_level), self._sk, self._si, 0,
            self._mk, self._mi, 0,
        )  # fmt: skip
        self._count -= int(removed)
        return int(removed)


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
