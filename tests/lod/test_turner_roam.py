"""Turner's ROAM (Filipović 2008 §5.1–5.2): patches, variance trees, split-only rebuild every
frame, crack-free forced splits across patches, triangle target by feedback, AABB culling."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from terrascape import Heightmap, HeightmapSizeError, InvalidParameterError
from terrascape.camera import Camera
from terrascape.lod.mesh_checks import conformity_report
from terrascape.lod.turner_roam import TurnerRoam, turner_variance

VIEWPORT = (320, 180)


def _terrain(rng, n: int, relief: float = 30.0) -> Heightmap:
    base = ndimage.gaussian_filter(rng.normal(size=(n, n)), rng.uniform(1.0, 4.0))
    base = base / (np.abs(base).max() + 1e-12) * relief
    return Heightmap((base + rng.normal(size=(n, n)) * relief * 0.02).astype(np.float32))


def _random_camera(rng, hm: Heightmap) -> Camera:
    w, d = hm.extent
    pos = (rng.uniform(-0.2, 1.2) * w, hm.max + rng.uniform(2.0, 40.0), rng.uniform(-0.2, 1.2) * d)
    target = (rng.uniform(0.2, 0.8) * w, hm.min, rng.uniform(0.2, 0.8) * d)
    return Camera.look_at(pos, target, near=0.5, far=1000.0)


def _patch_of(tri: np.ndarray, n: int, psize: int) -> np.ndarray:
    """Patch (row, col) of each triangle from its centroid."""
    t = tri.astype(np.int64)
    r = (t // n).mean(axis=1)
    c = (t % n).mean(axis=1)
    p = psize - 1
    return (r // p).astype(int), (c // p).astype(int)


@pytest.mark.parametrize(("n", "psize"), [(33, 9), (65, 17), (129, 33), (129, 129)])
def test_meshes_conform_and_tile(rng, n, psize):
    hm = _terrain(rng, n)
    target = int(rng.integers(300, 3000))
    tr = TurnerRoam(hm, patch_size=psize, target_triangles=target)
    for _ in range(4):
        stats = tr.update(_random_camera(rng, hm), VIEWPORT)
        tri = tr.triangles()
        rep = conformity_report(tri, hm.shape)  # no cracks across patch borders either
        assert rep.ok, str(rep)
        assert rep.area_actual == (n - 1) ** 2
        assert stats.triangles == len(tri) == tr.triangle_count
        visible = tr.triangles(visible_only=True)
        pr, pc = _patch_of(visible, n, psize)
        assert tr.visible_patches()[pr, pc].all()
        assert len(visible) <= len(tri)


@pytest.mark.parametrize("target", [800, 3000, 9000])
def test_triangle_target_held_within_5_percent(rng, target):
    hm = _terrain(rng, 129)
    tr = TurnerRoam(hm, patch_size=33, target_triangles=target)
    cam = Camera.look_at((-10.0, hm.max + 15.0, 140.0), (64.0, hm.min, 64.0), near=0.5)
    for _ in range(6):  # converge on a static view
        tr.update(cam, VIEWPORT)
    for _ in range(4):
        stats = tr.update(cam, VIEWPORT)
        assert abs(stats.triangles / target - 1) <= 0.05
        assert stats.passes == 1  # converged: no correction pass needed
    # a smooth flight keeps the count within ±5 % after convergence
    devs = []
    for _ in range(30):
        cam = cam.moved((0.7, 0.0, -0.7)).turned(0.4, 0.0)
        devs.append(tr.update(cam, VIEWPORT).triangles / target - 1)
    assert np.abs(devs).max() <= 0.05


def test_pure_turner_feedback_converges(rng):
    """Without in-frame correction passes (Turner's frame-to-frame feedback only)."""
    hm = _terrain(rng, 65)
    tr = TurnerRoam(hm, patch_size=17, target_triangles=2000, correction_passes=0)
    cam = Camera.look_at((0.0, hm.max + 10.0, 70.0), (32.0, hm.min, 32.0), near=0.5)
    counts = [tr.update(cam, VIEWPORT).triangles for _ in range(12)]
    assert abs(counts[-1] / 2000 - 1) <= 0.05
    assert abs(counts[0] / 2000 - 1) > 0.05  # it really had to converge
    # more target -> lower threshold
    tr2 = TurnerRoam(hm, patch_size=17, target_triangles=6000, correction_passes=0)
    for _ in range(12):
        tr2.update(cam, VIEWPORT)
    assert tr2.threshold_px < tr.threshold_px


def test_rebuilt_every_frame_without_coherence(rng):
    hm = _terrain(rng, 65)
    cam_a = Camera.look_at((0.0, hm.max + 5.0, 0.0), (32.0, hm.min, 32.0), near=0.5)
    cam_b = Camera.look_at((64.0, hm.max + 5.0, 64.0), (32.0, hm.min, 32.0), near=0.5)
    tr = TurnerRoam(hm, patch_size=17, target_triangles=1500, correction_passes=0)
    tr.update(cam_a, VIEWPORT)
    thr = tr.threshold_px
    tr.update(cam_b, VIEWPORT)
    fresh = TurnerRoam(
        hm, patch_size=17, target_triangles=1500, threshold_px=thr, correction_passes=0
    )
    fresh.update(cam_b, VIEWPORT)
    # the same threshold and view give the same mesh whatever came before (split-only)
    key = np.sort(tr.triangles(), axis=None)
    assert np.array_equal(key, np.sort(fresh.triangles(), axis=None))


def test_culled_patches_are_not_tessellated(rng):
    hm = _terrain(rng, 65)
    tr = TurnerRoam(hm, patch_size=17, target_triangles=3000)
    # looking at the north-west corner from outside it: most patches are culled
    cam = Camera.look_at((-20.0, hm.max + 10.0, -20.0), (5.0, hm.min, 5.0), fov_y=30.0, near=0.5)
    for _ in range(5):
        stats = tr.update(cam, VIEWPORT)
    vis = tr.visible_patches()
    assert np.array_equal(vis, tr.quadtree.visible(cam.frustum_planes()))
    assert 0 < stats.visible_patches < vis.size
    tri = tr.triangles()
    pr, pc = _patch_of(tri, 65, 17)
    per_patch = np.zeros(vis.shape, int)
    np.add.at(per_patch, (pr, pc), 1)
    assert per_patch[vis].sum() > 0.5 * len(tri)
    # culled patches are only refined by forced splits reaching in from visible ones: with the
    # same threshold and culling switched off, every culled patch gets at least as many
    # triangles, and in total clearly more
    thr = stats.threshold_px
    tr_all = TurnerRoam(hm, patch_size=17, threshold_px=thr, correction_passes=0)
    tr_all.quadtree.visible = lambda planes, out: out.fill(True)
    tr_culled = TurnerRoam(hm, patch_size=17, threshold_px=thr, correction_passes=0)
    tr_all.update(cam, VIEWPORT)
    tr_culled.update(cam, VIEWPORT)
    counts = []
    for t in (tr_culled, tr_all):
        pr, pc = _patch_of(t.triangles(), 65, 17)
        c = np.zeros(vis.shape, int)
        np.add.at(c, (pr, pc), 1)
        counts.append(c)
    assert (counts[0][~vis] <= counts[1][~vis]).all()
    assert counts[0][~vis].sum() < 0.5 * counts[1][~vis].sum()
    np.testing.assert_array_equal(counts[0], per_patch)
    # looking away from the terrain: nothing visible, base mesh only
    away = Camera.look_at((80.0, hm.max + 5.0, 32.0), (200.0, hm.max + 5.0, 32.0), near=0.5)
    s = tr.update(away, VIEWPORT)
    assert s.visible_patches == 0 and s.triangles == 2 * 16


def test_variance_tree_matches_definition(rng):
    hm = _terrain(rng, 17)
    var = turner_variance(hm, 9)  # 2×2 patches of 8 cells, full depth 6 levels
    assert var.shape == (4, 2 ** 7)
    h = hm.heights.astype(np.float64)
    from terrascape.lod.bintree import _tri_coords

    for p in range(4):
        pr, pc = divmod(p, 2)
        ref = np.zeros(2**7)
        for t in range(2**7 - 1, 1, -1):
            _, _, r0, c0, r1, c1 = _tri_coords(t, 8)
            r0, r1, c0, c1 = r0 + 8 * pr, r1 + 8 * pr, c0 + 8 * pc, c1 + 8 * pc
            d = abs(h[(r0 + r1) // 2, (c0 + c1) // 2] - 0.5 * (h[r0, c0] + h[r1, c1]))
            ref[t] = max(d, ref[2 * t], ref[2 * t + 1]) if 2 * t < 2**7 else d
        np.testing.assert_allclose(var[p, 2:], ref[2:], rtol=1e-6)
        assert (var[p, 2:64] >= np.maximum(var[p, 4:128:2], var[p, 5:128:2])).all()
    shallow = turner_variance(hm, 9, variance_depth=3)
    np.testing.assert_array_equal(shallow, var[:, :16])


def test_shallow_variance_tree_splits_deeper_levels(rng):
    hm = _terrain(rng, 65)
    cam = Camera.look_at((0.0, hm.max + 10.0, 70.0), (32.0, hm.min, 32.0), near=0.5)
    full = TurnerRoam(hm, patch_size=17, threshold_px=2.0, correction_passes=0)
    shallow = TurnerRoam(hm, patch_size=17, threshold_px=2.0, variance_depth=4, correction_passes=0)
    a = full.update(cam, VIEWPORT).triangles
    b = shallow.update(cam, VIEWPORT).triangles
    assert b > a  # beyond the stored depth Turner always splits
    assert conformity_report(shallow.triangles(), hm.shape).ok


def test_bad_input(rng):
    with pytest.raises(HeightmapSizeError, match="pad"):
        TurnerRoam(Heightmap(np.zeros((60, 60), np.float32)))
    hm = _terrain(rng, 65)
    for kwargs in (
        {"patch_size": 16},
        {"patch_size": 129},
    ):
        with pytest.raises(HeightmapSizeError):
            TurnerRoam(hm, **kwargs)
    for kwargs in (
        {"patch_size": 2},
        {"patch_size": 17.0},
        {"target_triangles": 0},
        {"target_triangles": 1.5},
        {"variance_depth": 0},
        {"variance_depth": 13},
        {"threshold_px": 0.0},
        {"threshold_px": float("nan")},
        {"pool_factor": 1.0},
        {"correction_passes": -1},
    ):
        with pytest.raises(InvalidParameterError):
            TurnerRoam(hm, **({"patch_size": 17} | kwargs))
    tr = TurnerRoam(hm, patch_size=17, target_triangles=500)
    with pytest.raises(InvalidParameterError):
        tr.update(object(), VIEWPORT)
    with pytest.raises(InvalidParameterError):
        tr.update(_random_camera(rng, hm), (-1, 10))
    with pytest.raises(InvalidParameterError):
        Camera.look_at((float("nan"), 1.0, 1.0), (0.0, 0.0, 0.0))
