"""Static terrain mesh by greedy insertion into a Delaunay triangulation (Garland–Heckbert).

Start from the two triangles of the grid's corners. Every triangle knows its *candidate*:
the grid sample it covers whose height is farthest from the triangle's plane, found by
rasterising the triangle over every sample it covers. A large triangle is first searched on
a sparser lattice (every 2nd, 4th, … row and column, so that it holds about 128–512 of its
samples); when a lattice sample is beyond ``max_error``, the worst of them is the candidate:
the triangle will be split anyway, and a point nearly as far from the plane as the farthest
serves as well (the meshes have as many triangles, ``python scripts/greedy_tin_ab.py``).
Only a triangle whose lattice is within the error is searched over every sample. A priority
queue keeps the triangles by their candidate's error (those within ``max_error`` stay out of
it: they can never be refined); the worst candidate is inserted (splitting its triangle in
three, or the two triangles of an edge it lies on in four), the Delaunay condition is
restored by edge flips, and only the triangles that changed are rasterised again.
Refinement stops when the largest error left is at most ``max_error``: since every sample
is covered by a triangle that was searched over every sample, the bound holds on every
sample of the grid.

Then the vertices the finished mesh no longer needs are removed. A vertex inserted early,
where the error was largest at the time, is often made redundant by the vertices inserted
around it later. Each interior vertex, newest first, is taken out of its star, the hole is
filled again by clipping ears (an ear whose circumcircle holds none of the hole's other
corners when there is one), and the removal is kept when every sample of the new triangles
is within ``max_error`` (the same exact rasterisation); a vertex is tried again when a
neighbour went. This takes a tenth to a fifth of the triangles away (``terrascape bench
peers``, 2026-12-04), and the mesh is no longer exactly Delaunay.

A dense mesh is built the other way round. When a piece's sides, simplified as lines,
keep at least 40 % of their samples, most samples will be vertices, and inserting them one
by one costs more than removing the few that can go: every inner sample of the piece is
made a vertex, its sides only with their kept samples (joined to the inner samples by a
band of triangles one sample wide, which covers no sample but the sides' own), and the same
removal takes away what the error allows. (Pieces only: one greedy order, ``in_pieces=False``,
always inserts.)

For an error bound, the grid is cut into pieces of about 448×448 samples (a side of more
than about 336 samples into at least two) that share the grid lines between them, and the
pieces are meshed independently, in parallel. Each shared line is first simplified alone,
slightly within the error (the worst sample of a segment is kept until every sample is
within it: the same greedy insertion in one dimension); those vertices are put on both
pieces' sides before anything else. A triangle along a side interpolates the side's
samples as the line did, so the bound holds there, no piece wants a vertex its neighbour
lacks, and the pieces meet without cracks. Joined into one mesh, the lines' vertices are
offered to the removal, and the edges along the lines are flipped towards Delaunay
(Lawson's flips) wherever both new triangles stay within the error. On two threads this
takes 0.47–0.73× one greedy order's time on the bench's synthetic map (1.00× its
triangles) and 0.18–0.53× on the Jacksboro DEM, whose dense pieces are decimated
(1.01–1.05× its triangles at 1–5 m); what stays of the lines as straight runs of edges
shows in a wireframe (``python scripts/tin_pieces.py`` measures both, 2026-12-06 17:33
UTC). The pieces depend only on the grid's size, so the mesh is the same on any number of
threads. A triangle budget
(``max_triangles``), or ``in_pieces=False``, is one greedy order over the whole grid.

Compared with the right-triangulated network of :mod:`terrascape.lod.rtin`, vertices go
anywhere on the grid, not only at bintree midpoints, so the same error takes fewer
triangles; the mesh is not a bintree (it cannot be refined per view or stitched to tiles
by level). It meshes any rectangular grid.

References
----------
.. [1] Garland, M., Heckbert, P. S. (1995). Fast Polygonal Approximation of Terrains and
   Height Fields. Technical report CMU-CS-95-181, Carnegie Mellon University.
.. [2] Guibas, L., Stolfi, J. (1985). Primitives for the manipulation of general
   subdivisions and the computation of Voronoi diagrams. ACM TOG 4(2) — the in-circle test
   and edge flips.
.. [3] Schroeder, W. J., Zarge, J. A., Lorensen, W. E. (1992). Decimation of triangle
   meshes. SIGGRAPH '92 — removing a vertex and re-triangulating its hole under an error
   criterion.
.. [4] Douglas, D. H., Peucker, T. K. (1973). Algorithms for the reduction of the number
   of points required to represent a digitized line or its caricature. Cartographica
   10(2) — the shared lines' simplification.
.. [5] Lawson, C. L. (1977). Software for C1 surface interpolation. In Mathematical
   Software III, Academic Press — flipping edges towards a Delaunay triangulation.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, read_only, stop_requested
from terrascape._stoppable import run_stoppable
from terrascape._validate import check_int, check_positive
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.memory import (
    MESH_TOO_BIG_HINT,
    PEAK_BYTES_PER_TRIANGLE,
    check_triangles,
    memory_limit,
    memory_refusal,
)

__all__ = ["greedy_tin"]

# state slots of the resumable kernel
_N_POINTS, _N_EDGES, _Q_LEN, _N_PENDING, _STATUS = range(5)
_DONE, _FULL, _STOPPED = 0, 1, 2
# queue index of a triangle already within the error: it can never be refined, so it is
# kept out of the queue (pending triangles have -1)
_SETTLED = -2


@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _orient(ax, ay, bx, by, cx, cy):
    return (bx - cx) * (ay - cy) - (by - cy) * (ax - cx)


@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _in_circle(ax, ay, bx, by, cx, cy, px, py):
    dx = ax - px
    dy = ay - py
    ex = bx - px
    ey = by - py
    fx = cx - px
    fy = cy - py
    ap = dx * dx + dy * dy
    bp = ex * ex + ey * ey
    cp = fx * fx + fy * fy
    return dx * (ey * cp - bp * fy) - dy * (ex * cp - bp * fx) + ap * (ex * fy - ey * fx) < 0


# --- priority queue of triangles by error (max-heap) ---------------------------------------
@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _q_swap(queue, qerr, qidx, i, j):
    ti = queue[i]
    tj = queue[j]
    queue[i] = tj
    queue[j] = ti
    qidx[ti] = j
    qidx[tj] = i
    e = qerr[i]
    qerr[i] = qerr[j]
    qerr[j] = e


@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _q_up(queue, qerr, qidx, j):
    while j > 0:
        i = (j - 1) >> 1
        if i == j or not qerr[j] > qerr[i]:
            break
        _q_swap(queue, qerr, qidx, i, j)
        j = i


@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _q_down(queue, qerr, qidx, i0, n):
    i = i0
    while True:
        j1 = 2 * i + 1
        if j1 >= n or j1 < 0:
            break
        j2 = j1 + 1
        j = j1
        if j2 < n and qerr[j2] > qerr[j1]:
            j = j2
        if not qerr[j] > qerr[i]:
            break
        _q_swap(queue, qerr, qidx, i, j)
        i = j
    return i > i0


@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _q_push(queue, qerr, qidx, state, t, error):
    i = state[_Q_LEN]
    qidx[t] = i
    queue[i] = t
    qerr[i] = error
    state[_Q_LEN] = i + 1
    _q_up(queue, qerr, qidx, i)


@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _q_pop_back(queue, qidx, state):
    n = state[_Q_LEN] - 1
    t = queue[n]
    state[_Q_LEN] = n
    qidx[t] = -1
    return t


@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _q_pop(queue, qerr, qidx, state):
    n = state[_Q_LEN] - 1
    _q_swap(queue, qerr, qidx, 0, n)
    _q_down(queue, qerr, qidx, 0, n)
    return _q_pop_back(queue, qidx, state)


@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _q_remove(queue, qerr, qidx, pending, state, t):
    i = qidx[t]
    if i == _SETTLED:
        return
    if i < 0:
        # not queued yet: it waits in the pending list for rasterisation
        for k in range(state[_N_PENDING]):
            if pending[k] == t:
                state[_N_PENDING] -= 1
                pending[k] = pending[state[_N_PENDING]]
                return
        return
    n = state[_Q_LEN] - 1
    if n != i:
        _q_swap(queue, qerr, qidx, i, n)
        if not _q_down(queue, qerr, qidx, i, n):
            _q_up(queue, qerr, qidx, i)
    _q_pop_back(queue, qidx, state)


# --- the triangulation ---------------------------------------------------------------------
@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _set_triangle(tris, half, e, a, b, c, ab, bc, ca):
    """Write triangle (a, b, c) at halfedges ``e … e + 2``, twinned with ``ab``, ``bc``,
    ``ca`` (-1: none)."""
    tris[e] = a
    tris[e + 1] = b
    tris[e + 2] = c
    half[e] = ab
    half[e + 1] = bc
    half[e + 2] = ca
    if ab >= 0:
        half[ab] = e
    if bc >= 0:
        half[bc] = e + 1
    if ca >= 0:
        half[ca] = e + 2


@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _add_triangle(tris, half, qidx, pending, state, a, b, c, ab, bc, ca, e):
    """Write triangle (a, b, c) at halfedge slot ``e`` (-1: append) and queue it for
    rasterisation; returns its first halfedge."""
    if e < 0:
        e = state[_N_EDGES]
        state[_N_EDGES] = e + 3
    t = e // 3
    _set_triangle(tris, half, e, a, b, c, ab, bc, ca)
    qidx[t] = -1
    if state[_N_PENDING] >= pending.shape[0]:
        raise RuntimeError("greedy TIN: pending list overflow")
    pending[state[_N_PENDING]] = t
    state[_N_PENDING] += 1
    return e


@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _quad(tris, a, b):
    """The two triangles around halfedge ``a`` (twin ``b``): their first halfedges, the
    halfedges beside ``a`` and ``b``, and the four corners — ``p0`` opposite ``a``, ``pr``
    and ``pl`` at its ends, ``p1`` opposite ``b``."""
    a0 = a - a % 3
    b0 = b - b % 3
    al = a0 + (a + 1) % 3
    ar = a0 + (a + 2) % 3
    bl = b0 + (b + 2) % 3
    br = b0 + (b + 1) % 3
    return a0, b0, al, ar, bl, br, tris[ar], tris[a], tris[al], tris[bl]


# not inlined: called once per inserted point (its flips are the work), and compiled once
# for the insertion and the shared lines' points
@njit(cache=CACHE, fastmath=FASTMATH, _nrt=False)
def _legalize(tris, half, coords, queue, qerr, qidx, pending, state, stack, top):
    """Restore the Delaunay condition by flips, depth first from the halfedges
    ``stack[:top]`` (the last one first, and all it flips before the next)."""
    while top > 0:
        top -= 1
        a = stack[top]
        b = half[a]
        if b < 0:
            continue
        a0, b0, al, ar, bl, br, p0, pr, pl, p1 = _quad(tris, a, b)
        if not _in_circle(coords[p0, 0], coords[p0, 1], coords[pr, 0], coords[pr, 1],
                          coords[pl, 0], coords[pl, 1], coords[p1, 0], coords[p1, 1]):
            continue
        hal = half[al]
        har = half[ar]
        hbl = half[bl]
        hbr = half[br]
        _q_remove(queue, qerr, qidx, pending, state, a0 // 3)
        _q_remove(queue, qerr, qidx, pending, state, b0 // 3)
        t0 = _add_triangle(tris, half, qidx, pending, state, p0, p1, pl, -1, hbl, hal, a0)
        t1 = _add_triangle(tris, half, qidx, pending, state, p1, p0, pr, t0, har, hbr, b0)
        # the recursion's order: t0 + 1 (and all it flips) before t1 + 2
        if top + 2 > stack.shape[0]:
            raise RuntimeError("greedy TIN: flip stack overflow")
        stack[top] = t1 + 2
        stack[top + 1] = t0 + 1
        top += 2


@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _span(w, a, lo, hi):
    """Narrow ``[lo, hi]`` (offsets along a row) to where ``w + a·dx >= 0`` (integers)."""
    if a > 0:
        if w < 0:
            lo = max(lo, (-w + a - 1) // a)
    elif a < 0:
        hi = min(hi, w // (-a))
    elif w < 0:
        hi = -1
    return lo, hi


# Max-reductions vectorise only without NaN/signed-zero semantics; heights are checked
# finite, and no sum is reassociated, so results are the same bits as without the flags.
_RASTER_MATH = {"nnan", "ninf", "nsz"}
# The tiles' fits may sum in any order (SIMD): a tile's plane only has to be the one its
# residuals' range is measured from, and any plane gives a true bound; the mesh does not
# depend on which (the search scans the same samples' exact errors).
_TILE_MATH = {"nnan", "ninf", "nsz", "reassoc", "contract"}
# Tiles of the fitted-plane grid that bounds the error of large triangles (samples per side).
_TILE = 16
# Triangles whose box holds more samples than this search tiles by their error bound.
_TILED_SEARCH = 8 * _TILE * _TILE
# Triangles whose box holds at most this many samples are scanned sample by sample; the
# row spans' exact bounds pay from a few rows on. 16 against 64 (`python
# scripts/greedy_tin_ab.py`, 15 rounds, 2026-12-06): 0.885× the time on the synthetic
# 1025² map at 1 m, 0.96–1.01× on the other bench maps; 0 and 32 were no better.
_BOX_SCAN = 16
# A triangle beyond the error is first searched on a lattice of every 2nd, 4th, … row and
# column holding about this many to four times as many samples of its box (the triangle
# about half of them); smaller ones are searched over every sample at once. Against 64 and
# 256 (`python scripts/greedy_tin_ab.py` on a worktree with the other value, 21 rounds,
# 2026-12-06 22:07 UTC), the time with 128 ÷ theirs 0.96–1.04 and 0.93–1.02, within the
# shared cores' noise; 64 gave up to 4 % more triangles (the synthetic map at 10 m: 0.800
# against 0.767× pydelatin's).
_SPARSE_SAMPLES = 128
# A piece whose sides keep at least this share of their samples when simplified is meshed
# by decimation: every sample a vertex first, then the removal of what the error allows.
# The sides' kept share tracks the mesh's vertices per sample (0.4 ≈ 0.26–0.34 on the
# bench's maps). Against 0.3 and 0.5 (`python scripts/greedy_tin_ab.py`, 21 rounds,
# 2026-12-06 22:08 UTC; the time with 0.4 ÷ with the other), only the maps whose pieces
# change sides move: 0.3 decimates the DEM at 10 m too (0.725, and 0.851 against 0.824×
# pydelatin's triangles); 0.5 inserts the DEM at 5 m (0.796, but 0.835 against 0.859× the
# triangles); the other rows 0.94–1.02.
_DENSE_SIDES = 0.4
# Samples per side of the pieces meshed independently (in parallel) for an error bound; a
# side of more than about 0.75 × _PIECE is still cut in two, so that two threads share a
# small map. Against 224 (`python scripts/greedy_tin_ab.py`, 21 rounds, and with `--large`
# 7, 2026-12-06 22:07 UTC), the time with 448 ÷ with 224: 0.83–0.85 on the synthetic 1025²
# map at 5 and 10 m, 0.97 at 4097², 0.98–1.07 on the other rows, with 0.99–1.01× the
# triangles; each piece starts afresh with its own large triangles and its own fixed
# costs, which weigh on sparse meshes.
_PIECE = 448
# a triangle budget that never stops the insertion
_NO_BUDGET = np.iinfo(np.int64).max
# triangle slots the insertion's arrays start with (doubled whenever full), and no limit on
# how far they grow
_START_SLOTS = 1024
_NO_SLOT_LIMIT = np.iinfo(np.int64).max


@njit(cache=CACHE, fastmath=_RASTER_MATH, _nrt=False)
def _scan_rows(h, y0, y1, x_lo, x_hi, min_x, min_y, w00, w01, w02, a12, a20, a01, b12, b20,
               b01, z0, z1, z2, dz_dx, best, bx, by):
    """Scan rows ``y0 … y1`` of a triangle, columns ``x_lo … x_hi`` only; return the best
    ``(error, x, y)``, ties going to the first sample in row-major order."""
    dy = y0 - min_y
    w0r = w00 + b12 * dy
    w1r = w01 + b20 * dy
    w2r = w02 + b01 * dy
    for y in range(y0, y1 + 1):
        lo, hi = x_lo - min_x, x_hi - min_x
        lo, hi = _span(w0r, a12, lo, hi)
        lo, hi = _span(w1r, a20, lo, hi)
        lo, hi = _span(w2r, a01, lo, hi)
        if lo <= hi:
            zr = z0 * w0r + z1 * w1r + z2 * w2r
            row_max = 0.0
            for dx in range(lo, hi + 1):
                d = abs(zr + dz_dx * dx - float(h[y, min_x + dx]))
                row_max = max(row_max, d)
            if row_max > best or (row_max == best and best > 0.0 and y < by):
                for dx in range(lo, hi + 1):
                    if abs(zr + dz_dx * dx - float(h[y, min_x + dx])) == row_max:
                        x = min_x + dx
                        if row_max > best or y < by or x < bx:
                            best = row_max
                            bx = x
                            by = y
                        break
            elif row_max == best and best > 0.0 and y == by:
                for dx in range(lo, hi + 1):
                    x = min_x + dx
                    if x >= bx:
                        break
                    if abs(zr + dz_dx * dx - float(h[y, x])) == row_max:
                        bx = x
                        break
        w0r += b12
        w1r += b20
        w2r += b01
    return best, bx, by


@njit(cache=CACHE, fastmath=_RASTER_MATH, inline="always")
def _scan_box(h, min_x, min_y, max_x, max_y, w00, w01, w02, a12, a20, a01, b12, b20, b01, z0,
              z1, z2, dz_dx):
    """The best ``(error, x, y)`` of a small triangle: its box sample by sample with the
    inside test (cheaper than three row spans when rows are a few samples long); the same
    values and the same tie rule as :func:`_scan_rows`."""
    best = 0.0
    bx = -1
    by = -1
    w0r = w00
    w1r = w01
    w2r = w02
    for y in range(min_y, max_y + 1):
        zr = z0 * w0r + z1 * w1r + z2 * w2r
        w0 = w0r
        w1 = w1r
        w2 = w2r
        for dx in range(max_x - min_x + 1):
            if w0 >= 0 and w1 >= 0 and w2 >= 0:
                d = abs(zr + dz_dx * dx - float(h[y, min_x + dx]))
                if d > best:
                    best = d
                    bx = min_x + dx
                    by = y
            w0 += a12
            w1 += a20
            w2 += a01
        w0r += b12
        w1r += b20
        w2r += b01
    return best, bx, by


@njit(cache=CACHE, fastmath=_RASTER_MATH, _nrt=False)
def _scan_lattice(h, step, min_x, min_y, max_x, max_y, w00, w01, w02, a12, a20, a01, b12, b20,
                  b01, z0, z1, z2, dz_dx):
    """The best ``(error, x, y)`` among a triangle's samples whose row and column are
    multiples of ``step`` (``x = -1`` when it holds none), ties going to the first in
    row-major order: :func:`_scan_rows` on a sparser lattice."""
    best = 0.0
    bx = -1
    by = -1
    y = -(-min_y // step) * step
    while y <= max_y:
        dy = y - min_y
        w0r = w00 + b12 * dy
        w1r = w01 + b20 * dy
        w2r = w02 + b01 * dy
        lo, hi = 0, max_x - min_x
        lo, hi = _span(w0r, a12, lo, hi)
        lo, hi = _span(w1r, a20, lo, hi)
        lo, hi = _span(w2r, a01, lo, hi)
        if lo <= hi:
            zr = z0 * w0r + z1 * w1r + z2 * w2r
            x = -(-(min_x + lo) // step) * step
            while x <= min_x + hi:
                d = abs(zr + dz_dx * (x - min_x) - float(h[y, x]))
                if d > best:
                    best = d
                    bx = x
                    by = y
                x += step
        y += step
    return best, bx, by


@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _tile_sift(bound, order, i, n):
    """Sift slot ``i`` down the max-heap ``order[:n]`` keyed by ``bound``."""
    k = order[i]
    key = bound[k]
    while True:
        j = 2 * i + 1
        if j >= n:
            break
        if j + 1 < n and bound[order[j + 1]] > bound[order[j]]:
            j += 1
        if not bound[order[j]] > key:
            break
        order[i] = order[j]
        i = j
    order[i] = k


@njit(cache=CACHE, fastmath=FASTMATH, _nrt=False)
def _tiled_search(h, tplane, tres, bound, order, min_x, min_y, max_x, max_y, w00, w01, w02, a12,
                  a20, a01, b12, b20, b01, z0, z1, z2, dz_dx, dz_dy, floor, stop, bx, by):
    """:func:`_rasterise`'s search of a large triangle, tile by tile in decreasing order of
    their error bounds, from ``floor``; it ends early once an error above ``stop`` is found
    (``inf``: never). Compiled once, not into each caller: it is most of the code and a
    small share of the calls; ``stop`` is a number, not a flag, so that the callers'
    constants do not make numba compile it once per value."""
    best = floor
    z00 = z0 * w00 + z1 * w01 + z2 * w02
    slack = 1e-9 * (1.0 + abs(z00) + abs(dz_dx) * (max_x - min_x)
                    + abs(dz_dy) * (max_y - min_y))
    tx0, tx1 = min_x // _TILE, max_x // _TILE
    ty0, ty1 = min_y // _TILE, max_y // _TILE
    ntx = tx1 - tx0 + 1
    n = ntx * (ty1 - ty0 + 1)
    for k in range(n):
        ty = ty0 + k // ntx
        tx = tx0 + k % ntx
        xa = max(min_x, tx * _TILE) - min_x
        xb = min(max_x, tx * _TILE + _TILE - 1) - min_x
        ya = max(min_y, ty * _TILE) - min_y
        yb = min(max_y, ty * _TILE + _TILE - 1) - min_y
        # a plane's extremes over a rectangle are at its corners
        # the triangle's plane minus the tile's fitted plane at the rectangle's corners
        # (tile coordinates u, v); |plane − h| = |(plane − fit) − residual|
        q0 = tplane[ty, tx, 0]
        qx = tplane[ty, tx, 1]
        qy = tplane[ty, tx, 2]
        u0 = min_x + xa - tx * _TILE
        u1 = min_x + xb - tx * _TILE
        v0 = min_y + ya - ty * _TILE
        v1 = min_y + yb - ty * _TILE
        c00 = z00 + dz_dx * xa + dz_dy * ya
        c10 = z00 + dz_dx * xb + dz_dy * ya
        c01 = z00 + dz_dx * xa + dz_dy * yb
        c11 = z00 + dz_dx * xb + dz_dy * yb
        # a plane's extremes over a rectangle are at its corners: against the heights'
        # range, and against the residuals from the fitted plane; the smaller bound holds
        pmin = min(min(c00, c10), min(c01, c11))
        pmax = max(max(c00, c10), max(c01, c11))
        plain = max(pmax - tres[ty, tx, 2], tres[ty, tx, 3] - pmin)
        c00 -= q0 + qx * u0 + qy * v0
        c10 -= q0 + qx * u1 + qy * v0
        c01 -= q0 + qx * u0 + qy * v1
        c11 -= q0 + qx * u1 + qy * v1
        dmin = min(min(c00, c10), min(c01, c11))
        dmax = max(max(c00, c10), max(c01, c11))
        fitted = (max(dmax - tres[ty, tx, 0], tres[ty, tx, 1] - dmin)
                  + 1e-9 * (abs(q0) + abs(qx) * _TILE + abs(qy) * _TILE))
        bound[k] = min(plain, fitted) + slack
        order[k] = k
    # tiles in decreasing bound from a max-heap built in place (usually only a few are
    # popped before the bound drops below the best error, so no full sort); ties in
    # bound are taken in any order, which cannot change the result: the scan keeps the
    # largest error and, among equal errors, the first sample in row-major order
    for i in range(n // 2 - 1, -1, -1):
        _tile_sift(bound, order, i, n)
    m = n
    while m > 0:
        k = order[0]
        if bound[k] < best:
            break
        m -= 1
        order[0] = order[m]
        _tile_sift(bound, order, 0, m)
        ty = ty0 + k // ntx
        tx = tx0 + k % ntx
        best, bx, by = _scan_rows(
            h, max(min_y, ty * _TILE), min(max_y, ty * _TILE + _TILE - 1),
            max(min_x, tx * _TILE), min(max_x, tx * _TILE + _TILE - 1), min_x, min_y,
            w00, w01, w02, a12, a20, a01, b12, b20, b01, z0, z1, z2, dz_dx, best, bx, by)
        if best > stop:
            break
    return best, bx, by


@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _rasterise(h, tplane, tres, bound, order, coords, tris, t, cand, cerr, floor, any_above,
               sparse=False):
    """Largest |h − plane| over the samples of triangle ``t``, and where it is, when it is
    above ``floor``; otherwise an error of at most ``floor``. With ``any_above``, only
    whether some sample is above ``floor``: a large triangle's search may stop at the first
    tile that holds one (the error is then above ``floor``, not necessarily the largest).
    With ``sparse``, a triangle whose box holds more than ``4 × _SPARSE_SAMPLES`` samples
    is first searched on a lattice of every ``step``-th row and column (:func:`_scan_lattice`,
    ``step`` the power of two that leaves ``_SPARSE_SAMPLES`` to four times as many of the
    box's samples); when the worst of them is above ``floor``, it is the answer (above
    ``floor``, not necessarily the largest), otherwise every sample is searched.

    The samples inside are those where the three edge functions are ≥ 0; on each row they
    form one span, found exactly in integers, so the inner loop has no inside test. Each
    row's maximum is taken first (a loop LLVM vectorises) and its position looked up only
    when it beats the best so far. A large triangle is searched tile by tile in decreasing
    order of an upper bound of its error there (the range of the triangle's plane against
    the tile's height range, or that of the plane minus the tile's least-squares plane
    against the residuals' range, whichever is smaller),
    stopping at the first tile whose bound is below the best error found: the same sample as
    a full scan, without scanning most of the triangle. The search starts from ``floor``
    (the mesh's error): what is within it needs no position, so a tile bounded within it is
    never scanned.
    """
    p0 = tris[3 * t]
    p1 = tris[3 * t + 1]
    p2 = tris[3 * t + 2]
    p0x, p0y = coords[p0, 0], coords[p0, 1]
    p1x, p1y = coords[p1, 0], coords[p1, 1]
    p2x, p2y = coords[p2, 0], coords[p2, 1]
    area2 = _orient(p0x, p0y, p1x, p1y, p2x, p2y)
    if area2 == 1:
        # the smallest lattice triangle covers no sample but its corners (Pick's theorem):
        # most triangles of a dense mesh are such
        cand[t, 0] = p0x
        cand[t, 1] = p0y
        cerr[t] = 0.0
        return
    min_x = min(p0x, p1x, p2x)
    min_y = min(p0y, p1y, p2y)
    max_x = max(p0x, p1x, p2x)
    max_y = max(p0y, p1y, p2y)
    # edge functions at the box corner, advanced by forward differences
    w00 = _orient(p1x, p1y, p2x, p2y, min_x, min_y)
    w01 = _orient(p2x, p2y, p0x, p0y, min_x, min_y)
    w02 = _orient(p0x, p0y, p1x, p1y, min_x, min_y)
    a01 = p1y - p0y
    b01 = p0x - p1x
    a12 = p2y - p1y
    b12 = p1x - p2x
    a20 = p0y - p2y
    b20 = p2x - p0x
    area = float(area2)
    z0 = float(h[p0y, p0x]) / area
    z1 = float(h[p1y, p1x]) / area
    z2 = float(h[p2y, p2x]) / area
    # the plane: z = z00 + dz_dx·(x − min_x) + dz_dy·(y − min_y)
    dz_dx = z0 * a12 + z1 * a20 + z2 * a01
    dz_dy = z0 * b12 + z1 * b20 + z2 * b01
    best = 0.0
    bx = p0x
    by = p0y
    box = (max_x - min_x + 1) * (max_y - min_y + 1)
    step = 1
    if sparse:
        while box > _SPARSE_SAMPLES * (2 * step) * (2 * step):
            step *= 2
    if step > 1:
        best, bx, by = _scan_lattice(h, step, min_x, min_y, max_x, max_y, w00, w01, w02, a12,
                                     a20, a01, b12, b20, b01, z0, z1, z2, dz_dx)
    if step > 1 and best > floor:
        pass  # a lattice sample beyond the floor: the triangle is refined from it
    elif box <= _BOX_SCAN:
        best, bx, by = _scan_box(h, min_x, min_y, max_x, max_y, w00, w01, w02, a12, a20, a01,
                                 b12, b20, b01, z0, z1, z2, dz_dx)
        if bx < 0:
            bx = p0x
            by = p0y
    elif box <= _TILED_SEARCH:
        best, bx, by = _scan_rows(h, min_y, max_y, min_x, max_x, min_x, min_y, w00, w01, w02,
                                  a12, a20, a01, b12, b20, b01, z0, z1, z2, dz_dx, floor, p0x,
                                  p0y)
    else:
        best, bx, by = _tiled_search(h, tplane, tres, bound, order, min_x, min_y, max_x, max_y,
                                     w00, w01, w02, a12, a20, a01, b12, b20, b01, z0, z1, z2,
                                     dz_dx, dz_dy, floor, floor if any_above else np.inf,
                                     p0x, p0y)
    if ((bx == p0x and by == p0y) or (bx == p1x and by == p1y)
            or (bx == p2x and by == p2y)):
        best = 0.0
    cand[t, 0] = bx
    cand[t, 1] = by
    cerr[t] = best


@njit(cache=CACHE, fastmath=_TILE_MATH, nogil=True)
def _tile_ranges(h, tplane, tres):
    """Per tile: the least-squares plane of its heights (value at the tile's first sample,
    slopes along x and y), the range of the heights' residuals from it, and the range of
    the heights.

    A band of tiles at a time, along whole rows: the per-column sums, and later the
    per-column ranges, are loops over a contiguous row that LLVM vectorises (a loop over a
    tile's 16 samples did not); each tile then reduces its 16 columns."""
    rows, cols = h.shape
    col_h = np.empty(cols)  # Σ over the band's rows of z, then of (v − ym)·z
    col_vh = np.empty(cols)
    base = np.empty(cols)  # the column's tile plane at v = 0, and its slope along v
    slope_v = np.empty(cols)
    r_lo = np.empty(cols)
    r_hi = np.empty(cols)
    z_lo = np.empty(cols)
    z_hi = np.empty(cols)
    for ty in range(tplane.shape[0]):
        y0 = ty * _TILE
        ny = min(rows, y0 + _TILE) - y0
        ym = 0.5 * (ny - 1)
        col_h[:] = 0.0
        col_vh[:] = 0.0
        for v in range(ny):
            wv = v - ym
            row = h[y0 + v]
            for x in range(cols):
                z = float(row[x])
                col_h[x] += z
                col_vh[x] += wv * z
        for tx in range(tplane.shape[1]):
            x0 = tx * _TILE
            nx = min(cols, x0 + _TILE) - x0
            # on a full rectangle the x and y offsets are uncorrelated: two 1-D regressions
            xm = 0.5 * (nx - 1)
            sh = 0.0
            sxh = 0.0
            syh = 0.0
            for u in range(nx):
                sh += col_h[x0 + u]
                sxh += (u - xm) * col_h[x0 + u]
                syh += col_vh[x0 + u]
            sxx = ny * nx * (nx * nx - 1) / 12.0
            syy = nx * ny * (ny * ny - 1) / 12.0
            gx = sxh / sxx if nx > 1 else 0.0
            gy = syh / syy if ny > 1 else 0.0
            q0 = sh / (nx * ny) - gx * xm - gy * ym
            tplane[ty, tx, 0] = q0
            tplane[ty, tx, 1] = gx
            tplane[ty, tx, 2] = gy
            for u in range(nx):
                base[x0 + u] = q0 + gx * u
                slope_v[x0 + u] = gy
        r_lo[:] = np.inf
        r_hi[:] = -np.inf
        z_lo[:] = np.inf
        z_hi[:] = -np.inf
        for v in range(ny):
            row = h[y0 + v]
            for x in range(cols):
                r = float(row[x]) - (base[x] + slope_v[x] * v)
                r_lo[x] = min(r_lo[x], r)
                r_hi[x] = max(r_hi[x], r)
            for x in range(cols):
                z = float(row[x])
                z_lo[x] = min(z_lo[x], z)
                z_hi[x] = max(z_hi[x], z)
        for tx in range(tplane.shape[1]):
            x0 = tx * _TILE
            lo, hi = r_lo[x0], r_hi[x0]
            z0, z1 = z_lo[x0], z_hi[x0]
            for x in range(x0 + 1, min(cols, x0 + _TILE)):
                lo = min(lo, r_lo[x])
                hi = max(hi, r_hi[x])
                z0 = min(z0, z_lo[x])
                z1 = max(z1, z_hi[x])
            tres[ty, tx, 0] = lo
            tres[ty, tx, 1] = hi
            tres[ty, tx, 2] = z0
            tres[ty, tx, 3] = z1


@njit(cache=CACHE, fastmath=FASTMATH, inline="always", _nrt=False)
def _queue(h, tplane, tres, bound, order, coords, tris, cand, cerr, queue, qerr, qidx, state,
           max_error, t):
    """Rasterise triangle ``t``: queue it when beyond the error, else settle it."""
    _rasterise(h, tplane, tres, bound, order, coords, tris, t, cand, cerr, max_error, False,
               True)
    if cerr[t] > max_error:
        _q_push(queue, qerr, qidx, state, t, cerr[t])
    else:
        qidx[t] = _SETTLED


@njit(cache=CACHE, fastmath=FASTMATH, inline="always", _nrt=False)
def _flush(h, tplane, tres, bound, order, coords, tris, cand, cerr, queue, qerr, qidx, pending,
           state, max_error):
    for k in range(state[_N_PENDING]):
        _queue(h, tplane, tres, bound, order, coords, tris, cand, cerr, queue, qerr, qidx,
               state, max_error, pending[k])
    state[_N_PENDING] = 0


@njit(cache=CACHE, fastmath=FASTMATH, nogil=True, _nrt=False)
def _insert_border_points(points, coords, tris, half, queue, qerr, qidx, pending, stack,
                          state):
    """Insert the ``points`` (on the grid's border; corners are skipped) into the
    triangulation as Delaunay vertices, before anything is rasterised."""
    for k in range(points.shape[0]):
        px = points[k, 0]
        py = points[k, 1]
        on = -1
        # newest edges first: a side's points come in order, so the next one lies on the
        # border edge the last split made (a point is on one border edge only, or a vertex)
        for e in range(state[_N_EDGES] - 1, -1, -1):
            if half[e] >= 0:
                continue
            a = tris[e]
            b = tris[_next_edge(e)]
            ax, ay = coords[a, 0], coords[a, 1]
            bx, by = coords[b, 0], coords[b, 1]
            if ((ax == px and ay == py) or (bx == px and by == py)):
                on = -2  # already a vertex
                break
            if (_orient(ax, ay, bx, by, px, py) == 0 and min(ax, bx) <= px <= max(ax, bx)
                    and min(ay, by) <= py <= max(ay, by)):
                on = e
                break
        if on == -2:
            continue
        if on < 0:
            raise RuntimeError("greedy TIN: a shared point is not on the piece's border")
        pn = _add_point(coords, state, px, py)
        top = _split_on_edge(tris, half, queue, qerr, qidx, pending, state, stack, pn, on)
        _legalize(tris, half, coords, queue, qerr, qidx, pending, state, stack, top)
        # nothing is rasterised yet: the start rasterises every triangle once
        state[_N_PENDING] = 0


@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _add_point(coords, state, x, y):
    i = state[_N_POINTS]
    coords[i, 0] = x
    coords[i, 1] = y
    state[_N_POINTS] = i + 1
    return i


@njit(cache=CACHE, fastmath=FASTMATH, _nrt=False)
def _split_on_edge(tris, half, queue, qerr, qidx, pending, state, stack, pn, a):
    """Insert point ``pn`` lying on halfedge ``a``: split the edge's one or two triangles;
    returns how many halfedges it put on ``stack`` for legalisation."""
    a0 = a - a % 3
    al = a0 + (a + 1) % 3
    ar = a0 + (a + 2) % 3
    p0 = tris[ar]
    pr = tris[a]
    pl = tris[al]
    hal = half[al]
    har = half[ar]
    b = half[a]
    if b < 0:
        t0 = _add_triangle(tris, half, qidx, pending, state, pn, p0, pr, -1, har, -1, a0)
        t1 = _add_triangle(tris, half, qidx, pending, state, p0, pn, pl, t0, -1, hal, -1)
        stack[0] = t1 + 2
        stack[1] = t0 + 1
        return 2
    b0 = b - b % 3
    bl = b0 + (b + 2) % 3
    br = b0 + (b + 1) % 3
    p1 = tris[bl]
    hbl = half[bl]
    hbr = half[br]
    _q_remove(queue, qerr, qidx, pending, state, b0 // 3)
    t0 = _add_triangle(tris, half, qidx, pending, state, p0, pr, pn, har, -1, -1, a0)
    t1 = _add_triangle(tris, half, qidx, pending, state, pr, p1, pn, hbr, -1, t0 + 1, b0)
    t2 = _add_triangle(tris, half, qidx, pending, state, p1, pl, pn, hbl, -1, t1 + 1, -1)
    t3 = _add_triangle(tris, half, qidx, pending, state, pl, p0, pn, hal, t0 + 2, t2 + 1, -1)
    stack[0] = t3
    stack[1] = t2
    stack[2] = t1
    stack[3] = t0
    return 4


@njit(cache=CACHE, fastmath=FASTMATH, _nrt=False, nogil=True)
def _refine(h, tplane, tres, bound, order, max_error, max_tris, coords, tris, half, cand, cerr,
            queue, qerr, qidx, pending, stack, state, stop):
    """Insert worst candidates until the error is met, the budget is reached, or the arrays
    are full (then return ``_FULL`` so the caller grows them and calls again), or another
    thread set ``stop[0]`` (``_STOPPED``: an interrupted mesh ends within an insertion)."""
    cap_tris = tris.shape[0] // 3
    while True:
        if stop_requested(stop):
            state[_STATUS] = _STOPPED
            return
        # the triangles that changed (at the start: all) rasterised and queued
        _flush(h, tplane, tres, bound, order, coords, tris, cand, cerr, queue, qerr, qidx,
               pending, state, max_error)
        if state[_Q_LEN] == 0 or not qerr[0] > max_error:
            break
        n_tris = state[_N_EDGES] // 3
        if n_tris + 2 > max_tris:
            break
        if n_tris + 2 > cap_tris or state[_N_POINTS] + 1 > coords.shape[0]:
            state[_STATUS] = _FULL
            return
        t = _q_pop(queue, qerr, qidx, state)
        e0 = 3 * t
        e1 = e0 + 1
        e2 = e0 + 2
        p0 = tris[e0]
        p1 = tris[e1]
        p2 = tris[e2]
        ax, ay = coords[p0, 0], coords[p0, 1]
        bx, by = coords[p1, 0], coords[p1, 1]
        cx, cy = coords[p2, 0], coords[p2, 1]
        px = cand[t, 0]
        py = cand[t, 1]
        pn = _add_point(coords, state, px, py)
        # a point on an edge splits both triangles of the edge, one inside splits its own
        e_on = -1
        if _orient(ax, ay, bx, by, px, py) == 0:
            e_on = e0
        elif _orient(bx, by, cx, cy, px, py) == 0:
            e_on = e1
        elif _orient(cx, cy, ax, ay, px, py) == 0:
            e_on = e2
        if e_on >= 0:
            top = _split_on_edge(tris, half, queue, qerr, qidx, pending, state, stack, pn, e_on)
        else:
            h0 = half[e0]
            h1 = half[e1]
            h2 = half[e2]
            t0 = _add_triangle(tris, half, qidx, pending, state, p0, p1, pn, h0, -1, -1, e0)
            t1 = _add_triangle(tris, half, qidx, pending, state, p1, p2, pn, h1, -1, t0 + 1,
                               -1)
            t2 = _add_triangle(tris, half, qidx, pending, state, p2, p0, pn, h2, t0 + 2,
                               t1 + 1, -1)
            stack[0] = t2
            stack[1] = t1
            stack[2] = t0
            top = 3
        # one legalisation, new edges in order (each with all it flips before the next)
        _legalize(tris, half, coords, queue, qerr, qidx, pending, state, stack, top)
    state[_STATUS] = _DONE


# --- removing the vertices the finished mesh no longer needs ---------------------------------
# Largest vertex degree a removal handles (a vertex with more neighbours stays).
_MAX_DEGREE = 48
# Passes over the vertices (a pass that removes none ends it early).
_REMOVAL_PASSES = 8


@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _next_edge(e):
    return e - e % 3 + (e + 1) % 3


@njit(cache=CACHE, fastmath=FASTMATH, inline="always")
def _prev_edge(e):
    return e - e % 3 + (e + 2) % 3


@njit(cache=CACHE, fastmath=FASTMATH)
def _holds_within(rx, ry, rz, i0, i1, i2, x, y, z, max_error):
    """Whether the triangle of corners ``i0, i1, i2`` holds ``(x, y)``, and if so whether
    its plane there is within ``max_error`` of ``z`` (True when it does not hold it)."""
    x0, y0 = rx[i0], ry[i0]
    x1, y1 = rx[i1], ry[i1]
    x2, y2 = rx[i2], ry[i2]
    w0 = _orient(x1, y1, x2, y2, x, y)
    w1 = _orient(x2, y2, x0, y0, x, y)
    w2 = _orient(x0, y0, x1, y1, x, y)
    if w0 >= 0 and w1 >= 0 and w2 >= 0:
        area = float(_orient(x0, y0, x1, y1, x2, y2))
        zt = (rz[i0] * w0 + rz[i1] * w1 + rz[i2] * w2) / area
        return True, abs(zt - z) <= max_error
    return False, True


@njit(cache=CACHE, fastmath=FASTMATH, _nrt=False)
def _fill_hole(rx, ry, rz, d, pprev, pnext, out, vx, vy, vz, max_error):
    """Triangulate the polygon of corners ``(rx[i], ry[i])``, ``i < d`` (the link of a
    removed vertex, in the mesh's winding) by clipping ears, taking an ear whose circumcircle
    holds no other polygon corner when there is one; ``out[k]`` = corner numbers of triangle
    k. False when no ear is left (a degenerate polygon), or as soon as the first triangle
    that holds the removed vertex's sample ``(vx, vy)`` puts it farther than ``max_error``
    from its height ``vz`` (corner heights ``rz``): most removals fail there, and the rest
    of the fill is then not needed."""
    for i in range(d):
        pprev[i] = (i - 1 + d) % d
        pnext[i] = (i + 1) % d
    alive = d
    start = 0
    k = 0
    placed = False  # the removed vertex's sample found in a triangle
    while alive > 3:
        chosen = -1
        fallback = -1
        i = start
        for _ in range(alive):
            p = pprev[i]
            n = pnext[i]
            ax, ay = rx[p], ry[p]
            bx, by = rx[i], ry[i]
            cx, cy = rx[n], ry[n]
            if _orient(ax, ay, bx, by, cx, cy) > 0:
                valid = True
                empty = True
                j = pnext[n]
                while j != p:
                    qx, qy = rx[j], ry[j]
                    if (_orient(bx, by, cx, cy, qx, qy) >= 0
                            and _orient(cx, cy, ax, ay, qx, qy) >= 0
                            and _orient(ax, ay, bx, by, qx, qy) >= 0):
                        valid = False
                        break
                    if empty and _in_circle(ax, ay, bx, by, cx, cy, qx, qy):
                        empty = False
                    j = pnext[j]
                if valid:
                    if empty:
                        chosen = i
                        break
                    if fallback < 0:
                        fallback = i
            i = pnext[i]
        if chosen < 0:
            chosen = fallback
        if chosen < 0:
            return False
        out[k, 0] = pprev[chosen]
        out[k, 1] = chosen
        out[k, 2] = pnext[chosen]
        if not placed:
            placed, fits = _holds_within(rx, ry, rz, out[k, 0], chosen, out[k, 2], vx, vy, vz,
                                         max_error)
            if not fits:
                return False
        k += 1
        pnext[pprev[chosen]] = pnext[chosen]
        pprev[pnext[chosen]] = pprev[chosen]
        alive -= 1
        start = pnext[chosen]
    a = start
    b = pnext[a]
    c = pnext[b]
    if _orient(rx[a], ry[a], rx[b], ry[b], rx[c], ry[c]) <= 0:
        return False
    out[k, 0] = a
    out[k, 1] = b
    out[k, 2] = c
    if not placed:
        placed, fits = _holds_within(rx, ry, rz, a, b, c, vx, vy, vz, max_error)
        if not fits:
            return False
    return True


@njit(cache=CACHE, fastmath=FASTMATH, nogil=True)
def _remove_vertices(h, tplane, tres, bound, order, coords, tris, half, n_points, n_edges,
                     max_error, passes, dirty, stop):
    """Remove every vertex (newest first, ``passes`` times over) whose star, refilled
    without it, keeps every sample it covers within ``max_error``; the triangles left over
    get vertex −1. Returns how many vertices went.

    The greedy insertion adds a vertex where the error was largest at that moment; vertices
    inserted later near it can make it unnecessary. Removing it takes two triangles away
    and changes no other sample's error. Only the vertices marked in ``dirty`` are tried
    (then their neighbours when one goes: a star changed); ``dirty`` is consumed. Ends
    early, the mesh left valid, once another thread sets ``stop[0]``."""
    vedge = np.full(n_points, -1, np.int64)  # one halfedge leaving each vertex
    ring = np.empty((4, _MAX_DEGREE), np.int64)  # link vertices, x, y, star halfedges
    outer = np.empty((3, _MAX_DEGREE), np.int64)  # twins outside, ear-clipping links
    rz = np.empty(_MAX_DEGREE, np.float64)
    fill = np.empty((_MAX_DEGREE, 3), np.int64)
    stris = np.empty(3 * _MAX_DEGREE, np.int32)
    scand = np.empty((_MAX_DEGREE, 2), np.int32)
    scerr = np.empty(_MAX_DEGREE, np.float64)
    return _remove_kernel(h, tplane, tres, bound, order, coords, tris, half, n_edges,
                          max_error, passes, vedge, dirty, ring, outer, rz, fill, stris, scand,
                          scerr, stop)


# without the runtime's reference counting: the kernel allocates nothing, and counting the
# references of a dozen arrays at every inlined rasterisation cost more than the
# rasterisation of a small triangle
@njit(cache=CACHE, fastmath=FASTMATH, nogil=True, _nrt=False)
def _remove_kernel(h, tplane, tres, bound, order, coords, tris, half, n_edges, max_error,
                   passes, vedge, dirty, rings, outers, rz, fill, stris, scand, scerr, stop):
    ring = rings[0]
    rx = rings[1]  # the link's coordinates and heights
    ry = rings[2]
    ring_e = rings[3]
    outer = outers[0]
    pprev = outers[1]
    pnext = outers[2]
    n_points = vedge.shape[0]
    for e in range(n_edges):
        if tris[e] >= 0:
            vedge[tris[e]] = e
    rows, cols = h.shape
    removed = 0
    for _ in range(passes):
        before = removed
        for v in range(n_points - 1, 3, -1):
            if not dirty[v]:
                continue
            if stop_requested(stop):
                return removed
            dirty[v] = False
            x = coords[v, 0]
            y = coords[v, 1]
            e0 = vedge[v]
            if e0 < 0 or x == 0 or y == 0 or x == cols - 1 or y == rows - 1:
                continue
            # the star: halfedges leaving v, its link vertices in the mesh's winding
            d = 0
            e = e0
            closed = False
            while d < _MAX_DEGREE:
                ring_e[d] = e
                r = tris[_next_edge(e)]
                ring[d] = r
                rx[d] = coords[r, 0]
                ry[d] = coords[r, 1]
                rz[d] = h[ry[d], rx[d]]
                outer[d] = half[_next_edge(e)]
                d += 1
                e = half[_prev_edge(e)]
                if e < 0:
                    break
                if e == e0:
                    closed = True
                    break
            if not closed:
                continue
            # whatever fills the hole interpolates v's sample between its neighbours' heights
            hv = float(h[y, x])
            lo = np.inf
            hi = -np.inf
            for k in range(d):
                lo = min(lo, rz[k])
                hi = max(hi, rz[k])
            if hv > hi + max_error or hv < lo - max_error:
                continue
            # the fill tests v's own sample against the new triangle over it first thing
            if not _fill_hole(rx, ry, rz, d, pprev, pnext, fill, x, y, hv, max_error):
                continue
            fits = True
            for k in range(d - 2):
                for m in range(3):
                    stris[3 * k + m] = ring[fill[k, m]]
                _rasterise(h, tplane, tres, bound, order, coords, stris, k, scand, scerr,
                           max_error, True)
                if scerr[k] > max_error:
                    fits = False
                    break
            if not fits:
                continue
            # refill the star's first d - 2 triangle slots, retire the last two
            for k in range(d - 2):
                base = 3 * (ring_e[k] // 3)
                for m in range(3):
                    tris[base + m] = ring[fill[k, m]]
            for k in range(d - 2, d):
                base = 3 * (ring_e[k] // 3)
                for m in range(3):
                    tris[base + m] = -1
                    half[base + m] = -1
            for k in range(d - 2):
                base = 3 * (ring_e[k] // 3)
                for m in range(3):
                    a = fill[k, m]
                    b = fill[k, (m + 1) % 3]
                    edge = base + m
                    vedge[ring[a]] = edge
                    if b == (a + 1) % d:  # a side of the hole: the outside triangle's twin
                        twin = outer[a]
                        half[edge] = twin
                        if twin >= 0:
                            half[twin] = edge
                    else:  # a diagonal: the other new triangle that has it reversed
                        for k2 in range(d - 2):
                            for m2 in range(3):
                                if fill[k2, m2] == b and fill[k2, (m2 + 1) % 3] == a:
                                    half[edge] = 3 * (ring_e[k2] // 3) + m2
            vedge[v] = -1
            removed += 1
            for k in range(d):
                dirty[ring[k]] = True
        if removed == before:
            break
    return removed


@njit(cache=CACHE, fastmath=FASTMATH, nogil=True, _nrt=False)
def _relax_edges(h, tplane, tres, bound, order, coords, tris, half, stack, top, max_error,
                 stris, scand, scerr):
    """Flip the halfedges ``stack[:top]`` towards Delaunay (Lawson's flips: an edge whose
    opposite vertex lies in the other triangle's circumcircle), each flip kept only when
    both new triangles keep every sample within ``max_error``; the four edges around a flip
    are checked next. Triangles with vertex -1 (removed) are skipped."""
    while top > 0:
        top -= 1
        a = stack[top]
        if tris[a] < 0:
            continue
        b = half[a]
        if b < 0:
            continue
        a0, b0, al, ar, bl, br, p0, pr, pl, p1 = _quad(tris, a, b)
        x0, y0 = coords[p0, 0], coords[p0, 1]
        xr, yr = coords[pr, 0], coords[pr, 1]
        xl, yl = coords[pl, 0], coords[pl, 1]
        x1, y1 = coords[p1, 0], coords[p1, 1]
        if not _in_circle(x0, y0, xr, yr, xl, yl, x1, y1):
            continue
        # the quadrilateral must be convex for the other diagonal to split it
        if _orient(x0, y0, x1, y1, xl, yl) <= 0 or _orient(x1, y1, x0, y0, xr, yr) <= 0:
            continue
        stris[0] = p0
        stris[1] = p1
        stris[2] = pl
        stris[3] = p1
        stris[4] = p0
        stris[5] = pr
        _rasterise(h, tplane, tres, bound, order, coords, stris, 0, scand, scerr, max_error,
                   True)
        if scerr[0] > max_error:
            continue
        _rasterise(h, tplane, tres, bound, order, coords, stris, 1, scand, scerr, max_error,
                   True)
        if scerr[1] > max_error:
            continue
        hal = half[al]
        har = half[ar]
        hbl = half[bl]
        hbr = half[br]
        _set_triangle(tris, half, a0, p0, p1, pl, -1, hbl, hal)
        _set_triangle(tris, half, b0, p1, p0, pr, a0, har, hbr)
        if top + 4 <= stack.shape[0]:
            stack[top] = a0 + 1
            stack[top + 1] = a0 + 2
            stack[top + 2] = b0 + 1
            stack[top + 3] = b0 + 2
            top += 4


def greedy_tin(heightmap: Heightmap, *, max_error: float | None = None,
               max_triangles: int | None = None, in_pieces: bool = True) -> np.ndarray:
    """Mesh with a guaranteed maximum vertical error by greedy Delaunay insertion.

    Parameters
    ----------
    heightmap
        Any rectangular :class:`~terrascape.Heightmap` of at least 2×2 samples (heights in
        world units).
    max_error
        Largest allowed vertical error in world units (≥ 0), measured on every sample.
    max_triangles
        Stop before exceeding this many triangles (≥ 2); with ``max_error`` too, the first
        criterion reached wins. The redundant vertices are removed only when the error
        bound was reached.
    in_pieces
        For an error bound alone: mesh pieces of the map in parallel (the default; dense
        pieces are decimated from every sample; on two threads 0.18–0.73× one order's time
        on the bench's maps, ``python scripts/tin_pieces.py``), or with False one greedy
        order over the whole map. Both meet the bound on every sample with about the same
        number of triangles (up to 5 % more in dense pieces); in a wireframe, some of the
        lines the pieces share stay visible as straight runs of edges, and decimated pieces
        keep some rows of grid-aligned edges.

    Returns
    -------
    numpy.ndarray
        ``uint32 (M, 3)`` grid vertex indices (``row·cols + col``), counter-clockwise seen
        from above, like :func:`terrascape.lod.rtin_mesh`.

    Raises
    ------
    MemoryLimitError
        When the mesh cannot fit the memory limit (:mod:`terrascape.memory`): in pieces, as
        soon as the pieces meshed so far make a join over it; as one order, before its
        arrays would grow past it.

    References
    ----------
    Garland & Heckbert (1995), see the module docstring.
    """
    if not isinstance(heightmap, Heightmap):
        raise InvalidParameterError(f"expected a Heightmap, got {type(heightmap).__name__}")
    if max_error is None and max_triangles is None:
        raise InvalidParameterError("give max_error (world units) and/or max_triangles")
    tol = 0.0
    if max_error is not None:
        tol = check_positive(max_error, "max_error (world units)", allow_zero=True)
    budget = _NO_BUDGET
    if max_triangles is not None:
        budget = check_int(max_triangles, "max_triangles", minimum=2)
    rows, cols = heightmap.shape
    if rows < 2 or cols < 2:
        raise InvalidParameterError(f"greedy TIN needs at least 2×2 samples, got {rows}×{cols}")
    h = read_only(np.ascontiguousarray(heightmap.heights, dtype=np.float32))
    magnitude = _magnitude(h)
    if not np.isfinite(magnitude):
        raise InvalidParameterError("heights must be finite (fill NaN/inf first)")
    if max_triangles is not None or not in_pieces:
        # a triangle budget is one greedy order over the whole map
        passes = _REMOVAL_PASSES if max_error is not None else 0
        tiles = (-(-rows // _TILE), -(-cols // _TILE))
        # its arrays grow as it inserts: they stop before they would pass the memory limit
        # (read once: a mesh within it never reads it again)
        cap = memory_limit()
        per_slot = PEAK_BYTES_PER_TRIANGLE["greedy one order"]
        coords, tris, _ = run_stoppable(rows * cols > _WAIT_SAMPLES, _mesh_piece, h, rows,
                                        cols, 0, 0, float(tol), 0.0, budget, passes, np.inf,
                                        np.empty((*tiles, 3)), np.empty((*tiles, 4)),
                                        int(cap // per_slot))
        if len(tris) == 0:
            slots = _START_SLOTS  # the insertion's arrays, doubled until the next would pass
            while 2 * slots <= cap // per_slot:
                slots *= 2
            raise memory_refusal(2 * slots * per_slot,
                                 f"a greedy TIN in one order of more than {slots:,} triangles",
                                 hint=MESH_TOO_BIG_HINT, cap=cap)
        return _grid_triangles(coords, tris, cols)
    return _mesh_in_pieces(h, tol, magnitude)


def _piece_edges(n: int) -> np.ndarray:
    """Where the pieces along one axis of ``n`` samples start and end (shared lines): on
    multiples of the error-bound tiles, so the pieces' tiles are the whole map's. About
    ``_PIECE`` samples each, but two pieces from ``0.75 × _PIECE`` samples on."""
    count = max(1, round((n - 1) / _PIECE), min(2, round(2 * (n - 1) / _PIECE)))
    edges = np.round(np.linspace(0, n - 1, count + 1) / _TILE).astype(np.int64) * _TILE
    edges[-1] = n - 1
    # pieces narrower than a tile would round to nothing or past the end: merged with a
    # neighbour
    return np.unique(np.minimum(edges, n - 1))


@njit(cache=CACHE, fastmath=FASTMATH, nogil=True)
def _simplify_line(z, tol, keep):
    """Mark in ``keep`` the samples of the line ``z`` that a polyline within ``tol`` of every
    sample needs: the two ends, then recursively the worst sample of a segment beyond ``tol``
    (in one dimension this is the greedy insertion itself)."""
    n = z.shape[0]
    keep[:] = False
    keep[0] = True
    keep[n - 1] = True
    stack = np.empty((n, 2), np.int64)
    stack[0, 0] = 0
    stack[0, 1] = n - 1
    top = 1
    while top > 0:
        top -= 1
        a = stack[top, 0]
        b = stack[top, 1]
        za = float(z[a])
        slope = (float(z[b]) - za) / (b - a)
        worst = -1.0
        at = -1
        for i in range(a + 1, b):
            d = abs(za + slope * (i - a) - float(z[i]))
            if d > worst:
                worst = d
                at = i
        if at >= 0 and worst > tol:
            keep[at] = True
            stack[top, 0] = a
            stack[top, 1] = at
            stack[top + 1, 0] = at
            stack[top + 1, 1] = b
            top += 2


def _magnitude(h: np.ndarray) -> float:
    """The largest |height|; NaN or inf when a height is not finite (numpy's minimum and
    maximum carry NaN through, and SIMD makes the two passes cheaper than one loop)."""
    return float(max(-float(h.min()), float(h.max())))


def _line_tolerance(magnitude: float, tol: float) -> float:
    """The error the shared lines are simplified within: slightly tighter than the mesh's,
    so that the plane of any triangle along a side, evaluated in two dimensions with its
    own rounding (relative to the heights' magnitude), is still within the mesh's error on
    the side's samples: no piece then wants a vertex on a side its neighbour does not have
    (which would crack the mesh). At most 0: every sample of the lines is kept."""
    return tol - 1e-7 * (1.0 + magnitude)


_POOLS: dict[tuple[int, int], ThreadPoolExecutor] = {}


# Maps of more samples are meshed in one order on a worker thread, the main thread waiting
# (:func:`terrascape._stoppable.run_stoppable`); a smaller one takes at most a second or
# two, and the hand-over about 0.1 ms (3–5 % of a 2,000-triangle budget on a 257² map)
_WAIT_SAMPLES = 1 << 18


def _thread_pool(workers: int) -> ThreadPoolExecutor:
    """A pool of ``workers`` threads for the pieces, kept for the next mesh: starting the
    threads anew took as long as meshing a sparse piece. One per process (a forked child
    has the pool but not its threads)."""
    key = (os.getpid(), workers)
    pool = _POOLS.get(key)
    if pool is None:
        pool = _POOLS[key] = ThreadPoolExecutor(workers, thread_name_prefix="greedy-tin")
    return pool


def _submit_all(workers: int, run, jobs: list, futures: list) -> None:
    """Hand ``run(job)`` for every job to the pool of ``workers`` threads, into ``futures``.

    A signal while handing them out may land while the pool starts a thread it has not yet
    registered for the interpreter's exit, which would then wait for that thread for ever.
    So on any exception the pool is shut down (its threads, that one too, then end) and
    left for a new one."""
    pool = _thread_pool(workers)
    try:
        for job in jobs:
            futures.append(pool.submit(run, job))
    except BaseException:
        _POOLS.pop((os.getpid(), workers), None)
        pool.shutdown(wait=False, cancel_futures=True)
        raise


def _mesh_in_pieces(h: np.ndarray, tol: float, magnitude: float) -> np.ndarray:
    """The mesh of ``h`` within ``tol`` as independent rectangular pieces meshed in parallel.

    Neighbouring pieces share the grid line between them, and on it the same vertices,
    chosen first by simplifying the line alone within the error: a triangle along a side
    interpolates the side's samples exactly as the line did, so the bound holds there and
    no piece inserts a vertex its neighbour lacks. Each piece then runs the greedy
    insertion and the removal of redundant vertices on its own samples, and the pieces are
    joined (:func:`_join_pieces`). The pieces depend only on the map's size, so the mesh is
    the same on any number of threads."""
    rows, cols = h.shape
    ys = _piece_edges(rows)
    xs = _piece_edges(cols)
    line_tol = _line_tolerance(magnitude, tol)
    jobs = [(int(ys[i]), int(ys[i + 1]), int(xs[j]), int(xs[j + 1]))
            for i in range(len(ys) - 1) for j in range(len(xs) - 1)]

    tiles = (-(-rows // _TILE), -(-cols // _TILE))
    tplane = np.empty((*tiles, 3))
    tres = np.empty((*tiles, 4))
    # set when this thread stops waiting (a signal, a refusal): the pieces still running end
    # within an insertion instead of finishing
    stop = np.zeros(1, np.uint8)

    def run(job):
        y0, y1, x0, x1 = job
        # a piece's arrays are bounded by its samples; the pieces together are checked below
        return _mesh_piece(_piece_of(h, y0, y1, x0, x1), rows, cols, y0, x0, float(tol),
                           float(line_tol), _NO_BUDGET, _REMOVAL_PASSES, _DENSE_SIDES, tplane,
                           tres, _NO_SLOT_LIMIT, stop)

    workers = min(len(jobs), numba.get_num_threads())
    if len(jobs) == 1:
        coords, tris, _ = run(jobs[0])
        return _grid_triangles(coords, tris, cols)
    parts = []
    n_tris = 0
    # the mesh's size is known piece by piece: once the pieces so far already make a join
    # that cannot fit, those not yet started are dropped. Only with more than two pieces
    # per thread (with fewer, at most one is still waiting when the first is done), and
    # the limit read once (about 0.1 ms a read: a few per cent of a small map's mesh).
    early = len(jobs) > 2 * workers
    cap = memory_limit() if early else 0
    per_triangle = PEAK_BYTES_PER_TRIANGLE["greedy join"]
    futures: list = []
    try:
        if workers > 1:
            _submit_all(workers, run, jobs, futures)
            done = (future.result() for future in futures)
        else:
            done = (run(job) for job in jobs)
        for part in done:
            parts.append(part)
            n_tris += len(part[1]) // 3
            if early and len(parts) < len(jobs) and n_tris * per_triangle > cap:
                check_triangles(n_tris, "greedy join", "joining a greedy TIN of at least")
    except BaseException:
        stop[0] = 1
        for future in futures:
            future.cancel()
        raise
    check_triangles(n_tris, "greedy join", "joining a greedy TIN of")
    return _join_pieces(h, tol, parts, tplane, tres, ys, xs)


def _join_pieces(h: np.ndarray, tol: float, parts: list, tplane: np.ndarray,
                 tres: np.ndarray, ys: np.ndarray, xs: np.ndarray) -> np.ndarray:
    """One mesh of the pieces (their triangles as grid indices), with the seams relaxed.

    Alone, every piece's mesh has the shared lines as edges, and the lines' vertices stay:
    a wireframe shows the pieces' outlines. Joined, the lines' vertices are offered to the
    removal of redundant vertices, and the line edges left are flipped towards Delaunay
    where both new triangles stay within the error. Where the error forbids a flip, the
    line stays a run of edges (``python scripts/tin_pieces.py`` measures how much)."""
    rows, cols = h.shape
    coords = np.concatenate([c for c, _, _ in parts])
    tris = np.concatenate([t for _, t, _ in parts])
    half = np.concatenate([hf for _, _, hf in parts])
    v_start = np.cumsum([0] + [len(c) for c, _, _ in parts])
    e_start = np.cumsum([0] + [len(t) for _, t, _ in parts])
    is_row_line = np.zeros(rows, np.int64) - 1
    is_row_line[ys[1:-1]] = np.arange(len(ys) - 2)
    is_col_line = np.zeros(cols, np.int64) - 1
    is_col_line[xs[1:-1]] = np.arange(len(xs) - 2)
    ids = np.empty(len(coords), np.int64)
    on_line = np.zeros(len(coords), np.bool_)
    # a slot per sample of the shared lines: the vertex there, and the halfedge of the line
    # segment starting there (waiting for its twin); each seam takes one
    line_slots = (len(ys) - 2) * cols + (len(xs) - 2) * rows
    slot_vertex = np.full(line_slots, -1, np.int64)
    slot_edge = np.full(line_slots, -1, np.int64)
    seams = np.empty(line_slots, np.int64)
    n_points, n_seams = _stitch(coords, tris, half, v_start, e_start, is_row_line,
                                is_col_line, len(ys) - 2, slot_vertex, slot_edge, ids, on_line,
                                seams)
    coords = coords[:n_points]
    on_line = on_line[:n_points]
    bound = np.empty(tres.shape[0] * tres.shape[1])
    tile_order = np.empty(tres.shape[0] * tres.shape[1], np.int64)
    _remove_vertices(h, tplane, tres, bound, tile_order, coords, tris, half, n_points,
                     len(tris), float(tol), _REMOVAL_PASSES, on_line, np.zeros(1, np.uint8))
    stack = np.empty(max(64, 8 * n_seams), np.int64)
    stack[:n_seams] = seams[:n_seams]
    _relax_edges(h, tplane, tres, bound, tile_order, coords, tris, half, stack, n_seams,
                 float(tol), np.empty(6, np.int32), np.empty((2, 2), np.int32), np.empty(2))
    return _grid_triangles(coords, tris, cols)


@njit(cache=CACHE, fastmath=FASTMATH, _nrt=False)
def _stitch(coords, tris, half, v_start, e_start, is_row_line, is_col_line, n_row_lines,
            slot_vertex, slot_edge, ids, on_line, seams):
    """Join the pieces' meshes in place: one vertex number per grid sample (the pieces'
    copies of a shared vertex merged; ``coords`` compacted to the numbers' order), the
    triangles renumbered, halfedge twins offset to the joined arrays, and the open
    halfedges of the shared lines twinned with their neighbour piece's. Marks the vertices
    on shared lines in ``on_line``; ``seams`` gets one halfedge of each line edge. Returns
    the vertex and seam counts.

    ``slot_vertex`` and ``slot_edge`` (-1 filled) have a slot per sample of the shared
    lines: the row lines' first (``is_row_line[y]·cols + x``), then the column lines'."""
    rows = is_row_line.shape[0]
    cols = is_col_line.shape[0]
    n = 0
    for p in range(v_start.shape[0] - 1):
        for v in range(v_start[p], v_start[p + 1]):
            x = coords[v, 0]
            y = coords[v, 1]
            k = -1
            if is_row_line[y] >= 0:
                k = is_row_line[y] * cols + x
            elif is_col_line[x] >= 0:
                k = n_row_lines * cols + is_col_line[x] * rows + y
            if k >= 0 and slot_vertex[k] >= 0:
                ids[v] = slot_vertex[k]
                continue
            coords[n, 0] = x
            coords[n, 1] = y
            on_line[n] = k >= 0
            if k >= 0:
                slot_vertex[k] = n
            ids[v] = n
            n += 1
    n_seams = 0
    for p in range(e_start.shape[0] - 1):
        v0 = v_start[p]
        e0 = e_start[p]
        for e in range(e0, e_start[p + 1]):  # the pieces hold live triangles only
            tris[e] = ids[v0 + tris[e]]
            if half[e] >= 0:
                half[e] += e0
    for e in range(tris.shape[0]):
        if half[e] >= 0:
            continue
        a = tris[e]
        b = tris[e - e % 3 + (e + 1) % 3]
        ax, ay = coords[a, 0], coords[a, 1]
        bx, by = coords[b, 0], coords[b, 1]
        # an open edge along a shared line (the map's own border has no line there)
        k = -1
        if ay == by and is_row_line[ay] >= 0:
            k = is_row_line[ay] * cols + min(ax, bx)
        elif ax == bx and is_col_line[ax] >= 0:
            k = n_row_lines * cols + is_col_line[ax] * rows + min(ay, by)
        if k < 0:
            continue
        if slot_edge[k] < 0:
            slot_edge[k] = e
        else:
            twin = slot_edge[k]
            half[e] = twin
            half[twin] = e
            seams[n_seams] = e
            n_seams += 1
    return n, n_seams


@njit(cache=CACHE, fastmath=FASTMATH, nogil=True)
def _grid_triangles(coords, tris, cols):
    """The live triangles (vertex -1: removed) as ``uint32 (M, 3)`` grid indices."""
    live = 0
    for t in range(tris.shape[0] // 3):
        if tris[3 * t] >= 0:
            live += 1
    out = np.empty((live, 3), np.uint32)
    k = 0
    for t in range(tris.shape[0] // 3):
        if tris[3 * t] >= 0:
            for m in range(3):
                v = tris[3 * t + m]
                out[k, m] = coords[v, 1] * cols + coords[v, 0]
            k += 1
    return out


@njit(cache=CACHE, nogil=True)
def _grown(a, size, fill):
    """``a`` (C-contiguous) in a new array of ``size`` rows, the new rows set to ``fill``.

    Element by element through flat views: a slice assignment would bring numba's
    shape-mismatch error message, whose formatting code took longer to compile than the
    copy (this is compiled once per array type of the insertion)."""
    out = np.empty((size, *a.shape[1:]), a.dtype)
    flat = out.reshape(out.size)
    old = a.reshape(a.size)
    for k in range(old.size):
        flat[k] = old[k]
    for k in range(old.size, flat.size):
        flat[k] = fill
    return out


@njit(cache=CACHE, fastmath=FASTMATH)
def _ring_param(x, y, x0, y0, x1, y1):
    """Position of ``(x, y)`` on the rectangle ``[x0, x1] × [y0, y1]``'s boundary, walked
    from ``(x0, y0)`` along the top, down the right side, back along the bottom and up the
    left side: 0 … 4, each side one unit, so that two nested rectangles' corners match."""
    if y == y0 and x < x1:
        return (x - x0) / (x1 - x0)
    if x == x1 and y < y1:
        return 1.0 + (y - y0) / (y1 - y0)
    if y == y1 and x > x0:
        return 2.0 + (x1 - x) / (x1 - x0)
    return 3.0 + (y1 - y) / (y1 - y0)


@njit(cache=CACHE, fastmath=FASTMATH)
def _put_triangle(tris, coords, t, a, b, c):
    """Triangle ``t`` with corners ``a, b, c`` in the mesh's winding (swapped if needed)."""
    if _orient(coords[a, 0], coords[a, 1], coords[b, 0], coords[b, 1], coords[c, 0],
               coords[c, 1]) < 0:
        b, c = c, b
    tris[3 * t] = a
    tris[3 * t + 1] = b
    tris[3 * t + 2] = c


@njit(cache=CACHE, fastmath=FASTMATH, nogil=True)
def _grid_start(nx, ny, keep):
    """A triangulation of an ``nx × ny`` piece (both ≥ 4) with every inner sample a vertex
    and, on its four sides, only the samples ``keep`` marks (rows: top, bottom along x;
    left, right along y; corners kept): the start of the decimation of dense pieces.

    The inner samples (rows and columns 1 … n − 2) are two triangles a cell. Between their
    outline and the piece's sides lies a band one sample wide; it is closed by walking both
    outlines at once, by the same position along the sides (:func:`_ring_param`), always
    joining the next vertex of the one that is behind: every triangle then has two corners
    on one outline and one on the other, adjacent rows or columns, and covers no sample
    but its corners and its edges' (the sides' samples between kept vertices are the
    simplified lines', within their error). Returns the vertices ``(x, y)`` (the corners
    first, as the insertion numbers them), the triangles and their halfedge twins."""
    n_ring = 0
    for side in range(4):
        n = nx if side < 2 else ny
        for i in range(n):
            n_ring += keep[side, i]
    n_ring -= 4  # corners are on two sides
    n_inner = (nx - 2) * (ny - 2)
    n_points = n_ring + n_inner
    coords = np.empty((n_points, 2), np.int64)
    outer = np.empty(n_ring, np.int64)
    outer_p = np.empty(n_ring)
    # corners first, numbered as the insertion does
    coords[0, 0], coords[0, 1] = 0, 0
    coords[1, 0], coords[1, 1] = nx - 1, 0
    coords[2, 0], coords[2, 1] = 0, ny - 1
    coords[3, 0], coords[3, 1] = nx - 1, ny - 1
    # the kept side vertices in walking order: top (left to right), right (down), bottom
    # (right to left), left (up); each side from its first corner, which is kept
    starts = ((0, 0), (nx - 1, 0), (nx - 1, ny - 1), (0, ny - 1))
    steps = ((1, 0), (0, 1), (-1, 0), (0, -1))
    n = 4
    k = 0
    for side in range(4):
        row = (0, 3, 1, 2)[side]  # its keep mask
        corner = (0, 1, 3, 2)[side]
        sx, sy = starts[side]
        dx, dy = steps[side]
        for step in range(nx - 1 if side % 2 == 0 else ny - 1):
            x = sx + dx * step
            y = sy + dy * step
            if not keep[row, x if side % 2 == 0 else y]:
                continue
            v = corner
            if step > 0:
                coords[n, 0], coords[n, 1] = x, y
                v = n
                n += 1
            outer[k] = v
            k += 1
    for k in range(n_ring):
        v = outer[k]
        outer_p[k] = _ring_param(coords[v, 0], coords[v, 1], 0, 0, nx - 1, ny - 1)
    base = n
    for y in range(1, ny - 1):
        for x in range(1, nx - 1):
            coords[n, 0] = x
            coords[n, 1] = y
            n += 1
    # the inner outline in walking order
    n_loop = 2 * (nx - 3) + 2 * (ny - 3)
    inner = np.empty(n_loop, np.int64)
    inner_p = np.empty(n_loop)
    k = 0
    for x in range(1, nx - 2):
        inner[k] = base + (x - 1)
        k += 1
    for y in range(1, ny - 2):
        inner[k] = base + (y - 1) * (nx - 2) + (nx - 3)
        k += 1
    for x in range(nx - 2, 1, -1):
        inner[k] = base + (ny - 3) * (nx - 2) + (x - 1)
        k += 1
    for y in range(ny - 2, 1, -1):
        inner[k] = base + (y - 1) * (nx - 2)
        k += 1
    for k in range(n_loop):
        v = inner[k]
        inner_p[k] = _ring_param(coords[v, 0], coords[v, 1], 1, 1, nx - 2, ny - 2)
    n_tris = 2 * (nx - 3) * (ny - 3) + n_ring + n_loop
    tris = np.empty(3 * n_tris, np.int32)
    t = 0
    for y in range(1, ny - 2):
        for x in range(1, nx - 2):
            p00 = base + (y - 1) * (nx - 2) + (x - 1)
            _put_triangle(tris, coords, t, p00 + nx - 1, p00, p00 + nx - 2)
            _put_triangle(tris, coords, t + 1, p00, p00 + nx - 1, p00 + 1)
            t += 2
    i = 0
    j = 0
    while i < n_ring or j < n_loop:
        next_o = outer_p[i + 1] if i + 1 < n_ring else 4.0
        next_i = inner_p[j + 1] if j + 1 < n_loop else 4.0
        o = outer[i % n_ring]
        a = inner[j % n_loop]
        if j < n_loop and (next_i <= next_o or i == n_ring):
            _put_triangle(tris, coords, t, o, a, inner[(j + 1) % n_loop])
            j += 1
        else:
            _put_triangle(tris, coords, t, o, outer[(i + 1) % n_ring], a)
            i += 1
        t += 1
    # twins: inside the grid by the cells' layout; the band's and the grid outline's by
    # each open halfedge's reverse among the open halfedges leaving its other end
    half = np.full(3 * n_tris, -1, np.int32)
    cw = nx - 3
    for y in range(ny - 3):
        for x in range(cw):
            c = y * cw + x
            half[6 * c] = 6 * c + 3
            half[6 * c + 3] = 6 * c
            if x > 0:
                half[6 * c + 1] = 6 * (c - 1) + 4
                half[6 * (c - 1) + 4] = 6 * c + 1
            if y > 0:
                half[6 * c + 5] = 6 * (c - cw) + 2
                half[6 * (c - cw) + 2] = 6 * c + 5
    count = np.zeros(n_points + 1, np.int64)
    for e in range(3 * n_tris):
        if half[e] < 0:
            count[tris[e] + 1] += 1
    for v in range(n_points):
        count[v + 1] += count[v]
    out = np.empty(count[n_points], np.int64)
    at = count[:-1].copy()
    for e in range(3 * n_tris):
        if half[e] < 0:
            out[at[tris[e]]] = e
            at[tris[e]] += 1
    for m0 in range(out.shape[0]):
        e = out[m0]
        a = tris[e]
        b = tris[_next_edge(e)]
        for m in range(count[b], count[b + 1]):
            e2 = out[m]
            if tris[_next_edge(e2)] == a:
                half[e] = e2
                break
    return coords, tris, half


def _piece_of(h: np.ndarray, y0: int, y1: int, x0: int, x1: int) -> np.ndarray:
    """The piece ``h[y0 : y1 + 1, x0 : x1 + 1]`` as its own array (a copy unless it is the
    whole map: its rows stay together in cache while it is meshed), read-only like the
    map's heights, so the kernels that see both compile once."""
    rows, cols = h.shape
    if (y0, y1, x0, x1) == (0, rows - 1, 0, cols - 1):
        return read_only(h)
    return read_only(np.ascontiguousarray(h[y0:y1 + 1, x0:x1 + 1]))


@njit(cache=CACHE, fastmath=FASTMATH, nogil=True)
def _mesh_piece(piece, rows, cols, y0, x0, tol, line_tol, budget, passes, dense_sides, tplane,
                tres, max_slots, stop):
    """Greedy insertion over ``piece`` (:func:`_piece_of`: the samples from row ``y0`` and
    column ``x0`` of a ``rows × cols`` map), then, when the error was reached, ``passes``
    of the removal of redundant vertices. The insertion starts from the piece's corners and
    the vertices of its sides on lines shared with other pieces: each such side is
    simplified alone within ``line_tol`` first (its neighbour simplifies the same samples
    the same way). When the error is to be reached (no budget, ``passes`` > 0) and the
    four sides, each simplified so, keep at least a ``dense_sides`` share of their samples,
    the piece is decimated instead: :func:`_grid_start`, then the removal (``inf``: never;
    one greedy order over the whole map passes it). The piece's tiles
    (:func:`_tile_ranges`) go into the map's ``tplane`` and ``tres``. Returns the vertices
    as map coordinates ``(x, y)``, the live triangles as indices into them (flat) and
    their halfedge twins. Once another thread sets ``stop[0]`` (an interrupted mesh) the
    insertion ends within a step and returns no triangles, the removal within a vertex.

    One compiled call for the whole piece, growing its own arrays: pieces meshed on
    several threads hold the interpreter's lock only to enter. Indices are 32-bit to halve
    the memory the insertion walks through (coordinates stay 64-bit for the in-circle
    test's products)."""
    ny, nx = piece.shape
    y1 = y0 + ny - 1
    x1 = x0 + nx - 1
    forced = np.empty((2 * (nx + ny), 2), np.int64)
    keep = np.ones((4, max(nx, ny)), np.bool_)
    n_forced = 0
    n_kept = 0
    # the sides: top, bottom (along x), left, right (along y), in local coordinates; those
    # on shared lines are forced (corners come twice and are inserted once), the others are
    # simplified too when the pieces are (they tell how dense the mesh will be)
    for side in range(4):
        along_x = side < 2
        if side == 0:
            shared = y0 > 0
        elif side == 1:
            shared = y1 < rows - 1
        elif side == 2:
            shared = x0 > 0
        else:
            shared = x1 < cols - 1
        if not shared and dense_sides > 1:
            continue  # never decimated: only the shared sides matter
        fixed = (0 if side == 0 else ny - 1) if along_x else (0 if side == 2 else nx - 1)
        n = nx if along_x else ny
        line = np.ascontiguousarray(piece[fixed]) if along_x else np.ascontiguousarray(
            piece[:, fixed])
        if line_tol > 0:
            _simplify_line(line, line_tol, keep[side, :n])
        for i in range(n):
            if keep[side, i]:
                n_kept += 1
                if shared:
                    forced[n_forced, 0] = i if along_x else fixed
                    forced[n_forced, 1] = fixed if along_x else i
                    n_forced += 1
    ty, tx = -(-ny // _TILE), -(-nx // _TILE)
    p_plane = np.empty((ty, tx, 3))
    p_res = np.empty((ty, tx, 4))
    _tile_ranges(piece, p_plane, p_res)
    # scratch of the tiled search: one bound and one heap slot per tile
    bound = np.empty(ty * tx)
    order = np.empty(ty * tx, np.int64)
    if (passes > 0 and budget == _NO_BUDGET and nx >= 4 and ny >= 4
            and n_kept >= dense_sides * 2 * (nx + ny)):
        # a dense mesh: start from every sample and remove what the error allows
        coords, tris, half = _grid_start(nx, ny, keep)
        n_edges = tris.shape[0]
        _remove_vertices(piece, p_plane, p_res, bound, order, coords, tris, half,
                         coords.shape[0], n_edges, tol, passes,
                         np.ones(coords.shape[0], np.bool_), stop)
        n_points = _drop_unused(coords, tris)
    else:
        coords, tris, half, n_points, n_edges = _insert_piece(
            piece, p_plane, p_res, bound, order, forced[:n_forced], tol, budget, passes,
            max_slots, stop)
        if n_edges < 0:  # stopped before growing past max_slots, or told to: no triangles
            return coords[:0], tris[:0], half[:0]
    # the piece's tiles are the map's (pieces start on tile multiples); a piece's last
    # row or column of tiles holds only its shared line, the next piece's first tiles
    t_y, t_x = y0 // _TILE, x0 // _TILE
    nty = ty - (1 if y1 < rows - 1 else 0)
    ntx = tx - (1 if x1 < cols - 1 else 0)
    # element by element: a slice assignment compiles numba's shape-mismatch message too
    for i in range(nty):
        for j in range(ntx):
            for m in range(3):
                tplane[t_y + i, t_x + j, m] = p_plane[i, j, m]
            for m in range(4):
                tres[t_y + i, t_x + j, m] = p_res[i, j, m]
    coords = coords[:n_points]
    for v in range(n_points):
        coords[v, 0] += x0
        coords[v, 1] += y0
    # here, on the piece's own thread, rather than in the serial join: a decimated piece
    # leaves most of its grid's triangle slots removed
    n_edges = _compact_triangles(tris, half, n_edges)
    # the insertion keeps the winding of the two first triangles: counter-clockwise seen
    # from above (+Y) with rows growing southward
    return coords, tris[:n_edges], half[:n_edges]


@njit(cache=CACHE, fastmath=FASTMATH, nogil=True)
def _compact_triangles(tris, half, n_edges):
    """Move the live triangles of ``tris[:n_edges]`` (removed ones have vertex -1) to the
    front in their order, their twins renumbered to match; returns the live halfedges'
    count. The live triangles keep their relative order, so whatever walks them in order
    (the join's removal, the output) does the same as before."""
    n_tris = n_edges // 3
    moved_to = np.empty(n_tris, np.int64)
    live = 0
    for t in range(n_tris):
        if tris[3 * t] >= 0:
            moved_to[t] = live
            live += 1
        else:
            moved_to[t] = -1
    for t in range(n_tris):
        k = moved_to[t]
        if k < 0:
            continue
        for m in range(3):
            tris[3 * k + m] = tris[3 * t + m]
            twin = half[3 * t + m]
            half[3 * k + m] = -1 if twin < 0 else 3 * moved_to[twin // 3] + twin % 3
    return 3 * live


@njit(cache=CACHE, fastmath=FASTMATH, nogil=True)
def _insert_piece(piece, p_plane, p_res, bound, order, forced, tol, budget, passes,
                  max_slots, stop):
    """:func:`_mesh_piece`'s greedy insertion from the piece's corners and its ``forced``
    side vertices, then, when the error was reached, ``passes`` of the removal of
    redundant vertices. Returns the vertices, triangles, twins and how many of the first
    two and of the halfedges are used; the halfedges' count is -1 when the arrays would
    have to grow to more than ``max_slots`` triangles (the memory limit's share), or when
    another thread set ``stop[0]``."""
    ny, nx = piece.shape
    n_forced = forced.shape[0]
    capacity = max(_START_SLOTS, 4 * n_forced + 16)
    coords = np.zeros((capacity // 2 + 8, 2), np.int64)
    tris = np.zeros(3 * capacity, np.int32)
    half = np.full(3 * capacity, -1, np.int32)
    cand = np.zeros((capacity, 2), np.int32)
    cerr = np.zeros(capacity, np.float64)
    queue = np.zeros(capacity, np.int32)
    qerr = np.zeros(capacity, np.float64)
    qidx = np.full(capacity, -1, np.int32)
    # stacks: only the slots below their counters are read, all written first (zeroing
    # them took a sixth of a sparse piece's time)
    pending = np.empty(1 << 16, np.int32)
    stack = np.empty(1 << 16, np.int32)
    state = np.zeros(5, np.int64)
    p0 = _add_point(coords, state, 0, 0)
    p1 = _add_point(coords, state, nx - 1, 0)
    p2 = _add_point(coords, state, 0, ny - 1)
    p3 = _add_point(coords, state, nx - 1, ny - 1)
    t0 = _add_triangle(tris, half, qidx, pending, state, p3, p0, p2, -1, -1, -1, -1)
    _add_triangle(tris, half, qidx, pending, state, p0, p3, p1, t0, -1, -1, -1)
    if n_forced > 0:
        _insert_border_points(forced, coords, tris, half, queue, qerr, qidx,
                              pending, stack, state)
    # every triangle so far waits to be rasterised, in their order (the first thing
    # _refine does; not a kernel of its own: one copy less of the rasterisation to compile)
    n_tris = state[_N_EDGES] // 3
    for t in range(n_tris):
        pending[t] = t
    state[_N_PENDING] = n_tris
    while True:
        _refine(piece, p_plane, p_res, bound, order, tol, budget, coords, tris, half, cand,
                cerr, queue, qerr, qidx, pending, stack, state, stop)
        if state[_STATUS] == _STOPPED:
            return coords, tris, half, state[_N_POINTS], -1
        if state[_STATUS] != _FULL:
            break
        if 2 * capacity > max_slots:
            return coords, tris, half, state[_N_POINTS], -1
        capacity *= 2
        coords = _grown(coords, capacity // 2 + 8, 0)
        tris = _grown(tris, 3 * capacity, 0)
        half = _grown(half, 3 * capacity, -1)
        cand = _grown(cand, capacity, 0)
        cerr = _grown(cerr, capacity, 0.0)
        queue = _grown(queue, capacity, 0)
        qerr = _grown(qerr, capacity, 0.0)
        qidx = _grown(qidx, capacity, -1)
    n_points = state[_N_POINTS]
    n_edges = state[_N_EDGES]
    if passes > 0 and (state[_Q_LEN] == 0 or qerr[0] <= tol):
        # the error bound is met: drop the vertices it no longer needs
        _remove_vertices(piece, p_plane, p_res, bound, order, coords, tris, half, n_points,
                         n_edges, tol, passes, np.ones(n_points, np.bool_), stop)
    return coords, tris, half, n_points, n_edges


@njit(cache=CACHE, fastmath=FASTMATH, nogil=True)
def _drop_unused(coords, tris):
    """Renumber the vertices the triangles still use in their order (the removed ones
    dropped: a decimated piece keeps a fraction of its samples) and return how many."""
    n_points = coords.shape[0]
    new_id = np.full(n_points, -1, np.int64)
    for e in range(tris.shape[0]):
        if tris[e] >= 0:
            new_id[tris[e]] = 0
    n = 0
    for v in range(n_points):
        if new_id[v] == 0:
            new_id[v] = n
            coords[n, 0] = coords[v, 0]
            coords[n, 1] = coords[v, 1]
            n += 1
    for e in range(tris.shape[0]):
        if tris[e] >= 0:
            tris[e] = new_id[tris[e]]
    return n


