"""Static terrain mesh with a TRUE maximum vertical error: a right-triangulated irregular
network (RTIN) over a ``2**n + 1`` grid.

The triangles are those of the binary triangle tree used by ROAM: the square
is cut along its diagonal into two right isosceles triangles, and a triangle is split at the
midpoint of its hypotenuse into two halves, down to one-cell triangles. A triangle is split
exactly when the grid vertex at its hypotenuse midpoint is "active", so the two triangles
sharing a hypotenuse (a diamond) are always split together.

Error (the difference from martini, which measures only the midpoint sample): the error of a
triangle is the maximum ``|h − plane|`` over EVERY grid sample it covers, computed exactly for
every triangle of the tree, level by level (each level tiles the grid once, so the cost is
``O(samples · 2n)``). A vertex gets the larger error of the (one or two) triangles it splits,
and then, finest level first, the maximum of the errors of the vertices that split its
children (nested bounds, as ROAM's). With nesting, the active set ``{v : E(v) > e}`` always
contains the parents of its members, so it is a crack-free bintree mesh, and every
unsplit triangle covers only samples within its own exact error ≤ ``E(midpoint) ≤ e``:
the bound is true, not estimated.

Budget mode: vertices are activated in decreasing order of their nested error (ties: coarser
level first, so a prefix of the order is always closed under parents). This is the greedy
split queue of ROAM with the forced splits already implied by nesting. A conforming
triangulation of a square with V vertices, B of them on the border, has ``2V − B − 2``
triangles, so each activated vertex adds exactly 2 triangles (1 on the border): the longest
prefix within ``max_triangles`` is found exactly, with zero overshoot, and a bigger budget
activates a longer prefix — the achieved bound never increases with the budget. (The
measured error is always ≤ the bound; on smooth terrain it falls with the budget too, but on
white noise it can rise slightly after a split, because a child's plane may fit a few
samples worse than its parent's did — only the bound is monotone by construction.)

Cost: :class:`Rtin`'s error setup is O(samples · 2n) once per map (about 0.1 s at 1025²,
0.5 s at 2049² on the reference machine); extraction by error is then a threshold plus a
tree walk; the first budget extraction sorts the vertices once (about 1 s at 2049²), later
ones reuse the order. One mesh for one error (:func:`rtin_mesh` with ``max_error`` only)
skips most exact errors: a triangle's error is bounded by its midpoint error plus its
children's bound, so only triangles near the final leaves are scanned, and a scan stops at
the first sample beyond the error (:func:`_active_for_error`; same mesh, bit for bit).

References
----------
- D. Filipović, "Generiranje i prikaz terena" (Terrain generation and display), BSc thesis 221,
  Faculty of Electrical Engineering and Computing, University of Zagreb, 2008, §4.1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, prange
from terrascape._validate import check_int, check_positive
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.lod.mesh_checks import _tri_error_upto, _tri_max_error

__all__ = ["Rtin", "RtinMesh", "rtin_mesh"]


@njit(cache=CACHE, fastmath=FASTMATH)
def _vertex_errors(h, n, err, lev):
    """Exact error of every bintree triangle, stored at its hypotenuse midpoint (max of the
    diamond's two triangles), then nested bottom-up. ``lev[v]`` = tree level v splits at."""
    _exact_vertex_errors(h, n, err, lev)
    _nest_errors(h.shape[0], n, err)


@njit(cache=CACHE, fastmath=FASTMATH)
def _exact_vertex_errors(h, n, err, lev):
    """The exact part of :func:`_vertex_errors` (no nesting)."""
    size = h.shape[0]
    s = size - 1
    # --- exact errors, levels 0 .. 2n-1 ---
    for j in range(n):
        side = s >> j
        nb = s // side
        half = side // 2
        # even level 2j: squares of `side`, one diagonal each, midpoint = square centre
        for bi in range(nb):
            for bj in range(nb):
                r0 = bi * side
                c0 = bj * side
                r1 = r0 + side
                c1 = c0 + side
                if (bi + bj) % 2 == 0:  # diagonal TL-BR, apexes TR and BL
                    e1 = _tri_max_error(h, r0, c0, r1, c1, r0, c1)
                    e2 = _tri_max_error(h, r0, c0, r1, c1, r1, c0)
                else:  # diagonal TR-BL, apexes TL and BR
                    e1 = _tri_max_error(h, r0, c1, r1, c0, r0, c0)
                    e2 = _tri_max_error(h, r0, c1, r1, c0, r1, c1)
                m = (r0 + half) * size + c0 + half
                err[m] = max(err[m], e1, e2)
                lev[m] = 2 * j
        # odd level 2j+1: each square's four triangles with apex at the centre and the sides
        # as hypotenuses; a side midpoint is shared by two squares (a diamond)
        for bi in range(nb):
            for bj in range(nb):
                r0 = bi * side
                c0 = bj * side
                r1 = r0 + side
                c1 = c0 + side
                rc = r0 + half
                cc = c0 + half
                e = _tri_max_error(h, r0, c0, r0, c1, rc, cc)  # north side
                m = r0 * size + cc
                err[m] = max(err[m], e)
                lev[m] = 2 * j + 1
                e = _tri_max_error(h, r1, c0, r1, c1, rc, cc)  # south
                m = r1 * size + cc
                err[m] = max(err[m], e)
                lev[m] = 2 * j + 1
                e = _tri_max_error(h, r0, c0, r1, c0, rc, cc)  # west
                m = rc * size + c0
                err[m] = max(err[m], e)
                lev[m] = 2 * j + 1
                e = _tri_max_error(h, r0, c1, r1, c1, rc, cc)  # east
                m = rc * size + c1
                err[m] = max(err[m], e)
                lev[m] = 2 * j + 1


@njit(cache=CACHE, fastmath=FASTMATH)
def _nest_errors(size, n, err):
    """Each vertex's error becomes the largest of its own and its bintree children's,
    finest level first (level 2n-1 has no grid children): the vertices above any error
    then form a closed (crack-free) set."""
    s = size - 1
    for j in range(n - 1, -1, -1):
        side = s >> j
        nb = s // side
        half = side // 2
        quarter = side // 4
        # odd level 2j+1: a side midpoint's children split at the centres of the two
        # half-size sub-squares touching that side
        if quarter > 0:
            for bi in range(nb):
                for bj in range(nb):
                    r0 = bi * side
                    c0 = bj * side
                    r1 = r0 + side
                    c1 = c0 + side
                    # sub-square centres
                    tl = (r0 + quarter) * size + c0 + quarter
                    tr = (r0 + quarter) * size + c1 - quarter
                    bl = (r1 - quarter) * size + c0 + quarter
                    br = (r1 - quarter) * size + c1 - quarter
                    m = r0 * size + c0 + half
                    err[m] = max(err[m], err[tl], err[tr])
                    m = r1 * size + c0 + half
                    err[m] = max(err[m], err[bl], err[br])
                    m = (r0 + half) * size + c0
                    err[m] = max(err[m], err[tl], err[bl])
                    m = (r0 + half) * size + c1
                    err[m] = max(err[m], err[tr], err[br])
        # even level 2j: the centre's children split at the four side midpoints
        for bi in range(nb):
            for bj in range(nb):
                r0 = bi * side
                c0 = bj * side
                m = (r0 + half) * size + c0 + half
                err[m] = max(
                    err[m],
                    err[r0 * size + c0 + half],
                    err[(r0 + side) * size + c0 + half],
                    err[(r0 + half) * size + c0],
                    err[(r0 + half) * size + c0 + side],
                )


@njit(cache=CACHE, fastmath=FASTMATH)
def _tri_bound(h, tol, slack, em, u, ar, ac, br, bc, pr, pc):
    """An upper bound of the error of triangle (a, b, apex p) that is exact (> ``tol``) when
    the triangle must split: ``em + u`` (``em`` its hypotenuse-midpoint error, ``u`` its
    children's bound) when that already proves the error within ``tol``, else the scan."""
    if (em + u) * (1.0 + 1e-6) + slack <= tol:
        return em + u
    return _tri_error_upto(h, ar, ac, br, bc, pr, pc, tol)


@njit(cache=CACHE, fastmath=FASTMATH)
def _up32(x):
    """``x`` as float32, rounded up (the bounds must never shrink)."""
    return np.float32(x * (1.0 + 2.4e-7))


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _active_for_error(h, n, tol, slack, ud, active):
    """The active set of :class:`Rtin` for one error ``tol``, without every triangle's error.

    Finest level first, a vertex is active iff a vertex splitting its children is (nesting),
    or one of its (one or two) triangles has a sample more than ``tol`` off its plane. That
    scan is skipped when an upper bound proves it cannot find one: with ``T0`` a child of
    ``T`` and ``m`` the midpoint of T's hypotenuse, ``|h − P_T| ≤ |h − P_T0| + |P_T0 − P_T|``
    and ``P_T0 − P_T`` is linear on T0, zero at T's corners, ``e_m = h(m) − P_T(m)`` at m, so
    ``err(T) ≤ |e_m| + max err(children)``. ``ud`` keeps, per vertex, a bound of its
    triangles' errors (max over the diamond): the exact error where a triangle was scanned,
    else that sum (float32, rounded up; the margin 1e-6 and ``slack`` cover the float64
    rounding of the sum against the heights). Only triangles near the final mesh's leaves
    are scanned, and the scan of a triangle that must split stops at its first sample beyond
    ``tol``. (The bound of an active vertex is never read: its parents are active.) The
    result equals ``Rtin(h).errors > tol`` exactly. ``ud`` and ``active`` are
    ``(size, size)``; every vertex but the four corners is written before it is read."""
    size = h.shape[0]
    s = size - 1
    for j in range(n - 1, -1, -1):
        side = s >> j
        half = side >> 1
        q = half >> 1
        nb = s // side
        # odd level 2j+1, horizontal sides: midpoint (r, c), apexes (r ∓ half, c)
        for ri in prange(nb + 1):
            r = ri * side
            for c in range(half, s, side):
                em = abs(np.float64(h[r, c])
                         - 0.5 * (np.float64(h[r, c - half]) + np.float64(h[r, c + half])))
                uu = np.float32(0.0)
                ud_ = np.float32(0.0)
                need = False
                if q > 0:
                    if r > 0:
                        uu = max(ud[r - q, c - q], ud[r - q, c + q])
                        need = active[r - q, c - q] or active[r - q, c + q]
                    if r < s:
                        ud_ = max(ud[r + q, c - q], ud[r + q, c + q])
                        need = need or active[r + q, c - q] or active[r + q, c + q]
                bound = 0.0
                if not need and r > 0:
                    bound = _tri_bound(h, tol, slack, em, uu, r, c - half, r, c + half,
                                       r - half, c)  # fmt: skip
                    need = bound > tol
                if not need and r < s:
                    bound = max(bound, _tri_bound(h, tol, slack, em, ud_, r, c - half, r,
                                                  c + half, r + half, c))  # fmt: skip
                    need = bound > tol
                ud[r, c] = _up32(bound)
                active[r, c] = need
        # odd level 2j+1, vertical sides: midpoint (r, c), apexes (r, c ∓ half)
        for ri in prange(nb):
            r = ri * side + half
            for c in range(0, size, side):
                em = abs(np.float64(h[r, c])
                         - 0.5 * (np.float64(h[r - half, c]) + np.float64(h[r + half, c])))
                uu = np.float32(0.0)
                ud_ = np.float32(0.0)
                need = False
                if q > 0:
                    if c > 0:
                        uu = max(ud[r - q, c - q], ud[r + q, c - q])
                        need = active[r - q, c - q] or active[r + q, c - q]
                    if c < s:
                        ud_ = max(ud[r - q, c + q], ud[r + q, c + q])
                        need = need or active[r - q, c + q] or active[r + q, c + q]
                bound = 0.0
                if not need and c > 0:
                    bound = _tri_bound(h, tol, slack, em, uu, r - half, c, r + half, c,
                                       r, c - half)  # fmt: skip
                    need = bound > tol
                if not need and c < s:
                    bound = max(bound, _tri_bound(h, tol, slack, em, ud_, r - half, c,
                                                  r + half, c, r, c + half))  # fmt: skip
                    need = bound > tol
                ud[r, c] = _up32(bound)
                active[r, c] = need
        # even level 2j: square centres; diagonal TL–BR where (bi + bj) is even (as _emit)
        for bi in prange(nb):
            r = bi * side + half
            for bj in range(nb):
                c = bj * side + half
                top = ud[r - half, c]
                bottom = ud[r + half, c]
                left = ud[r, c - half]
                right = ud[r, c + half]
                need = (active[r - half, c] or active[r + half, c] or active[r, c - half]
                        or active[r, c + half])  # fmt: skip
                if (bi + bj) % 2 == 0:
                    ar, ac, br, bc = r - half, c - half, r + half, c + half
                else:
                    ar, ac, br, bc = r - half, c + half, r + half, c - half
                em = abs(np.float64(h[r, c])
                         - 0.5 * (np.float64(h[ar, ac]) + np.float64(h[br, bc])))
                bound = 0.0
                if not need:
                    if (bi + bj) % 2 == 0:  # apexes TR (children top, right), BL (left, bottom)
                        p1r, p1c, u1 = r - half, c + half, max(top, right)
                        p2r, p2c, u2 = r + half, c - half, max(left, bottom)
                    else:  # apexes TL (top, left), BR (right, bottom)
                        p1r, p1c, u1 = r - half, c - half, max(top, left)
                        p2r, p2c, u2 = r + half, c + half, max(right, bottom)
                    bound = _tri_bound(h, tol, slack, em, u1, ar, ac, br, bc, p1r, p1c)
                    need = bound > tol
                    if not need:
                        bound = max(bound, _tri_bound(h, tol, slack, em, u2, ar, ac, br, bc,
                                                      p2r, p2c))  # fmt: skip
                        need = bound > tol
                ud[r, c] = _up32(bound)
                active[r, c] = need


@njit(cache=CACHE, fastmath=FASTMATH)
def _emit(size, active, out):
    """Top-down bintree walk: split where the hypotenuse midpoint is active; write leaves
    as CCW-from-above grid indices. Returns the triangle count."""
    s = size - 1
    stack = np.empty((4 * 64 + 8, 6), np.int64)
    # roots (row, col): a=(0,0), b=(s,s), apex c=(0,s); and a=(s,s), b=(0,0), apex c=(s,0)
    stack[0, 0], stack[0, 1], stack[0, 2], stack[0, 3], stack[0, 4], stack[0, 5] = (
        0, 0, s, s, 0, s)
    stack[1, 0], stack[1, 1], stack[1, 2], stack[1, 3], stack[1, 4], stack[1, 5] = (
        s, s, 0, 0, s, 0)
    top = 2
    n = 0
    while top > 0:
        top -= 1
        ar, ac, br, bc, cr, cc = (stack[top, 0], stack[top, 1], stack[top, 2],
                                  stack[top, 3], stack[top, 4], stack[top, 5])
        sr = ar + br
        sc = ac + bc
        if sr % 2 == 0 and sc % 2 == 0:
            mr = sr // 2
            mc = sc // 2
            if active[mr * size + mc]:
                # children (c, a, m) and (b, c, m) keep the orientation
                stack[top, 0], stack[top, 1], stack[top, 2], stack[top, 3] = cr, cc, ar, ac
                stack[top, 4], stack[top, 5] = mr, mc
                top += 1
                stack[top, 0], stack[top, 1], stack[top, 2], stack[top, 3] = br, bc, cr, cc
                stack[top, 4], stack[top, 5] = mr, mc
                top += 1
                continue
        out[n, 0] = ar * size + ac
        out[n, 1] = br * size + bc
        out[n, 2] = cr * size + cc
        n += 1
    return n


def _triangles_of(size: int, active: np.ndarray) -> np.ndarray:
    """Leaves of the bintree whose split vertices are ``active`` (flat, size²)."""
    grid = active.reshape(size, size)
    # a conforming bintree mesh of a square with V vertices, B on the border, has 2V − B − 2
    # triangles: each active vertex adds 2 (1 on the border)
    count = 2 + int(np.count_nonzero(active)) * 2 - int(
        np.count_nonzero(grid[[0, -1], :]) + np.count_nonzero(grid[1:-1, [0, -1]])
    )
    out = np.empty((count, 3), np.uint32)
    written = _emit(size, active, out)
    if written != count:  # the Euler count and the walk must agree on a valid bintree
        raise AssertionError(f"RTIN emitted {written} triangles, expected {count}")
    return out


def _active_set(heightmap: Heightmap, max_error: float) -> np.ndarray:
    """Flat active-vertex mask of the coarsest RTIN mesh within ``max_error``."""
    size = heightmap.require_pow2_plus1("RTIN")
    h = heightmap.heights
    n = (size - 1).bit_length() - 1
    ud = np.empty((size, size), np.float32)
    active = np.empty((size, size), np.bool_)
    active[0, 0] = active[0, -1] = active[-1, 0] = active[-1, -1] = False  # never split
    # rounding of the float64 bound, relative to the heights' magnitude
    slack = 1e-12 * float(np.max(np.abs(h)))
    _active_for_error(h, n, float(max_error), slack, ud, active)
    return active.reshape(-1)


@dataclass(frozen=True)
class RtinMesh:
    """A static mesh: ``triangles`` (uint32 grid indices, CCW from above) and ``bound``, the
    guaranteed maximum vertical error (world units); the measured error is ≤ ``bound``."""

    triangles: np.ndarray
    bound: float


class Rtin:
    """Precomputed exact, nested bintree errors of a ``2**n + 1`` heightmap; extract meshes
    for any error or triangle budget without recomputing.

    Parameters
    ----------
    heightmap
        Square ``2**n + 1`` :class:`~terrascape.Heightmap` (heights in world units).

    Attributes
    ----------
    errors
        float64 ``(rows, cols)``: the nested error bound of splitting at each vertex
        (0 at the corners, which never split).
    """

    def __init__(self, heightmap: Heightmap) -> None:
        if not isinstance(heightmap, Heightmap):
            raise InvalidParameterError(f"expected a Heightmap, got {type(heightmap).__name__}")
        size = heightmap.require_pow2_plus1("RTIN")
        self.heightmap = heightmap
        self.size = size
        n = (size - 1).bit_length() - 1
        err = np.zeros(size * size)
        lev = np.full(size * size, -1, np.int64)
        _vertex_errors(heightmap.heights, n, err, lev)
        self._err = err
        self._lev = lev
        self.errors = err.reshape(size, size)
        self._order: np.ndarray | None = None
        self._increments: np.ndarray | None = None

    def _sorted(self) -> tuple[np.ndarray, np.ndarray]:
        if self._order is None:
            cand = np.flatnonzero(self._lev >= 0)
            # decreasing error, then coarser level first: every prefix is parent-closed
            order = cand[np.lexsort((self._lev[cand], -self._err[cand]))]
            r, c = order // self.size, order % self.size
            s = self.size - 1
            border = (r == 0) | (r == s) | (c == 0) | (c == s)
            self._order = order
            self._increments = np.cumsum(np.where(border, 1, 2)) + 2
        return self._order, self._increments  # type: ignore[return-value]

    def mesh(self, *, max_error: float | None = None,
             max_triangles: int | None = None) -> RtinMesh:
        """Coarsest mesh meeting ``max_error`` and/or at most ``max_triangles`` triangles.

        With both, the first criterion reached wins: refinement stops when the error is met
        or when the next split would exceed the budget.

        Parameters
        ----------
        max_error
            Largest allowed vertical error in world units (≥ 0; 0 = lossless).
        max_triangles
            Hard triangle budget (≥ 2), never exceeded.
        """
        if max_error is None and max_triangles is None:
            raise InvalidParameterError("give max_error (world units) and/or max_triangles")
        threshold = 0.0
        if max_error is not None:
            threshold = check_positive(max_error, "max_error (world units)", allow_zero=True)
        budget = None
        if max_triangles is not None:
            budget = check_int(max_triangles, "max_triangles", minimum=2)
        active = self._err > threshold
        k_err = int(np.count_nonzero(active))
        k = k_err
        order = None
        if budget is not None:
            order, incr = self._sorted()
            # triangles after activating the first i vertices: incr[i-1]; keep incr ≤ budget
            k = min(k_err, int(np.searchsorted(incr, budget, side="right")))
        if k < k_err:
            active = np.zeros(self.size * self.size, np.bool_)
            active[order[:k]] = True
            bound = float(self._err[order[k]])
        else:
            bound = float(self._err[~active].max()) if (~active).any() else 0.0
        out = _triangles_of(self.size, active)
        return RtinMesh(out, bound)


def rtin_mesh(heightmap: Heightmap, *, max_error: float | None = None,
              max_triangles: int | None = None) -> np.ndarray:
    """Static RTIN mesh with a true maximum vertical error and/or a hard triangle budget.

    See :class:`Rtin` (and the module docstring) for the algorithm and the guarantee:
    measured on every grid sample, the error never exceeds ``max_error``. With
    ``max_error`` alone, the mesh (identical to ``Rtin(heightmap).mesh(max_error=…)``) is
    built without every triangle's exact error (:func:`_active_for_error`): 7–15× faster
    than ``Rtin`` for one mesh (`terrascape bench lod`). Use :class:`Rtin` to extract
    several meshes or budgets from one map.

    Returns
    -------
    numpy.ndarray
        ``uint32 (M, 3)`` grid vertex indices, counter-clockwise seen from above.
    """
    if max_triangles is None and max_error is not None:
        if not isinstance(heightmap, Heightmap):
            raise InvalidParameterError(
                f"expected a Heightmap, got {type(heightmap).__name__}"
            )
        tol = check_positive(max_error, "max_error (world units)", allow_zero=True)
        size = heightmap.require_pow2_plus1("RTIN")
        return _triangles_of(size, _active_set(heightmap, tol))
    return Rtin(heightmap).mesh(max_error=max_error, max_triangles=max_triangles).triangles
