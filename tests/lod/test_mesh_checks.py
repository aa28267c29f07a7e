"""Mesh conformity and true-error measurement (terrascape.lod.mesh_checks)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from terrascape import Heightmap
from terrascape.camera import Camera
from terrascape.errors import InvalidParameterError
from terrascape.lod import (
    conformity_report,
    full_resolution_triangles,
    is_conforming,
    max_screen_error,
    max_vertical_error,
    sample_errors,
)


def _brute_errors(h: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Independent reference: float barycentrics per sample, max over covering triangles."""
    rows, cols = h.shape
    rr, cc = np.mgrid[0:rows, 0:cols]
    out = np.full(h.shape, -1.0)
    for t in tri:
        r, c = np.divmod(t.astype(np.int64), cols)
        m = np.array([[c[1] - c[0], c[2] - c[0]], [r[1] - r[0], r[2] - r[0]]], float)
        inv = np.linalg.inv(m)
        uv = np.einsum("ij,jrc->irc", inv, np.stack([cc - c[0], rr - r[0]]).astype(float))
        inside = (uv[0] >= -1e-9) & (uv[1] >= -1e-9) & (uv[0] + uv[1] <= 1 + 1e-9)
        hv = h[r, c].astype(float)
        interp = hv[0] + uv[0] * (hv[1] - hv[0]) + uv[1] * (hv[2] - hv[0])
        e = np.abs(h - interp)
        out = np.where(inside, np.maximum(out, e), out)
    return out


def test_full_resolution_mesh_is_conforming_and_exact(rng):
    h = rng.random((9, 13)).astype(np.float32)
    tri = full_resolution_triangles(h.shape)
    assert tri.dtype == np.uint32 and tri.shape == (2 * 8 * 12, 3)
    rep = conformity_report(tri, h.shape)
    assert rep.ok, str(rep)
    assert rep.area_actual == rep.area_expected == 96
    assert max_vertical_error(h, tri) == 0.0


def test_full_resolution_matches_renderer_grid():
    from terrascape.mesh import grid_triangles

    np.testing.assert_array_equal(full_resolution_triangles((5, 7)), grid_triangles(5, 7))


def test_two_triangles_conforming_and_error_matches_brute_force(rng):
    h = rng.random((9, 9)).astype(np.float32) * 10
    tri = np.array([[0, 72, 8], [8, 72, 80]], np.uint32)
    assert is_conforming(tri, (9, 9))
    ref = _brute_errors(h, tri)
    np.testing.assert_allclose(sample_errors(h, tri), ref, rtol=1e-9, atol=1e-9)
    assert math.isclose(max_vertical_error(h, tri), ref.max(), rel_tol=1e-12)
    assert max_vertical_error(h, tri) > 1.0  # random heights are far from one plane


def test_error_of_random_conforming_mesh_matches_brute_force(rng):
    from terrascape.lod import Rtin

    h = rng.random((17, 17)).astype(np.float32) * 5
    tri = Rtin(Heightmap(h)).mesh(max_error=1.0).triangles
    np.testing.assert_allclose(sample_errors(h, tri), _brute_errors(h, tri), atol=1e-9)


def test_planar_terrain_has_zero_error_for_any_mesh():
    r, c = np.mgrid[0:9, 0:9]
    h = (3.0 * c - 2.0 * r + 1.0).astype(np.float32)
    tri = np.array([[0, 72, 8], [8, 72, 80]], np.uint32)
    assert max_vertical_error(h, tri) == pytest.approx(0.0, abs=1e-5)


def test_t_junction_detected():
    # the right half is split at the diagonal's midpoint 40; the left triangle is not
    tri = np.array([[0, 72, 8], [8, 40, 80], [40, 72, 80]], np.uint32)
    rep = conformity_report(tri, (9, 9))
    assert not rep.ok
    assert rep.t_junctions == 1
    assert rep.open_interior_edges == 3
    assert rep.area_actual == rep.area_expected  # area alone would not catch it


def test_split_on_border_is_fine():
    # vertex 76 lies on the domain border edge 72-80, not inside another triangle's edge
    tri = np.array([[0, 72, 8], [8, 72, 76], [8, 76, 80]], np.uint32)
    assert is_conforming(tri, (9, 9))


def test_wrong_orientation_and_inconsistent_edges_detected():
    tri = full_resolution_triangles((5, 5)).astype(np.int64)
    tri[3] = tri[3, ::-1]
    rep = conformity_report(tri, (5, 5))
    assert rep.wrong_orientation == 1
    assert rep.inconsistent_edges >= 1
    assert not rep.ok


def test_hole_and_overlap_detected():
    tri = full_resolution_triangles((5, 5))
    hole = conformity_report(tri[1:], (5, 5))  # corner triangle: 2 border edges, 1 inner
    assert hole.area_actual == 15.5 and hole.open_interior_edges == 1 and not hole.ok
    overlap = conformity_report(np.vstack([tri, tri[:1]]), (5, 5))
    assert overlap.non_manifold_edges >= 1 and not overlap.ok
    degenerate = conformity_report(np.vstack([tri, [[0, 1, 2]]]), (5, 5))
    assert degenerate.degenerate == 1


def test_uncovered_samples_raise():
    tri = full_resolution_triangles((5, 5))[:-2]  # last cell missing: sample (4, 4) uncovered
    with pytest.raises(InvalidParameterError, match="uncovered"):
        max_vertical_error(np.zeros((5, 5), np.float32), tri)


def test_screen_error_matches_formula(rng):
    h = rng.random((9, 9)).astype(np.float32) * 4
    hm = Heightmap(h, spacing=(2.0, 3.0))
    tri = np.array([[0, 72, 8], [8, 72, 80]], np.uint32)
    cam = Camera(position=(30.0, 20.0, -10.0), fov_y=50.0, near=0.5)
    viewport = (640, 480)
    err = _brute_errors(h, tri)
    rr, cc = np.mgrid[0:9, 0:9]
    d = np.sqrt((cc * 2.0 - 30) ** 2 + (h - 20.0) ** 2 + (rr * 3.0 + 10) ** 2)
    k = 480 / (2 * math.tan(math.radians(25.0)))
    expected = (err * k / np.maximum(d, 0.5)).max()
    assert max_screen_error(hm, tri, cam, viewport) == pytest.approx(expected, rel=1e-6)


def test_bad_inputs():
    tri = full_resolution_triangles((5, 5))
    with pytest.raises(InvalidParameterError, match=r"\(M, 3\)"):
        conformity_report(tri[:, :2], (5, 5))
    with pytest.raises(InvalidParameterError, match="indices"):
        conformity_report(tri + 100, (5, 5))
    with pytest.raises(InvalidParameterError, match="integer"):
        conformity_report(tri.astype(float), (5, 5))
    with pytest.raises(InvalidParameterError, match="viewport"):
        max_screen_error(np.zeros((5, 5), np.float32), tri, Camera(), (0, 10))
    with pytest.raises(InvalidParameterError, match="Camera"):
        max_screen_error(np.zeros((5, 5), np.float32), tri, "camera", (10, 10))


def test_line_edge_share_measures_grid_lines_running_along_edges():
    from terrascape.lod.mesh_checks import line_edge_share

    shape = (9, 9)
    full = full_resolution_triangles(shape)
    # the full grid has an edge between every two neighbouring samples of every row
    assert line_edge_share(full, shape, [4], []) == 1.0
    assert line_edge_share(full, shape, [2, 6], [3]) == 1.0
    # the map's own border lines too (their edges belong to one triangle each)
    assert line_edge_share(full, shape, [0, 8], [0]) == 1.0
    # two triangles over the whole grid: an inner line is only crossed
    two = np.array([[8 * 9 + 8, 0, 8 * 9], [0, 8 * 9 + 8, 8]], np.uint32)
    assert conformity_report(two, shape).ok
    assert line_edge_share(two, shape, [4], [4]) == 0.0
    assert line_edge_share(two, shape, [0], [8]) == 1.0  # the outline is two edges
    # a fan around the centre (4, 4) with a vertex at the left end of row 4: that row runs
    # along an edge for its left half only
    def idx(r, c):
        return r * 9 + c

    fan = []
    for a, b, c in ([(0, 0), (0, 8), (4, 4)], [(0, 0), (4, 4), (4, 0)],
                    [(4, 0), (4, 4), (8, 0)], [(4, 4), (8, 8), (8, 0)],
                    [(0, 8), (8, 8), (4, 4)]):
        t = [idx(*a), idx(*b), idx(*c)]
        # counter-clockwise seen from above, as conformity_report wants
        (r0, c0), (r1, c1), (r2, c2) = a, b, c
        if (c1 - c0) * (r2 - r0) - (r1 - r0) * (c2 - c0) > 0:
            t[1], t[2] = t[2], t[1]
        fan.append(t)
    mixed = np.array(fan, np.uint32)
    assert conformity_report(mixed, shape).ok
    assert line_edge_share(mixed, shape, [4], []) == 0.5
    assert line_edge_share(mixed, shape, [], [4]) == 0.0
    assert line_edge_share(mixed, shape, [], []) == 0.0
