"""Geomipmapping (Filipović 2008 §4.2): crack-free mixed levels, screen error ≤ τ, level rules."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import ndimage

from terrascape import Heightmap
from terrascape.camera import Camera
from terrascape.errors import HeightmapSizeError, InvalidParameterError
from terrascape.lod import (
    Geomipmap,
    conformity_report,
    max_screen_error,
    max_vertical_error,
    patch_templates,
)

VIEWPORT = (800, 600)


@pytest.fixture(scope="module")
def terrain():
    rng = np.random.default_rng(11)
    h = ndimage.gaussian_filter(rng.standard_normal((129, 129)), 3) * 600
    return Heightmap(h.astype(np.float32), spacing=(10.0, 10.0))


@pytest.fixture(scope="module")
def gm(terrain):
    return Geomipmap(terrain, 9)


def _cameras(terrain, n, seed):
    rng = np.random.default_rng(seed)
    w, d = terrain.extent
    for _ in range(n):
        pos = rng.uniform([-0.3 * w, terrain.max + 5, -0.3 * d],
                          [1.3 * w, terrain.max + 0.8 * w, 1.3 * d])
        yield Camera(position=tuple(pos), yaw=rng.uniform(0, 360), pitch=rng.uniform(-60, 0),
                     fov_y=rng.uniform(30, 90), near=0.5, far=1e5), rng.uniform(0.5, 8.0)


@pytest.mark.parametrize("size", [5, 9, 17])
def test_every_template_is_a_conforming_patch(size):
    for (level, mask), t in patch_templates(size).items():
        idx = t[:, [0, 2, 4]] * size + t[:, [1, 3, 5]]
        rep = conformity_report(idx, (size, size))
        assert rep.ok, (level, mask, str(rep))
        # the skipped side has exactly the coarser level's vertices
        step = 1 << level
        verts = set(idx.reshape(-1).tolist())
        if step < size - 1:
            north = {v for v in verts if v < size}
            expect = set(range(0, size, 2 * step if mask & 1 else step))
            assert north == expect


def test_random_views_conforming_within_tolerance(terrain, gm):
    mixed = 0
    for cam, tol in _cameras(terrain, 12, seed=3):
        gm.update(cam, VIEWPORT, tolerance_px=tol)
        tri = gm.triangles()
        assert tri.dtype == np.uint32 and len(tri) == gm.triangle_count()
        rep = conformity_report(tri, terrain.shape)
        assert rep.ok, str(rep)
        err = max_screen_error(terrain, tri, cam, VIEWPORT)
        assert err <= tol * (1 + 1e-9)
        lev = gm.levels
        assert np.abs(np.diff(lev, axis=0)).max(initial=0) <= 1
        assert np.abs(np.diff(lev, axis=1)).max(initial=0) <= 1
        mixed += len(np.unique(lev)) > 1
    assert mixed >= 6  # most views really mix levels


def test_masks_mark_coarser_neighbours(terrain, gm):
    cam = Camera(position=(0.0, terrain.max + 3000, 0.0), yaw=135, pitch=-30, near=0.5)
    gm.update(cam, VIEWPORT, tolerance_px=8.0)
    lev, mask = gm.levels, gm.masks
    assert len(np.unique(lev)) >= 3
    i, j = np.nonzero(mask & 4)
    assert (lev[i + 1, j] == lev[i, j] + 1).all()
    i, j = np.nonzero(~mask & 2)
    inner = j < lev.shape[1] - 1
    assert (lev[i[inner], j[inner] + 1] <= lev[i[inner], j[inner]]).all()


def test_distant_camera_gets_coarser_levels_and_fewer_triangles(terrain, gm):
    counts, means = [], []
    for dist in (200.0, 2000.0, 20000.0, 200000.0):
        cam = Camera(position=(640.0, terrain.max + dist, 640.0), pitch=-89, near=0.5, far=1e7)
        gm.update(cam, VIEWPORT, tolerance_px=2.0)
        counts.append(gm.triangle_count())
        means.append(gm.levels.mean())
    assert counts == sorted(counts, reverse=True) and counts[0] > counts[-1]
    assert means == sorted(means)
    assert counts[-1] == 2 * 16 * 16  # everything at the coarsest level: 2 per patch


def test_flat_terrain_is_two_triangles_per_patch():
    gm = Geomipmap(Heightmap(np.full((65, 65), 5.0, np.float32)), 17)
    cam = Camera(position=(32.0, 6.0, 32.0), near=0.1)
    gm.update(cam, VIEWPORT, tolerance_px=0.1)
    assert (gm.levels == 4).all() and gm.triangle_count() == 32
    assert conformity_report(gm.triangles(), (65, 65)).ok


def test_delta_is_the_measured_error_of_the_level(terrain, gm):
    from terrascape.lod.geomipmap import _level_triangles

    i, j = 5, 9
    p = 8
    sub = terrain.heights[i * p:i * p + p + 1, j * p:j * p + p + 1]
    for level in range(gm.n_levels):
        t = np.array(_level_triangles(p, level, 0))
        idx = t[:, [0, 2, 4]] * (p + 1) + t[:, [1, 3, 5]]
        assert gm.delta[i, j, level] == pytest.approx(max_vertical_error(sub, idx), rel=1e-12)
    assert gm.delta[i, j, 0] == 0.0
    assert (gm.delta_stitched >= gm.delta).all()


def test_min_distance_is_formula_3(terrain, gm):
    cam = Camera(position=(0.0, 900.0, 0.0), fov_y=45.0, near=2.0)
    tau, v_res = 3.0, 600
    n = cam.near
    t = n * math.tan(math.radians(45.0) / 2)
    c = (n / abs(t)) / (2 * tau / v_res)
    d = gm.min_distances(cam, (800, v_res), tau)
    mono = np.maximum.accumulate(gm.delta_stitched, axis=-1)
    np.testing.assert_allclose(d, mono * c)
    assert c == pytest.approx(cam.pixels_per_radian(v_res) / tau)


def test_culling_keeps_only_visible_patches(terrain, gm):
    cam = Camera(position=(-100.0, terrain.max + 50, 640.0), yaw=90, pitch=-10, fov_y=40,
                 near=0.5, far=800.0)
    gm.update(cam, VIEWPORT, 2.0)
    full = gm.triangle_count()
    gm.update(cam, VIEWPORT, 2.0, cull=True)
    vis = gm.visible
    assert 0 < vis.sum() < vis.size
    np.testing.assert_array_equal(vis, gm.quadtree.visible_brute_force(cam.frustum_planes()))
    assert gm.triangle_count() < full
    first, count, _ = gm.draw_ranges()
    assert len(first) == vis.sum() and count.sum() == len(gm.triangles())


def test_draw_ranges_rebuild_the_mesh(terrain, gm):
    cam = next(_cameras(terrain, 1, seed=8))[0]
    gm.update(cam, VIEWPORT, 2.0)
    first, count, base = gm.draw_ranges()
    parts = [gm.index_buffer[f:f + c].astype(np.int64) + b
             for f, c, b in zip(first, count, base, strict=True)]
    np.testing.assert_array_equal(np.concatenate(parts), gm.triangles())


def test_bad_inputs(terrain, gm):
    with pytest.raises(HeightmapSizeError, match=r"2\*\*k \+ 1"):
        Geomipmap(terrain, 12)
    with pytest.raises(HeightmapSizeError, match="tile"):
        Geomipmap(Heightmap(np.zeros((100, 100), np.float32)), 17)
    with pytest.raises(HeightmapSizeError, match="tile"):
        Geomipmap(terrain, 257)
    with pytest.raises(InvalidParameterError):
        Geomipmap(terrain, 1)
    fresh = Geomipmap(Heightmap(np.zeros((17, 17), np.float32)), 9)
    with pytest.raises(InvalidParameterError, match="update"):
        fresh.triangles()
    cam = Camera(position=(0.0, 10.0, 0.0))
    for tol in (0.0, -1.0, float("nan")):
        with pytest.raises(InvalidParameterError, match="tolerance"):
            gm.update(cam, VIEWPORT, tolerance_px=tol)
    with pytest.raises(InvalidParameterError, match="finite"):
        Camera(position=(float("nan"), 0.0, 0.0))
    with pytest.raises(InvalidParameterError, match="Camera"):
        gm.update((0, 0, 0), VIEWPORT)
    with pytest.raises(InvalidParameterError, match="viewport"):
        gm.update(cam, (800, -1))
