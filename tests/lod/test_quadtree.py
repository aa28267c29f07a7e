"""Quadtree AABB frustum culling (terrascape.lod.quadtree) against brute force."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape import Heightmap
from terrascape.camera import Camera
from terrascape.errors import HeightmapSizeError, InvalidParameterError
from terrascape.lod import PatchQuadtree, patch_grid


@pytest.fixture(scope="module")
def tree():
    rng = np.random.default_rng(7)
    h = (rng.random((257, 257)) * 300).astype(np.float32)
    return PatchQuadtree(Heightmap(h, spacing=(4.0, 4.0)), 17)


def _random_camera(rng, extent=1024.0):
    return Camera(
        position=rng.uniform([-200, -50, -200], [extent + 200, 800, extent + 200]),
        yaw=rng.uniform(0, 360), pitch=rng.uniform(-80, 60), fov_y=rng.uniform(20, 100),
        aspect=rng.uniform(0.5, 2.5), near=rng.uniform(0.1, 5), far=rng.uniform(50, 3000),
    )


def test_structure(tree):
    assert tree.patch_shape == (16, 16)
    assert tree.node_count == 1 + 4 + 16 + 64 + 256
    box = tree.patch_aabbs[3, 5]
    h = tree.heightmap.heights[48:65, 80:97]
    np.testing.assert_allclose(box, [320, 384, h.min(), h.max(), 192, 256])


def test_zero_wrongly_culled_on_1000_random_frusta(tree):
    rng = np.random.default_rng(2024)
    wrongly_culled = extra = total_visible = 0
    out = np.zeros(tree.patch_shape, bool)
    for _ in range(1000):
        planes = _random_camera(rng).frustum_planes()
        vis = tree.visible(planes, out=out)
        brute = tree.visible_brute_force(planes)
        wrongly_culled += int(np.count_nonzero(brute & ~vis))
        extra += int(np.count_nonzero(vis & ~brute))
        total_visible += int(brute.sum())
    assert wrongly_culled == 0
    assert extra == 0  # same test at the leaves, so the tree agrees exactly
    assert 0 < total_visible < 1000 * 256  # the frusta really cull something, and not all


def test_no_sample_inside_the_frustum_is_culled(tree):
    """Physical check independent of the AABB maths: every grid sample strictly inside the
    frustum lies in a visible patch."""
    rng = np.random.default_rng(5)
    hm = tree.heightmap
    rr, cc = np.mgrid[0:257, 0:257]
    pts = np.stack([cc * 4.0, hm.heights.astype(float), rr * 4.0, np.ones(rr.shape)], -1)
    for _ in range(50):
        planes = _random_camera(rng).frustum_planes()
        inside = (pts @ planes.T >= 1e-9).all(-1)
        vis = tree.visible(planes)
        pr = np.minimum(rr // 16, 15)
        pc = np.minimum(cc // 16, 15)
        # a sample on a patch border belongs to both patches: accept either
        pr2 = np.maximum((rr - 1) // 16, 0)
        pc2 = np.maximum((cc - 1) // 16, 0)
        covered = vis[pr, pc] | vis[pr2, pc] | vis[pr, pc2] | vis[pr2, pc2]
        assert not (inside & ~covered).any()


def test_looking_away_culls_everything_and_overview_sees_everything(tree):
    away = Camera(position=(512, 100, -50), yaw=0, pitch=0, far=1000)  # looks north, away
    assert not tree.visible(away.frustum_planes()).any()
    above = Camera.look_at((512, 3000, 512.01), (512, 0, 512), fov_y=60, far=10000)
    assert tree.visible(above.frustum_planes()).all()


def test_non_square_map():
    h = np.zeros((33, 65), np.float32)
    t = PatchQuadtree(Heightmap(h), 17)
    assert t.patch_shape == (2, 4)
    assert patch_grid((33, 65), 9) == (4, 8)


def test_bad_inputs(tree):
    with pytest.raises(HeightmapSizeError, match="multiples of 16"):
        PatchQuadtree(Heightmap(np.zeros((40, 40), np.float32)), 17)
    with pytest.raises(InvalidParameterError, match="planes"):
        tree.visible(np.zeros((6, 3)))
    with pytest.raises(InvalidParameterError, match="finite"):
        tree.visible(np.full((6, 4), np.nan))
    with pytest.raises(InvalidParameterError, match="Heightmap"):
        PatchQuadtree(np.zeros((17, 17)), 17)
