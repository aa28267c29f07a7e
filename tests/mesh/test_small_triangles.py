"""Small-triangle culling: kept triangles against a brute-force per-triangle reference."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape.camera import Camera
from terrascape.errors import InvalidParameterError
from terrascape.mesh import banded_grid_triangles
from terrascape.mesh.small_triangles import (
    DEFAULT_MARGIN_PX,
    MAX_CENTRE_TESTS,
    cull_small_triangles,
)


def _tile(rng, rows=33, cols=41, spacing=1.0):
    z, x = np.meshgrid(np.arange(rows) * spacing, np.arange(cols) * spacing, indexing="ij")
    y = rng.random((rows, cols)) * 3.0
    return np.stack([x, y, z], -1).astype(np.float32)


def _screen(tile, cam, size):
    p = np.c_[tile.reshape(-1, 3).astype(np.float64), np.ones(tile.shape[0] * tile.shape[1])]
    clip = p @ cam.view_projection().T
    w = clip[:, 3]
    scr = (clip[:, :2] / w[:, None] * 0.5 + 0.5) * np.asarray(size, dtype=np.float64)
    return scr, w


def _covers(t, size, margin, max_tests):
    """Does the screen triangle t (3, 2) contain a viewport pixel centre, widened by margin
    px (True too when its box holds more than max_tests centres)?"""
    lo = np.maximum(t.min(axis=0), 0.0)
    hi = np.minimum(t.max(axis=0), np.asarray(size, dtype=np.float64))
    k0 = np.ceil(lo - 0.5 - margin)
    k1 = np.floor(hi - 0.5 + margin)
    if (k0 > k1).any():
        return False
    if np.prod(k1 - k0 + 1) > max_tests:
        return True
    a, b, c = t
    area2 = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
    if area2 == 0:
        return True
    for ky in np.arange(k0[1], k1[1] + 1):
        for kx in np.arange(k0[0], k1[0] + 1):
            p = np.array([kx + 0.5, ky + 0.5])
            dist = []
            for u, v in ((a, b), (b, c), (c, a)):
                e = v - u
                dist.append(np.sign(area2) * (e[0] * (p[1] - u[1]) - e[1] * (p[0] - u[0]))
                            / max(np.hypot(*e), 1e-300))
            if min(dist) >= -margin:
                return True
    return False


def _reference(tile, cam, size, margin, max_tests=MAX_CENTRE_TESTS):
    """Per triangle of the band order: may it cover a pixel centre (widened by margin)?"""
    tris = banded_grid_triangles(tile.shape[0], tile.shape[1]).astype(np.int64)
    scr, w = _screen(tile, cam, size)
    holds = np.array([_covers(scr[t], size, margin, max_tests) for t in tris])
    behind = (w[tris] <= 0).any(axis=1)
    return tris, holds, behind


def _kept_mask(tris, kept):
    """Which band-order triangles ``kept`` holds, checking it is an ordered subsequence."""
    got = kept.reshape(-1, 3).astype(np.int64)
    index = {tuple(t): k for k, t in enumerate(tris.tolist())}
    pos = np.array([index[tuple(t)] for t in got.tolist()], dtype=np.int64)
    assert (np.diff(pos) > 0).all()  # band order kept, no duplicates
    mask = np.zeros(len(tris), dtype=bool)
    mask[pos] = True
    return mask


@pytest.mark.parametrize(("size", "distance"), [((64, 36), 120.0), ((320, 180), 60.0),
                                                 ((97, 53), 25.0)])
def test_keeps_exactly_the_triangles_that_can_cover_a_pixel_centre(rng, size, distance):
    tile = _tile(rng)
    cam = Camera.orbit((20, 0, 16), 40.0, 35.0, distance, aspect=size[0] / size[1], fov_y=45)
    kept = cull_small_triangles(tile, cam.view_projection(), size)
    tris, holds_in, _ = _reference(tile, cam, size, -1e-6)
    _, holds_out, _ = _reference(tile, cam, size, DEFAULT_MARGIN_PX + 1e-6)
    mask = _kept_mask(tris, kept)
    assert mask[holds_in].all()  # never drops a triangle that may draw
    assert not mask[~holds_out].any()  # drops every one that cannot
    if distance > 100:
        assert mask.mean() < 0.5  # far away most triangles fall between pixel centres


def test_large_triangles_and_clipped_ones_are_all_kept(rng):
    tile = _tile(rng, 9, 9, spacing=10.0)
    # eye inside the tile's extent, looking along +x: the vertices at x < 40 are behind it
    cam = Camera.look_at((40, 6, 40), (80, 1, 40), aspect=1.0, fov_y=60, near=0.1)
    kept = cull_small_triangles(tile, cam.view_projection(), (256, 256))
    tris, holds, behind = _reference(tile, cam, (256, 256), 0.0)
    mask = _kept_mask(tris, kept)
    assert behind.any() and not behind.all()
    assert mask[behind].all()
    assert mask[holds].all()


def test_a_tile_out_of_view_keeps_nothing(rng):
    tile = _tile(rng)
    # the tile lies in front of the eye but far to the side of a narrow view
    cam = Camera.look_at((-100, 5, 16), (0, 5, 500), aspect=1.0, fov_y=30)
    _, holds, behind = _reference(tile, cam, (64, 64), 0.0)
    assert not behind.any() and not holds.any()
    assert cull_small_triangles(tile, cam.view_projection(), (64, 64)).size == 0


def test_out_scratch_and_dtypes(rng):
    tile = _tile(rng, 5, 6)
    cam = Camera.orbit((3, 0, 2), 10.0, 40.0, 20.0, aspect=1.0)
    vp = cam.view_projection()
    scratch = np.empty(6 * 4 * 5 + 7, dtype=np.uint32)
    a = cull_small_triangles(tile, vp, (32, 32), out=scratch)
    b = cull_small_triangles(tile, vp, (32, 32))
    assert a.base is scratch or a.base is scratch.base
    assert b.dtype == np.uint16
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(b, cull_small_triangles(tile, vp, (32, 32)))  # same bytes


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"positions": np.zeros((4, 4))}, "rows, cols, 3"),
        ({"positions": np.zeros((1, 4, 3))}, "rows, cols >= 2"),
        ({"positions": np.zeros((4, 4, 3), dtype=np.int32)}, "floats"),
        ({"view_projection": np.full((4, 4), np.nan)}, "finite 4×4"),
        ({"viewport": (0, 10)}, "viewport size"),
        ({"viewport": 5}, "width, height"),
        ({"margin": -1.0}, "margin"),
        ({"out": np.empty(3, dtype=np.uint16)}, "at least"),
        ({"out": np.empty(200, dtype=np.float32)}, "uint16/uint32"),
    ],
)
def test_bad_input_is_refused(kwargs, match):
    args = {"positions": np.zeros((4, 4, 3), dtype=np.float32), "view_projection": np.eye(4),
            "viewport": (16, 16)}
    args.update(kwargs)
    positions = args.pop("positions")
    vp = args.pop("view_projection")
    viewport = args.pop("viewport")
    with pytest.raises(InvalidParameterError, match=match):
        cull_small_triangles(positions, vp, viewport, **args)
