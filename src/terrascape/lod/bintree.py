"""Binary triangle tree (bintree) over a square ``(2**n + 1)²`` grid — implicit numbering,
geometry, neighbours and Duchaineau's nested error bounds.

Numbering (heap order, no per-triangle objects)
-----------------------------------------------
The grid square is cut along its NW–SE diagonal into two root triangles, id 2 (``A``, the
south-west half) and id 3 (``B``, the north-east half), at level 0. Triangle ``t`` has the
children ``2t`` (``T0``) and ``2t + 1`` (``T1``); its level is ``bit_length(t) − 2``. With
``S = 2**n`` cells per side the finest level is ``L = 2n`` (half grid cells) and every id is
below ``4·S²``, so per-triangle flags fit in one flat array.

A triangle is written ``(apex, v0, v1)`` — the thesis's ``T = (v_a, v_0, v_1)``: ``v_a`` is
the right-angle vertex and ``v0–v1`` the hypotenuse. Splitting adds ``v_c``, the midpoint
of the hypotenuse, and ``T0 = (v_c, v_a, v_0)``, ``T1 = (v_c, v_1, v_a)``.
Both roots are counter-clockwise seen from above (+Y) and the split keeps the orientation,
so every triangle of every bintree mesh is counter-clockwise seen from above: with
``x = col``, ``z = row`` the normal ``(v0 − v_a) × (v1 − v_a)`` points up (the convention of
:mod:`terrascape.lod.mesh_checks`).

Coordinates are grid ``(row, col)`` pairs; world positions are ``x = col·dx``, ``z = row·dz``,
``y = h[row, col]``.

Neighbours are found geometrically, not stored: the base neighbour ``T_B`` (sharing the
hypotenuse) has the apex mirrored through ``v_c``, and :func:`_locate` descends from the
root to the triangle of a given level containing a point (O(level) integer steps).

Error bounds
------------
Duchaineau et al. 1997 ("ugniježđene granice pogrešaka"): the wedgie thickness

    e_T = max(e_T0, e_T1) + |z(v_c) − (z(v_0) + z(v_1)) / 2|,   e_T = 0 at the finest level,

is a TRUE bound on the vertical distance between the triangle's plane and every grid sample
it covers, and it is nested (``e_T >= e_child``): the child's plane differs from the parent's
by a linear function that is 0 at the two shared vertices and ``±|z(v_c) − mean|`` at
``v_c``. Both triangles of a diamond share ``v_c``, so :func:`wedgie_errors` stores one value
per grid vertex: the maximum of the two triangles' thicknesses (still a true, nested bound,
and the diamond's merge priority needs exactly that maximum).

References
----------
- D. Filipović, "Generiranje i prikaz terena" (Terrain generation and display), BSc thesis 221,
  Faculty of Electrical Engineering and Computing, University of Zagreb, 2008, §4.1, §4.1.1,
  §4.1.1–4.1.2.
"""

from __future__ import annotations

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit
from terrascape._validate import as_height_array, check_int, check_pow2_plus1_square
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap

__all__ = [
    "ROOT_A",
    "ROOT_B",
    "level_of",
    "max_level",
    "partner_of",
    "triangle_vertices",
    "uniform_triangles",
    "wedgie_errors",
]

ROOT_A = 2
ROOT_B = 3


# --------------------------------------------------------------------------------------------
# numba kernels (private): ids and geometry
# --------------------------------------------------------------------------------------------
@njit(cache=CACHE, fastmath=FASTMATH)
def _level(t):
    """Level of heap id ``t`` (ids 2, 3 are level 0)."""
    lvl = -2
    while t > 0:
        t >>= 1
        lvl += 1
    return lvl


@njit(cache=CACHE, fastmath=FASTMATH)
def _orient(ar, ac, br, bc, cr, cc):
    """Y component of ``(b − a) × (c − a)`` with ``x = col``, ``z = row``: > 0 ⇔ the triangle
    (a, b, c) is counter-clockwise seen from above."""
    return (br - ar) * (cc - ac) - (bc - ac) * (cr - ar)


@njit(cache=CACHE, fastmath=FASTMATH)
def _tri_coords(t, size):
    """``(ar, ac, r0, c0, r1, c1)``: apex and hypotenuse ends of triangle ``t`` on a grid of
    ``size`` cells per side; walks the id's bits from the root (O(level))."""
    lvl = _level(t)
    if (t >> lvl) == 2:  # root A: apex SW, v0 SE, v1 NW
        ar, ac, r0, c0, r1, c1 = size, 0, size, size, 0, 0
    else:  # root B: apex NE, v0 NW, v1 SE
        ar, ac, r0, c0, r1, c1 = 0, size, 0, 0, size, size
    for i in range(lvl - 1, -1, -1):
        mr = (r0 + r1) >> 1
        mc = (c0 + c1) >> 1
        if ((t >> i) & 1) == 0:  # T0 = (v_c, v_a, v_0)
            r1, c1 = r0, c0
            r0, c0 = ar, ac
        else:  # T1 = (v_c, v_1, v_a)
            r0, c0 = r1, c1
            r1, c1 = ar, ac
        ar, ac = mr, mc
    return ar, ac, r0, c0, r1, c1


@njit(cache=CACHE, fastmath=FASTMATH)
def _locate(level, ar, ac, r0, c0, r1, c1, size):
    """Id of the level-``level`` triangle with the given corners (which must be a bintree
    triangle). Descends from the roots with the interior point ``(2·apex + v0 + v1) / 4``,
    in 4× integer coordinates so every test is exact."""
    pr = 2 * ar + r0 + r1
    pc = 2 * ac + c0 + c1
    s4 = 4 * size
    if pr > pc:  # below the NW–SE diagonal: root A
        t = 2
        qa_r, qa_c, q0_r, q0_c, q1_r, q1_c = s4, 0, s4, s4, 0, 0
    else:
        t = 3
        qa_r, qa_c, q0_r, q0_c, q1_r, q1_c = 0, s4, 0, 0, s4, s4
    for _ in range(level):
        mr = (q0_r + q1_r) >> 1
        mc = (q0_c + q1_c) >> 1
        if _orient(mr, mc, qa_r, qa_c, pr, pc) > 0:  # same side as v0: T0
            t = 2 * t
            q1_r, q1_c = q0_r, q0_c
            q0_r, q0_c = qa_r, qa_c
        else:
            t = 2 * t + 1
            q0_r, q0_c = q1_r, q1_c
            q1_r, q1_c = qa_r, qa_c
        qa_r, qa_c = mr, mc
    return t


@njit(cache=CACHE, fastmath=FASTMATH)
def _partner_from_coords(level, ar, ac, r0, c0, r1, c1, size):
    """Id of the base neighbour (same level, shares the hypotenuse), or −1 on the border."""
    br = r0 + r1 - ar
    bc = c0 + c1 - ac
    if br < 0 or bc < 0 or br > size or bc > size:
        return -1
    return _locate(level, br, bc, r1, c1, r0, c0, size)


@njit(cache=CACHE, fastmath=FASTMATH)
def _partner(t, size):
    ar, ac, r0, c0, r1, c1 = _tri_coords(t, size)
    return _partner_from_coords(_level(t), ar, ac, r0, c0, r1, c1, size)


@njit(cache=CACHE, fastmath=FASTMATH)
def _tri_error(err, level, max_lvl, r0, c0, r1, c1):
    """Nested bound of a triangle: the value stored at its split vertex; 0 at the finest
    level (whose hypotenuse midpoint is not a grid vertex)."""
    if level >= max_lvl:
        return 0.0
    return np.float64(err[(r0 + r1) >> 1, (c0 + c1) >> 1])


# --------------------------------------------------------------------------------------------
# nested error bounds
# --------------------------------------------------------------------------------------------
@njit(cache=CACHE, fastmath=FASTMATH)
def _wedgie_errors(h, out):
    """Fill ``out[r, c]`` with the diamond wedgie thickness of every non-corner vertex.

    Scales s = 2, 4, …, S. Per scale, first the "edge" diamonds (split vertex = midpoint of
    an axis-aligned hypotenuse of length s; children split at the centres of the four
    adjacent s/2 squares), then the "square" diamonds (split vertex = centre of an s-square,
    hypotenuse = its diagonal; children split at the four edge midpoints). The diagonal of
    square (i, j) runs NW–SE when i + j is even, NE–SW otherwise (the bintree's alternating
    "union jack" pattern, fixed by the NW–SE root diagonal).
    """
    n = h.shape[0]
    size = n - 1
    s = 2
    while s <= size:
        half = s // 2
        q = half // 2  # offset to the s/2-square centres; 0 when they are half-cells
        # edge diamonds: horizontal (row multiple of s) then vertical (col multiple of s)
        for orient in range(2):
            r_start = 0 if orient == 0 else half
            c_start = half if orient == 0 else 0
            for r in range(r_start, n, s):
                for c in range(c_start, n, s):
                    if orient == 0:
                        z0 = np.float64(h[r, c - half])
                        z1 = np.float64(h[r, c + half])
                    else:
                        z0 = np.float64(h[r - half, c])
                        z1 = np.float64(h[r + half, c])
                    d = abs(np.float64(h[r, c]) - 0.5 * (z0 + z1))
                    best = 0.0
                    if q > 0:
                        for dr in (-q, q):
                            for dc in (-q, q):
                                rr = r + dr
                                cc = c + dc
                                if 0 <= rr < n and 0 <= cc < n:
                                    v = out[rr, cc]
                                    if v > best:
                                        best = v
                    out[r, c] = d + best
        # square diamonds
        for r in range(half, n, s):
            for c in range(half, n, s):
                if ((r // s) + (c // s)) % 2 == 0:  # NW–SE diagonal
                    z0 = np.float64(h[r - half, c - half])
                    z1 = np.float64(h[r + half, c + half])
                else:  # NE–SW
                    z0 = np.float64(h[r - half, c + half])
                    z1 = np.float64(h[r + half, c - half])
                d = abs(np.float64(h[r, c]) - 0.5 * (z0 + z1))
                best = max(out[r - half, c], out[r + half, c], out[r, c - half], out[r, c + half])
                out[r, c] = d + best
        s *= 2


def wedgie_errors(heights) -> np.ndarray:
    """Duchaineau's nested wedgie thicknesses, one per grid vertex.

    ``out[r, c]`` bounds the vertical error (world units, same units as ``heights``) of both
    triangles whose hypotenuse midpoint is vertex ``(r, c)`` against every grid sample they
    cover; corners are 0. See the module docstring for the formula and why it is a true,
    nested bound.

    Parameters
    ----------
    heights
        Square ``(2**n + 1)²`` array (or :class:`~terrascape.Heightmap`).

    Returns
    -------
    numpy.ndarray
        float32 ``(N, N)``; rounded UP from the float64 computation so it stays a bound.
    """
    h = _heights(heights, "ROAM error bounds")
    out = np.zeros(h.shape, np.float64)
    _wedgie_errors(h, out)
    # float32 rounding must not shrink a bound
    f32 = out.astype(np.float32)
    low = f32.astype(np.float64) < out
    f32[low] = np.nextafter(f32[low], np.float32(np.inf))
    return f32


def _heights(heights, algorithm: str) -> np.ndarray:
    if isinstance(heights, Heightmap):
        heights = heights.heights
    h = as_height_array(heights)
    check_pow2_plus1_square(h.shape, algorithm=algorithm)
    return h


# --------------------------------------------------------------------------------------------
# small public helpers (vectorised over ids; used by tests, RTIN export and debugging)
# --------------------------------------------------------------------------------------------
def _check_size(size) -> int:
    s = check_int(size, "grid size (cells per side)", minimum=2)
    if s & (s - 1):
        raise InvalidParameterError(f"grid size (cells per side) must be a power of two, got {s}")
    return s


def max_level(size: int) -> int:
    """Finest bintree level ``2n`` for ``size = 2**n`` cells per side."""
    return 2 * (_check_size(size).bit_length() - 1)


def level_of(ids) -> np.ndarray:
    """Levels of heap ids (``2, 3`` → 0)."""
    ids = np.asarray(ids, dtype=np.int64)
    if (ids < 2).any():
        raise InvalidParameterError(f"bintree ids start at 2, got min {int(ids.min())}")
    return np.frexp(ids.astype(np.float64))[1].astype(np.int64) - 2


@njit(cache=CACHE, fastmath=FASTMATH)
def _vertices(ids, size, out):
    n = size + 1
    for i in range(ids.shape[0]):
        ar, ac, r0, c0, r1, c1 = _tri_coords(ids[i], size)
        out[i, 0] = ar * n + ac
        out[i, 1] = r0 * n + c0
        out[i, 2] = r1 * n + c1


def _check_ids(ids, size: int) -> np.ndarray:
    ids = np.ascontiguousarray(np.asarray(ids, dtype=np.int64).reshape(-1))
    if ids.size and (ids.min() < 2 or ids.max() >= 4 * size * size):
        raise InvalidParameterError(
            f"bintree ids must be in [2, {4 * size * size - 1}] for {size} cells per side, "
            f"got [{int(ids.min())}, {int(ids.max())}]"
        )
    return ids


def triangle_vertices(ids, size: int) -> np.ndarray:
    """Grid vertex indices ``(apex, v0, v1)`` (``row·(size+1) + col``) of bintree triangles;
    uint32 ``(M, 3)``, counter-clockwise seen from above."""
    size = _check_size(size)
    ids = _check_ids(ids, size)
    out = np.empty((ids.size, 3), np.uint32)
    _vertices(ids, np.int64(size), out)
    return out


@njit(cache=CACHE, fastmath=FASTMATH)
def _partners(ids, size, out):
    for i in range(ids.shape[0]):
        out[i] = _partner(ids[i], size)


def partner_of(ids, size: int) -> np.ndarray:
    """Base neighbours (same level, shared hypotenuse) of bintree triangles; −1 on the border."""
    size = _check_size(size)
    ids = _check_ids(ids, size)
    out = np.empty(ids.size, np.int64)
    _partners(ids, np.int64(size), out)
    return out


def uniform_triangles(size: int, level: int) -> np.ndarray:
    """All ``2**(level+1)`` triangles of one level: the uniform bintree mesh, uint32 (M, 3)."""
    size = _check_size(size)
    level = check_int(level, "level", minimum=0, maximum=max_level(size))
    ids = np.arange(2 << level, 4 << level, dtype=np.int64)
    return triangle_vertices(ids, size)
