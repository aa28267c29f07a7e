"""Impostors seen from above: the atlas holds views from the side to straight above, so a
far forest seen from 60° is drawn as impostors (not meshes), covering the same pixels in
about the same colours as the meshes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from terrascape.camera import Camera
from terrascape.heightmap import Heightmap
from terrascape.objects import Instances, builtin_meshes
from terrascape.render.objects import IMPOSTOR_ELEVATIONS, _bake_matrix, impostor_up_range
from terrascape.render.offscreen import OffscreenRenderer

SUN = (135.0, 40.0)


def scene(elevation: float, size=(256, 192)):
    meshes = builtin_meshes()
    kinds = ("conifer", "broadleaf", "house", "rock")
    rng = np.random.default_rng(5)
    n = 80
    hm = Heightmap(np.zeros((129, 129), np.float32), spacing=(1.0, 1.0))
    pos = np.c_[rng.uniform(10, 118, n), np.zeros(n), rng.uniform(10, 118, n)]
    inst = Instances(tuple(meshes[k] for k in kinds), rng.integers(0, 4, n), pos,
                     rng.uniform(0.8, 1.2, n), rng.uniform(0, 2 * np.pi, n))
    target = np.array([64.0, 0.0, 64.0])
    el = math.radians(elevation)
    eye = target + 260.0 * np.array([0.0, math.sin(el), math.cos(el)])
    cam = Camera.look_at(tuple(eye), tuple(target), fov_y=35.0, near=10.0, far=800.0,
                         aspect=size[0] / size[1])
    return hm, inst, cam, size


def test_bake_views_cover_the_hemisphere_and_hold_the_mesh():
    """Every atlas view puts the mesh's bounding cylinder inside its cell, its depth inside
    [-1, 1], and the straight-down view looks along -Y."""
    assert IMPOSTOR_ELEVATIONS[0] == 0.0 and IMPOSTOR_ELEVATIONS[-1] == 90.0
    radius, y0, y1, mid = 3.0, -0.6, 15.0, 7.2
    up = impostor_up_range(radius, y0, y1)
    sphere = math.sqrt(radius ** 2 + (y1 - mid) ** 2) + 0.5
    ang = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    ring = [np.c_[radius * np.sin(ang), np.full(16, y), radius * np.cos(ang)] for y in (y0, y1)]
    pts = np.c_[np.concatenate(ring), np.ones(32)]
    for el in IMPOSTOR_ELEVATIONS:
        for k in range(8):
            ndc = pts @ _bake_matrix(k, 8, el, radius, up, mid, sphere).T
            assert (np.abs(ndc[:, :3]) <= 1.0 + 1e-9).all(), (el, k)
    top = _bake_matrix(0, 8, 90.0, radius, up, mid, sphere)
    np.testing.assert_allclose(top[2, :3], [0.0, -1.0 / sphere, 0.0], atol=1e-12)


@pytest.mark.gl
def test_a_far_forest_seen_from_60_degrees_is_drawn_as_impostors_like_its_meshes(gl_ctx):
    hm, inst, cam, size = scene(60.0)
    r = OffscreenRenderer(gl_ctx, hm, size=size)
    params = {"sun": SUN, "object_shadows": "none"}
    try:
        empty = r.render(cam, "plain", params)
        r.terrain.set_objects(inst)
        r.render(cam, "plain", params)  # the automatic level of detail
        auto = dict(r.terrain.last_stats)
        meshes = r.render(cam, "plain", {**params, "impostor_pixels": 0})
        impostors = r.render(cam, "plain", {**params, "impostor_pixels": 1e6})
        assert r.terrain.last_stats["objects_impostors"] == len(inst)
    finally:
        r.release()
    # far and small on screen: most objects are impostors now (all meshes when the atlas
    # held side views only and views from above 40° kept the meshes)
    assert auto["objects_impostors"] >= 0.9 * len(inst), auto
    assert auto["objects_meshes"] + auto["objects_impostors"] == len(inst)
    assert auto["objects_triangles"] < 0.1 * sum(m.triangles for m in
                                                 (inst.meshes[k] for k in inst.kind))

    def covered(img):
        return np.abs(img[..., :3].astype(int) - empty[..., :3].astype(int)).max(axis=-1) > 6

    cover_m, cover_i = covered(meshes), covered(impostors)
    assert cover_m.sum() > 3000
    # the same footprint (within 5 %), mostly the same pixels, about the same colour
    assert abs(int(cover_i.sum()) - int(cover_m.sum())) < 0.05 * cover_m.sum()
    both = cover_m & cover_i
    assert both.sum() > 0.88 * cover_m.sum()
    mean_m = meshes[both][:, :3].astype(float).mean(axis=0)
    mean_i = impostors[both][:, :3].astype(float).mean(axis=0)
    assert np.abs(mean_m - mean_i).max() < 10.0, (mean_m, mean_i)


@pytest.mark.gl
@pytest.mark.parametrize("kind", ["house", "hall"])
def test_buildings_seen_from_above_keep_their_outline_as_impostors(gl_ctx, kind):
    """A house or hall turned between two atlas views, seen from 90° and 75°: its impostor
    covers the mesh's pixels (each view sampled where it saw the point the viewing ray
    meets, so two views a turn apart do not show it twice — a roof as a round blur), and
    from straight above in the mesh's colours."""
    hm = Heightmap(np.zeros((65, 65), np.float32), spacing=(1.0, 1.0))
    size = (192, 192)
    params = {"sun": SUN, "object_shadows": "none", "fog_density": 0.0}
    r = OffscreenRenderer(gl_ctx, hm, size=size)
    try:
        for yaw in (0.3, 1.0):  # 17° and 57°: between the atlas views 45° apart
            inst = Instances((builtin_meshes()[kind],), [0], [[32.0, 0.0, 32.0]], [1.0], [yaw])
            for elevation, min_iou, max_err in ((90.0, 0.94, 3.0), (75.0, 0.89, 20.0)):
                e = math.radians(elevation)
                target = np.array([32.0, 3.0, 32.0])
                eye = target + 120.0 * np.array([0.0, math.sin(e), math.cos(e) + 1e-4])
                cam = Camera.look_at(tuple(eye), tuple(target), fov_y=15.0, near=10.0,
                                     far=800.0, aspect=1.0)
                r.terrain.set_objects(None)
                empty = r.render(cam, "plain", params).astype(int)
                r.terrain.set_objects(inst)
                mesh = r.render(cam, "plain", {**params, "impostor_pixels": 0}).astype(int)
                imp = r.render(cam, "plain", {**params, "impostor_pixels": 1e6}).astype(int)
                assert r.terrain.last_stats["objects_impostors"] == 1
                cover_m = np.abs(mesh[..., :3] - empty[..., :3]).max(axis=-1) > 6
                cover_i = np.abs(imp[..., :3] - empty[..., :3]).max(axis=-1) > 6
                assert cover_m.sum() > 2000
                iou = (cover_m & cover_i).sum() / (cover_m | cover_i).sum()
                both = cover_m & cover_i
                err = np.abs(mesh[both][:, :3] - imp[both][:, :3]).mean()
                assert iou >= min_iou, (yaw, elevation, iou)
                assert err <= max_err, (yaw, elevation, err)
    finally:
        r.release()
