"""Measurements every level-of-detail mesh must pass: conformity and true approximation error.

All LOD code in :mod:`terrascape.lod` shares one triangle format: a ``uint32 (M, 3)`` array of
GRID VERTEX INDICES ``row * cols + col``, counter-clockwise seen from above (+Y). With
``x = col`` and ``z = row`` this means the normal ``(p1 - p0) × (p2 - p0)`` has a positive Y
component, i.e. the 2-D cross product ``dx1·dz2 − dz1·dx2`` in the (x, z) plane is NEGATIVE
(the Z axis points south, so "counter-clockwise from above" is clockwise in (col, row) maths).

The checks here are exact (integer geometry on the grid) and independent of the algorithms
that produce the meshes: ROAM, geomipmapping (§4.2) and the static RTIN.

References
----------
- D. Filipović, "Generiranje i prikaz terena" (Terrain generation and display), BSc thesis 221,
  Faculty of Electrical Engineering and Computing, University of Zagreb, 2008, §4.1, §4.2,
  Formula 3.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit
from terrascape._validate import as_height_array
from terrascape.camera import Camera
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap

__all__ = [
    "ConformityReport",
    "conformity_report",
    "frustum_mask",
    "is_conforming",
    "line_edge_share",
    "max_screen_error",
    "max_vertical_error",
    "sample_errors",
    "screen_errors",
]


# --------------------------------------------------------------------------------------------
# input validation
# --------------------------------------------------------------------------------------------
def _as_shape(shape) -> tuple[int, int]:
    try:
        rows, cols = (int(s) for s in shape)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"shape must be (rows, cols), got {shape!r}") from None
    if rows < 2 or cols < 2:
        raise InvalidParameterError(f"shape must be at least (2, 2), got {shape!r}")
    return rows, cols


def as_triangles(triangles, shape: tuple[int, int]) -> np.ndarray:
    """Validate a triangle array: integer ``(M, 3)`` grid indices in ``[0, rows·cols)``.

    Returns a C-contiguous ``int64`` copy (int64 keeps the geometry maths overflow-free).
    """
    rows, cols = _as_shape(shape)
    tri = np.asarray(triangles)
    if tri.ndim != 2 or tri.shape[1] != 3:
        raise InvalidParameterError(f"triangles must have shape (M, 3), got {tri.shape}")
    if tri.shape[0] == 0:
        raise InvalidParameterError("triangles must not be empty, got 0 triangles")
    if not np.issubdtype(tri.dtype, np.integer):
        raise InvalidParameterError(f"triangles must be integer indices, got dtype {tri.dtype}")
    tri = np.ascontiguousarray(tri, dtype=np.int64)
    lo, hi = int(tri.min()), int(tri.max())
    if lo < 0 or hi >= rows * cols:
        raise InvalidParameterError(
            f"triangle indices must be in [0, {rows * cols - 1}] for a {cols}×{rows} grid, "
            f"got [{lo}, {hi}]"
        )
    return tri


def _heights_of(heightmap) -> tuple[np.ndarray, tuple[float, float]]:
    """Heights (float32 2-D) and spacing from a Heightmap or a plain 2-D array."""
    if isinstance(heightmap, Heightmap):
        return heightmap.heights, heightmap.spacing
    return as_height_array(heightmap), (1.0, 1.0)


# --------------------------------------------------------------------------------------------
# conformity
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ConformityReport:
    """Result of :func:`conformity_report`; ``ok`` is True when every check passes.

    Counts are numbers of offending triangles / edges / vertices; areas are in grid cells
    (twice the area is integral, so the comparison is exact).
    """

    shape: tuple[int, int]
    n_triangles: int
    degenerate: int
    wrong_orientation: int
    area_expected: float
    area_actual: float
    non_manifold_edges: int
    inconsistent_edges: int
    open_interior_edges: int
    t_junctions: int
    problems: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.problems

    def __str__(self) -> str:
        if self.ok:
            rows, cols = self.shape
            return f"conforming mesh: {self.n_triangles} triangles on {cols}×{rows}"
        return "non-conforming mesh: " + "; ".join(self.problems)


@njit(cache=CACHE, fastmath=FASTMATH)
def _t_junction_count(edges_a, edges_b, used, cols):
    """Count used grid vertices lying strictly inside an edge (lattice points on the segment).

    The lattice points strictly inside segment a→b are ``a + k·(b−a)/g``, k = 1..g−1 with
    g = gcd(|dx|, |dz|): on an integer grid no other point can be a vertex.
    """
    count = 0
    for i in range(edges_a.shape[0]):
        a = edges_a[i]
        b = edges_b[i]
        ar, ac = a // cols, a % cols
        br, bc = b // cols, b % cols
        dr, dc = br - ar, bc - ac
        x, y = abs(dr), abs(dc)
        while y:
            x, y = y, x % y
        g = x
        if g <= 1:
            continue
        sr, sc = dr // g, dc // g
        for k in range(1, g):
            if used[(ar + k * sr) * cols + ac + k * sc]:
                count += 1
    return count


def conformity_report(triangles, shape) -> ConformityReport:
    """Check that ``triangles`` form a crack-free, consistently oriented tiling of the grid.

    Checks (all exact integer geometry):

    * no degenerate (zero-area) triangle;
    * every triangle counter-clockwise seen from above (+Y), see the module docstring;
    * triangle areas sum to the domain area ``(rows−1)·(cols−1)``;
    * every edge is used by at most two triangles, and a shared edge is traversed in opposite
      directions by its two triangles (consistent orientation);
    * edges used once (boundary edges) lie on the domain border;
    * no T-junction: no vertex used by the mesh lies strictly inside any triangle's edge —
      the crack condition that ROAM's forced splits and geomipmapping's
      changed edge indexing (§4.2, Figure 24) exist to prevent.

    Parameters
    ----------
    triangles
        ``(M, 3)`` grid vertex indices ``row·cols + col``.
    shape
        ``(rows, cols)`` of the grid.
    """
    rows, cols = _as_shape(shape)
    tri = as_triangles(triangles, (rows, cols))
    r = tri // cols
    c = tri % cols
    # twice the signed area in (x=col, z=row); CCW from above <=> negative
    cross = (c[:, 1] - c[:, 0]) * (r[:, 2] - r[:, 0]) - (r[:, 1] - r[:, 0]) * (c[:, 2] - c[:, 0])
    degenerate = int(np.count_nonzero(cross == 0))
    wrong = int(np.count_nonzero(cross > 0))
    area2 = int(np.abs(cross).sum())
    expected2 = 2 * (rows - 1) * (cols - 1)

    # directed edges a->b of every triangle
    a = tri.reshape(-1)
    b = tri[:, [1, 2, 0]].reshape(-1)
    lo = np.minimum(a, b)
    hi = np.maximum(a, b)
    key = lo * (rows * cols) + hi
    order = np.argsort(key, kind="stable")
    key_s = key[order]
    starts = np.flatnonzero(np.r_[True, key_s[1:] != key_s[:-1]])
    counts = np.diff(np.r_[starts, key_s.size])
    non_manifold = int(np.count_nonzero(counts > 2))
    # shared edges: the two directed copies must run in opposite directions
    pair = starts[counts == 2]
    forward = a[order] < b[order]
    inconsistent = int(np.count_nonzero(forward[pair] == forward[pair + 1]))
    # edges used once must lie on the border: both ends on the same border line
    single = order[starts[counts == 1]]
    ra, ca, rb, cb = a[single] // cols, a[single] % cols, b[single] // cols, b[single] % cols
    on_border = (
        ((ra == 0) & (rb == 0))
        | ((ra == rows - 1) & (rb == rows - 1))
        | ((ca == 0) & (cb == 0))
        | ((ca == cols - 1) & (cb == cols - 1))
    )
    open_interior = int(np.count_nonzero(~on_border))

    used = np.zeros(rows * cols, dtype=np.bool_)
    used[a] = True
    uniq = order[starts]
    t_junctions = int(_t_junction_count(lo[uniq], hi[uniq], used, np.int64(cols)))

    problems = []
    if degenerate:
        problems.append(f"{degenerate} degenerate (zero-area) triangle(s)")
    if wrong:
        problems.append(f"{wrong} triangle(s) clockwise seen from above (expected CCW, +Y normal)")
    if area2 != expected2:
        problems.append(
            f"triangle areas sum to {area2 / 2:g} cells, expected the domain area {expected2 / 2:g}"
        )
    if non_manifold:
        problems.append(f"{non_manifold} edge(s) shared by more than two triangles")
    if inconsistent:
        problems.append(f"{inconsistent} shared edge(s) traversed in the same direction twice")
    if open_interior:
        problems.append(f"{open_interior} edge(s) used once that are not on the domain border")
    if t_junctions:
        problems.append(f"{t_junctions} T-junction(s): a mesh vertex strictly inside an edge")
    return ConformityReport(
        shape=(rows, cols),
        n_triangles=int(tri.shape[0]),
        degenerate=degenerate,
        wrong_orientation=wrong,
        area_expected=expected2 / 2,
        area_actual=area2 / 2,
        non_manifold_edges=non_manifold,
        inconsistent_edges=inconsistent,
        open_interior_edges=open_interior,
        t_junctions=t_junctions,
        problems=problems,
    )


def is_conforming(triangles, shape) -> bool:
    """True when :func:`conformity_report` finds no problem."""
    return conformity_report(triangles, shape).ok


# --------------------------------------------------------------------------------------------
# vertical error: rasterise every triangle over the grid samples it covers
# --------------------------------------------------------------------------------------------
def line_edge_share(triangles, shape, rows_at, cols_at) -> float:
    """Share of the length of the grid rows ``rows_at`` and columns ``cols_at`` (across
    the whole grid) that runs along mesh edges: 0 when the mesh only crosses them, 1 when
    they are edges end to end. It shows where a mesh built in pieces keeps their outlines.

    Parameters
    ----------
    triangles
        ``(M, 3)`` grid vertex indices ``row·cols + col`` of a conforming mesh.
    shape
        ``(rows, cols)`` of the grid.
    rows_at, cols_at
        Row and column numbers of the lines.
    """
    rows, cols = _as_shape(shape)
    tri = as_triangles(triangles, (rows, cols)).astype(np.int64)
    rows_at = np.asarray(rows_at, np.int64)
    cols_at = np.asarray(cols_at, np.int64)
    total = len(rows_at) * (cols - 1) + len(cols_at) * (rows - 1)
    if total == 0:
        return 0.0
    # each edge once (an inner edge belongs to two triangles, one on the border to one)
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    x, y = edges % cols, edges // cols
    on_row = (y[:, 0] == y[:, 1]) & np.isin(y[:, 0], rows_at)
    on_col = (x[:, 0] == x[:, 1]) & np.isin(x[:, 0], cols_at)
    length = (np.abs(x[on_row, 0] - x[on_row, 1]).sum()
              + np.abs(y[on_col, 0] - y[on_col, 1]).sum())
    return float(length) / total


@njit(cache=CACHE, fastmath={"nnan", "nsz"})
def _tri_error_upto(h, ar, ac, br, bc, cr, cc, tol):
    """Maximum ``|h − plane|`` over the grid samples of triangle (a, b, c), edges included,
    or the first row maximum found above ``tol`` (early exit, tested once per row so the
    inner loop stays branch-free). Each row is clipped to the triangle's exact integer span
    (edge functions are exact in integer arithmetic, so a sample on a shared edge is counted
    by both triangles, and both interpolate it identically, linear along the edge). The
    fastmath flags only drop NaN and signed-zero handling, which finite heights never need;
    no reassociation or contraction, so the arithmetic is that of :func:`_sample_errors`."""
    det = (bc - ac) * (cr - ar) - (br - ar) * (cc - ac)
    if det == 0:
        return 0.0
    sg = 1 if det > 0 else -1
    ha = np.float64(h[ar, ac])
    hb = np.float64(h[br, bc])
    hc = np.float64(h[cr, cc])
    inv = 1.0 / det
    # edge functions w = A·r + B·c + C (w_a is 0 on edge b–c, …), inside: sg·w ≥ 0
    aa, ba, ca = cc - bc, br - cr, bc * cr - br * cc
    ab, bb, cb = ac - cc, cr - ar, cc * ar - cr * ac
    a_c, b_c, c_c = bc - ac, ar - br, ac * br - ar * bc
    cmin, cmax = min(ac, bc, cc), max(ac, bc, cc)
    best = 0.0
    for r in range(min(ar, br, cr), max(ar, br, cr) + 1):
        ka = aa * r + ca
        kb = ab * r + cb
        kc = a_c * r + c_c
        lo = cmin
        hi = cmax
        for k in range(3):
            if k == 0:
                b, w = sg * ba, sg * ka
            elif k == 1:
                b, w = sg * bb, sg * kb
            else:
                b, w = sg * b_c, sg * kc
            if b > 0:  # b·c + w ≥ 0  ⇔  c ≥ ceil(−w / b)
                lo = max(lo, -(w // b))
            elif b < 0:  # c ≤ floor(w / −b)
                hi = min(hi, w // (-b))
            elif w < 0:
                hi = lo - 1
        for c in range(lo, hi + 1):
            wa = ka + ba * c
            wb = kb + bb * c
            wc = kc + b_c * c
            e = abs(np.float64(h[r, c]) - (wa * ha + wb * hb + wc * hc) * inv)
            best = max(best, e)
        if best > tol:  # checked per row: the inner loop stays branch-free
            return best
    return best


@njit(cache=CACHE, fastmath=FASTMATH)
def _tri_max_error(h, ar, ac, br, bc, cr, cc):
    """Maximum |h − plane| over the grid samples covered by triangle (a, b, c), edges included."""
    return _tri_error_upto(h, ar, ac, br, bc, cr, cc, np.inf)


@njit(cache=CACHE, fastmath=FASTMATH)
def _sample_errors(h, tri, cols, out):
    """``out[r, c]`` = max vertical error of sample (r, c) over the triangles covering it;
    samples covered by no triangle keep −1."""
    for t in range(tri.shape[0]):
        a, b, cidx = tri[t, 0], tri[t, 1], tri[t, 2]
        ar, ac = a // cols, a % cols
        br, bc = b // cols, b % cols
        cr, cc = cidx // cols, cidx % cols
        det = (bc - ac) * (cr - ar) - (br - ar) * (cc - ac)
        if det == 0:
            continue
        ha = np.float64(h[ar, ac])
        hb = np.float64(h[br, bc])
        hc = np.float64(h[cr, cc])
        inv = 1.0 / det
        rmin, rmax = min(ar, br, cr), max(ar, br, cr)
        cmin, cmax = min(ac, bc, cc), max(ac, bc, cc)
        for r in range(rmin, rmax + 1):
            for c in range(cmin, cmax + 1):
                wa = (bc - c) * (cr - r) - (br - r) * (cc - c)
                wb = (cc - c) * (ar - r) - (cr - r) * (ac - c)
                wc = (ac - c) * (br - r) - (ar - r) * (bc - c)
                if det > 0:
                    if wa < 0 or wb < 0 or wc < 0:
                        continue
                elif wa > 0 or wb > 0 or wc > 0:
                    continue
                e = abs(np.float64(h[r, c]) - (wa * ha + wb * hb + wc * hc) * inv)
                if e > out[r, c]:
                    out[r, c] = e


def sample_errors(heightmap, triangles) -> np.ndarray:
    """Vertical error of EVERY grid sample against the triangle(s) covering it.

    Returns float64 ``(rows, cols)``: ``|h(sample) − interpolated height|`` in world units
    (the maximum over covering triangles for samples on shared edges).

    Raises
    ------
    InvalidParameterError
        If some sample is covered by no triangle (the mesh has a hole or is partial).
    """
    h, _ = _heights_of(heightmap)
    rows, cols = h.shape
    tri = as_triangles(triangles, (rows, cols))
    out = np.full((rows, cols), -1.0)
    _sample_errors(h, tri, np.int64(cols), out)
    holes = int(np.count_nonzero(out < 0))
    if holes:
        raise InvalidParameterError(
            f"the triangles leave {holes} of {rows * cols} grid samples uncovered; "
            "expected a mesh covering the whole heightmap"
        )
    return out


def max_vertical_error(heightmap, triangles) -> float:
    """Maximum vertical error (world units) of the mesh over EVERY grid sample.

    Each sample is compared with the linear interpolation of the triangle covering it
    (numba rasterisation of every triangle over the samples in its bounding box, exact
    integer inside test). This is the true L∞ approximation error the static meshers
    promise, not an estimate from a few points.
    """
    return float(sample_errors(heightmap, triangles).max())


@njit(cache=CACHE, fastmath=FASTMATH)
def _screen_errors(err, dx, dz, h, ex, ey, ez, k, near, out):
    rows, cols = err.shape
    for r in range(rows):
        for c in range(cols):
            vx = c * dx - ex
            vy = np.float64(h[r, c]) - ey
            vz = r * dz - ez
            d = math.sqrt(vx * vx + vy * vy + vz * vz)
            if d < near:
                d = near
            out[r, c] = err[r, c] * k / d


def screen_errors(heightmap, triangles, camera, viewport) -> np.ndarray:
    """Per-sample screen-space error in pixels, float64 ``(rows, cols)``; see
    :func:`max_screen_error` for the metric."""
    if not isinstance(camera, Camera):
        raise InvalidParameterError(f"camera must be a terrascape Camera, got {type(camera)}")
    _, height = _viewport(viewport)
    h, (dx, dz) = _heights_of(heightmap)
    err = sample_errors(heightmap, triangles)
    k = camera.pixels_per_radian(height)
    ex, ey, ez = (float(v) for v in camera.position)
    out = np.empty_like(err)
    _screen_errors(err, dx, dz, h, ex, ey, ez, k, float(camera.near), out)
    return out


def frustum_mask(heightmap, camera) -> np.ndarray:
    """``bool (rows, cols)``: which grid samples lie inside the camera's view frustum.

    View-dependent LOD (ROAM's frustum flags, Duchaineau et al. 1997) only promises its
    screen-space tolerance where the terrain can be seen; use this mask to measure there.
    """
    if not isinstance(camera, Camera):
        raise InvalidParameterError(f"camera must be a terrascape Camera, got {type(camera)}")
    h, (dx, dz) = _heights_of(heightmap)
    rows, cols = h.shape
    z, x = np.mgrid[0:rows, 0:cols].astype(np.float64)
    pts = np.stack([x * dx, h.astype(np.float64), z * dz], axis=-1)
    planes = camera.frustum_planes()
    return np.all(pts @ planes[:, :3].T + planes[:, 3] >= 0, axis=-1)


def max_screen_error(heightmap, triangles, camera, viewport) -> float:
    """Maximum screen-space error of the mesh in pixels, over every grid sample.

    Metric: a sample with vertical error δ (see :func:`max_vertical_error`) at Euclidean
    distance d from the eye (clamped below at the near-plane distance) has the pixel error

        ε = δ · K / d,   K = v_res / (2·tan(fov_y / 2))   (camera.pixels_per_radian)

    — the size on screen of a segment of length δ seen at distance d at the view centre. It
    is the quantity geomipmapping's precomputed distance ``D_n = |δ|·C``, ``C = A/T``,
    ``A = n/|t|``, ``T = 2τ/v_res`` bounds: since
    ``A/T = v_res/(2τ·tan(fov/2)) = K/τ``, ``d ≥ D_n  ⇔  δ·K/d ≤ τ``. The view direction is
    ignored (every sample counts, visible or not), which makes the bound conservative and
    independent of frustum culling.

    Parameters
    ----------
    heightmap
        :class:`~terrascape.Heightmap` (spacing gives world positions ``x = col·dx``,
        ``z = row·dz``, ``y = h``).
    triangles
        ``(M, 3)`` grid vertex indices covering the whole grid.
    camera
        :class:`~terrascape.camera.Camera`.
    viewport
        ``(width, height)`` in pixels; only the height (``v_res``) enters the metric.
    """
    return float(screen_errors(heightmap, triangles, camera, viewport).max())


def _viewport(viewport) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in viewport)
        ok = all(float(v) == int(v) for v in viewport)
    except (TypeError, ValueError):
        raise InvalidParameterError(
            f"viewport must be (width, height) in pixels, got {viewport!r}"
        ) from None
    if not ok or width <= 0 or height <= 0:
        raise InvalidParameterError(
            f"viewport must be two positive integers (width, height), got {viewport!r}"
        )
    return width, height
