"""Objects on the terrain, checked on pixels: instanced draws equal a pre-transformed draw,
objects appear where they were placed, the sun's cascaded shadows fall where a CPU ray cast
puts a box's shadow on flat ground (and keep the sky's light), impostors switch in without
a jump in colour; and the cascades' geometry (splits, texel snapping)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from terrascape.camera import Camera
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.lighting.sun import sun_direction
from terrascape.objects.model import Instances, ObjectMesh
from terrascape.render.cascades import fit_cascades, practical_splits
from terrascape.render.objects import ObjectShadowFallbackWarning, resolve_object_shadows
from terrascape.render.offscreen import OffscreenRenderer

LUMA = np.array([0.2126, 0.7152, 0.0722])
SUN = (135.0, 40.0)


def flat(n=65, spacing=1.0) -> Heightmap:
    return Heightmap(np.zeros((n, n), np.float32), spacing=(spacing, spacing))


def overhead(hm: Heightmap, height: float, size) -> Camera:
    ex, ez = hm.extent
    return Camera.look_at((ex / 2, height, ez / 2 + 1e-3), (ex / 2, 0.0, ez / 2), fov_y=40.0,
                          near=1.0, far=height * 3, aspect=size[0] / size[1])


def pixel_rays(cam: Camera, size):
    """World origin and unit direction of the ray through every pixel centre (h, w, 3)."""
    w, h = size
    px, py = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    ndc = np.stack([px / w * 2 - 1, 1 - py / h * 2, np.ones_like(px), np.ones_like(px)], -1)
    far = ndc @ np.linalg.inv(cam.view_projection()).T
    far = far[..., :3] / far[..., 3:]
    d = far - cam.eye
    return cam.eye, d / np.linalg.norm(d, axis=-1, keepdims=True)


def ray_box(origin, d, lo, hi):
    """Slab test: bool hit and entry distance of rays against one axis-aligned box."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / np.where(np.abs(d) < 1e-12, 1e-12, d)
        t0 = (lo - origin) * inv
        t1 = (hi - origin) * inv
    tmin = np.minimum(t0, t1).max(axis=-1)
    tmax = np.maximum(t0, t1).min(axis=-1)
    return (tmax >= np.maximum(tmin, 0.0)), tmin


def luma(img):
    return img[..., :3].astype(np.float64) @ LUMA


@pytest.fixture(scope="module")
def boxes(box_mesh):
    mesh = box_mesh()
    pos = np.array([[20.0, 0.0, 24.0], [40.0, 0.0, 30.0], [30.0, 0.0, 44.0]])
    return Instances((mesh,), np.zeros(3, int), pos, np.array([1.0, 1.5, 0.8]),
                     np.array([0.0, 0.7, 2.1]))


# --- cascades geometry (no GL) ----------------------------------------------------------
def test_practical_splits_blend_log_and_uniform():
    z = practical_splits(1.0, 1000.0, 3, blend=1.0)
    np.testing.assert_allclose(z, [1.0, 10.0, 100.0, 1000.0])
    np.testing.assert_allclose(practical_splits(1.0, 10.0, 3, blend=0.0), [1, 4, 7, 10])
    with pytest.raises(InvalidParameterError):
        practical_splits(5.0, 1.0, 3)


def test_cascades_snap_to_texels_and_keep_their_size_as_the_camera_moves():
    # a scene larger than the camera's range: the splits run from its near to its far plane
    lo, hi = np.array([-1e5, 0.0, -1e5]), np.array([1e5, 80.0, 1e5])
    sun = sun_direction(*SUN)
    cam = Camera.look_at((250.0, 60.0, 520.0), (250.0, 0.0, 200.0), fov_y=50.0, near=1.0,
                         far=2000.0)
    moved = Camera(position=tuple(cam.eye + np.array([3.37, 0.4, -1.91])), yaw=cam.yaw + 17.0,
                   pitch=cam.pitch - 5.0, fov_y=50.0, near=1.0, far=2000.0)
    a = fit_cascades(cam, sun, lo, hi, resolution=1024)
    b = fit_cascades(moved, sun, lo, hi, resolution=1024)
    assert len(a) == 3 and (np.diff(a.splits) > 0).all()
    assert (np.diff(a.texel_size) > 0).all()  # far cascades cover more ground
    np.testing.assert_allclose(a.splits, b.splits)
    # the slices' bounding spheres do not change with the camera: nor does the texel size
    np.testing.assert_allclose(a.texel_size, b.texel_size, rtol=1e-12)
    for cas in (a, b):
        for k in range(len(cas)):
            m = cas.matrices[k]
            # clip x = (x_light − cx) / r: the box's centre sits on a whole texel
            centre = -m[:2, 3] / np.linalg.norm(m[:2, :3], axis=1)
            texels = centre / cas.texel_size[k]
            np.testing.assert_allclose(texels, np.round(texels), atol=1e-6)
    # a world point keeps its position inside its texel after the move (no shimmer): its
    # light-space coordinate changes by a whole number of texels in the same cascade
    p = np.array([300.0, 5.0, 300.0, 1.0])
    for k in range(3):
        ta = (a.matrices[k] @ p)[:2] * 0.5 * a.resolution
        tb = (b.matrices[k] @ p)[:2] * 0.5 * b.resolution
        np.testing.assert_allclose(ta - tb, np.round(ta - tb), atol=1e-6)


def test_object_shadow_modes():
    assert resolve_object_shadows(None, True) == "cascades"
    assert resolve_object_shadows(None, False) == "none"
    assert resolve_object_shadows("none", True) == "none"
    with pytest.raises(InvalidParameterError, match="object_shadows"):
        resolve_object_shadows("stencil", True)


# --- GL -------------------------------------------------------------------------------
@pytest.mark.gl
def test_instanced_draw_equals_a_pretransformed_draw(gl_ctx, boxes):
    """Three instances of a box, drawn instanced, against one mesh of the same triangles
    already in world space (drawn once at the origin)."""
    hm = flat()
    size = (160, 120)
    cam = Camera.look_at((32.0, 30.0, 80.0), (32.0, 0.0, 32.0), fov_y=45.0, near=1.0,
                         far=300.0, aspect=size[0] / size[1])
    tris = boxes.world_triangles()
    mesh = boxes.meshes[0]
    colors = np.repeat(mesh.colors[mesh.indices].reshape(1, -1, 3), len(boxes), 0)
    normals = []
    for m, k in zip(boxes.matrices(), range(len(boxes)), strict=True):
        rot = m[:3, :3] / boxes.scale[k]
        normals.append(mesh.normals[mesh.indices].reshape(-1, 3) @ rot.T)
    whole = ObjectMesh("whole", tris.reshape(-1, 3), np.concatenate(normals),
                       colors.reshape(-1, 3), np.arange(tris.shape[0] * 3).reshape(-1, 3))
    single = Instances((whole,), [0], [[0.0, 0.0, 0.0]], [1.0], [0.0])
    params = {"sun": SUN, "object_shadows": "none", "impostor_pixels": 0, "haze": 0.0}
    r = OffscreenRenderer(gl_ctx, hm, size=size)
    try:
        empty = r.render(cam, "plain", params)
        r.terrain.set_objects(boxes)
        inst = r.render(cam, "plain", params)
        assert r.terrain.last_stats["objects_meshes"] == 3
        r.terrain.set_objects(single)
        ref = r.render(cam, "plain", params)
    finally:
        r.release()
    diff = np.abs(inst.astype(int) - ref.astype(int)).max(axis=-1)
    covered = np.abs(inst.astype(int) - empty.astype(int)).max(axis=-1) > 0
    assert covered.sum() > 300  # the boxes are on screen
    assert (diff <= 2).mean() > 0.999


@pytest.mark.gl
def test_objects_appear_where_they_were_placed(gl_ctx, boxes):
    hm = flat()
    size = (160, 120)
    cam = Camera.look_at((32.0, 40.0, 85.0), (32.0, 0.0, 30.0), fov_y=45.0, near=1.0,
                         far=300.0, aspect=size[0] / size[1])
    r = OffscreenRenderer(gl_ctx, hm, size=size)
    try:
        empty = r.render(cam, "plain", {"sun": SUN})
        r.terrain.set_objects(boxes)
        with_objects = r.render(cam, "plain", {"sun": SUN})
    finally:
        r.release()
    changed = np.abs(with_objects.astype(int) - empty.astype(int)).max(axis=-1) > 8
    # a point a little above each foot, on the box's axis
    pts = boxes.positions + np.c_[np.zeros(3), 1.0 * boxes.scale, np.zeros(3)]
    px = cam.project(pts, size)
    for x, y, _ in px:
        row, col = int(y), int(x)
        assert changed[row - 1:row + 2, col - 1:col + 2].all(), (row, col)
    # and nothing changes far from every object and its shadow
    assert not changed[:10].any()


def _shadow_scene(gl_ctx, boxes, size, resolution=None):
    hm = flat()
    cam = overhead(hm, 90.0, size)
    params = {"sun": SUN, "haze": 0.0, "cascade_resolution": resolution}
    r = OffscreenRenderer(gl_ctx, hm, size=size)
    try:
        empty = r.render(cam, "plain", params)
        r.terrain.set_objects(boxes)
        img = r.render(cam, "plain", params)
        no_shadow = r.render(cam, "plain", {**params, "object_shadows": "none"})
    finally:
        r.release()
    return hm, cam, empty, img, no_shadow


def _analytic_shadow(cam, size, boxes):
    """Per pixel: (ground pixel, in the shadow of a box) from a CPU ray cast: the view ray
    meets the ground y = 0 (not a box first); the ray from there toward the sun meets a box."""
    eye, d = pixel_rays(cam, size)
    t = -eye[1] / d[..., 1]
    ground = eye + d * t[..., None]
    sun = sun_direction(*SUN)
    on_box = np.zeros(d.shape[:2], bool)
    shadow = np.zeros(d.shape[:2], bool)
    mesh_lo, mesh_hi = boxes.meshes[0].bounds
    for k in range(len(boxes)):
        tris = boxes.world_triangles(k).reshape(-1, 3)
        lo, hi = tris.min(axis=0), tris.max(axis=0)
        if boxes.yaw[k] != 0.0:
            # a turned box: cast in its own frame (rotate the rays by -yaw about its foot)
            c, s = math.cos(boxes.yaw[k]), math.sin(boxes.yaw[k])
            inv = np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]])
            foot = boxes.positions[k]
            lo = mesh_lo * boxes.scale[k]
            hi = mesh_hi * boxes.scale[k]
            o1 = (eye - foot) @ inv.T
            d1 = d @ inv.T
            g1 = (ground - foot) @ inv.T
            s1 = np.broadcast_to(sun @ inv.T, d.shape)
        else:
            o1, d1, g1, s1 = eye, d, ground, np.broadcast_to(sun, d.shape)
        hit, _ = ray_box(o1, d1, lo, hi)
        on_box |= hit
        sh, _ = ray_box(g1 + 1e-4 * s1, s1, lo, hi)
        shadow |= sh
    return ~on_box, shadow


@pytest.mark.gl
def test_cascade_shadows_fall_where_the_cpu_ray_cast_puts_them(gl_ctx, boxes):
    size = (192, 192)
    _, cam, empty, img, no_shadow = _shadow_scene(gl_ctx, boxes, size)
    ground, shadow = _analytic_shadow(cam, size, boxes)
    ratio = luma(img) / np.maximum(luma(empty), 1.0)
    measured = ratio < 0.8
    # away from contact edges: 2 pixels off every edge of the analytic shadow and the boxes
    from scipy.ndimage import binary_dilation, binary_erosion

    edge = (binary_dilation(shadow, iterations=2) & ~binary_erosion(shadow, iterations=2))
    edge |= binary_dilation(~ground, iterations=2)
    keep = ground & ~edge
    assert shadow[keep].sum() > 200  # the shadows are in view and sizeable
    agreement = (measured[keep] == shadow[keep]).mean()
    assert agreement >= 0.98, agreement
    # without object shadows the ground is unchanged outside the boxes themselves
    assert (np.abs(luma(no_shadow) - luma(empty))[keep] < 2).mean() > 0.99
    # no black shadows: the sky still lights the shadowed ground
    inner = binary_erosion(shadow, iterations=3) & ground
    assert luma(img)[inner].min() > 0.25 * luma(empty)[inner].mean()


@pytest.mark.gl
def test_cascade_shadows_point_away_from_the_sun(gl_ctx, box_mesh):
    """One tall box: the darkened ground lies on the side away from the sun's azimuth."""
    mesh = box_mesh(size=(2.0, 10.0, 2.0))
    one = Instances((mesh,), [0], [[32.0, 0.0, 32.0]], [1.0], [0.0])
    size = (128, 128)
    _, cam, empty, img, _ = _shadow_scene(gl_ctx, one, size, resolution=1024)
    dark = luma(img) / np.maximum(luma(empty), 1.0) < 0.8
    rows, cols = np.nonzero(dark)
    foot = cam.project([[32.0, 0.0, 32.0]], size)[0]
    # sun in the south-east (azimuth 135°): the shadow goes north-west — up-left on screen
    # for a camera looking down with north at the top
    top = cam.project([[32.0, 0.0, 0.0]], size)[0]
    assert top[1] < foot[1]  # north is up in this view
    assert np.mean(cols) < foot[0] - 3
    assert np.mean(rows) < foot[1] - 3


@pytest.mark.gl
def test_impostors_switch_in_without_a_jump_in_colour(gl_ctx, box_mesh):
    mesh = box_mesh(size=(3.0, 8.0, 3.0), color=(0.2, 0.35, 0.12))
    rng = np.random.default_rng(3)
    n = 60
    pos = np.c_[rng.uniform(8, 120, n), np.zeros(n), rng.uniform(8, 60, n)]
    inst = Instances((mesh,), np.zeros(n, int), pos, rng.uniform(0.8, 1.2, n),
                     rng.uniform(0, 2 * np.pi, n))
    hm = flat(129)
    size = (256, 144)
    cam = Camera.look_at((64.0, 25.0, 200.0), (64.0, 0.0, 30.0), fov_y=40.0, near=1.0,
                         far=600.0, aspect=size[0] / size[1])
    r = OffscreenRenderer(gl_ctx, hm, size=size)
    try:
        empty = r.render(cam, "plain", {"sun": SUN})
        r.terrain.set_objects(inst)
        meshes = r.render(cam, "plain", {"sun": SUN, "impostor_pixels": 0})
        assert r.terrain.last_stats["objects_impostors"] == 0
        impostors = r.render(cam, "plain", {"sun": SUN, "impostor_pixels": 1e6})
        assert r.terrain.last_stats["objects_meshes"] == 0
        assert r.terrain.last_stats["objects_impostors"] > 40
    finally:
        r.release()
    # covered = any channel moved, not the luma: the sunlit faces of these green boxes have
    # the luma of the grey haze behind them (the fade surround), and a luma test loses
    # a third of the mesh's pixels there (fewer of the impostor's, shaded a little darker)
    def covered(img):
        return np.abs(img[..., :3].astype(int) - empty[..., :3].astype(int)).max(axis=-1) > 6

    cover_m, cover_i = covered(meshes), covered(impostors)
    assert cover_m.sum() > 300
    # same footprint on screen (within a tenth) and close in mean colour
    assert abs(int(cover_i.sum()) - int(cover_m.sum())) < 0.1 * cover_m.sum()
    both = cover_m & cover_i
    mean_m = meshes[both][:, :3].mean(axis=0)
    mean_i = impostors[both][:, :3].mean(axis=0)
    assert np.abs(mean_m - mean_i).max() < 8.0, (mean_m, mean_i)
    assert abs(meshes[..., :3].mean() - impostors[..., :3].mean()) < 1.0


@pytest.mark.gl
def test_volumes_draw_stencil_volumes_without_a_fallback(gl_ctx, boxes):
    hm = flat(33)
    r = OffscreenRenderer(gl_ctx, hm, size=(64, 64))
    try:
        r.terrain.set_objects(boxes)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            r.render(None, "plain", {"object_shadows": "volumes"})
        assert r.terrain.objects.mode == "volumes"
        assert r.terrain.last_stats["shadow_volume_triangles"] > 0
        with pytest.raises(InvalidParameterError, match="object_shadows"):
            r.render(None, "plain", {"object_shadows": "stencil"})
    finally:
        r.release()


# --- CLI and API ------------------------------------------------------------------------
@pytest.mark.gl
def test_render_cli_objects_equal_the_api(gl_ctx, tmp_path):
    from PIL import Image

    from terrascape.cli.app import run_app
    from terrascape.generate.registry import VIEW_SPACING, generate
    from terrascape.objects import scatter
    from terrascape.render.offscreen import render_to_array

    out = tmp_path / "objects.png"
    plain = tmp_path / "plain.png"
    args = ["render", "--generate", "fbm", "--gen-size", "65", "--seed", "4", "--size",
            "96x64", "-q"]
    assert run_app([*args, "-o", str(out), "--objects", "default"]) == 0
    assert run_app([*args, "-o", str(plain)]) == 0
    img = np.asarray(Image.open(out))
    hm = generate("fbm", 65, seed=4, spacing=VIEW_SPACING)
    inst = scatter(hm, seed=4)
    assert len(inst) > 0
    ref = render_to_array(hm, size=(96, 64), ctx=gl_ctx, objects=inst, params={"seed": 4})
    np.testing.assert_array_equal(img, ref[..., :3])
    assert (img != np.asarray(Image.open(plain))).any(axis=-1).mean() > 0.005
    # bad input: one clear line, exit 2
    assert run_app([*args, "-o", str(tmp_path / "x.png"), "--objects", "default",
                    "--object-shadows", "stencil"]) == 2
    assert run_app([*args, "-o", str(tmp_path / "y.png"), "--object-shadows", "none"]) == 2


@pytest.mark.gl
def test_viewer_keys_toggle_objects_and_cycle_their_shadows(gl_ctx, boxes):
    from terrascape.viewer.controls import HELP
    from terrascape.viewer.session import ViewerSession

    size = (96, 64)
    s = ViewerSession(gl_ctx, flat(), size=size, hud=False, warn=lambda m: None,
                      objects=boxes)
    s.camera = Camera.look_at((32.0, 40.0, 85.0), (32.0, 0.0, 30.0), fov_y=45.0, near=1.0,
                              far=300.0)
    fbo = gl_ctx.simple_framebuffer(size)

    def frame():
        s.render(fbo, 0.02)
        return np.frombuffer(fbo.read(components=3), np.uint8).reshape(size[1], size[0], 3)

    try:
        shown = frame()
        assert s.stats["objects_meshes"] + s.stats["objects_impostors"] == 3
        assert s.renderer.objects.mode == "cascades"
        s.state.handle_key("B")
        hidden = frame()
        assert "objects_meshes" not in s.stats
        assert (shown != hidden).any(axis=-1).mean() > 0.01
        s.state.handle_key("B")
        s.state.handle_key("G")  # → volumes (cascades here: this framebuffer has no stencil)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ObjectShadowFallbackWarning)
            frame()
        s.state.handle_key("G")  # → none
        frame()
        assert s.state.object_shadows == "none" and s.renderer.objects.mode == "none"
        assert any("object shadows" in d for _, d in HELP)
        assert any("shadows none" in line for line in s.status_lines())
    finally:
        fbo.release()
        s.release()


@pytest.mark.gl
def test_cascades_on_hills_agree_with_the_ray_cast_reference(gl_ctx):
    """Built-in trees and a house on hills: the terrain pixels the cascades darken are those
    the CPU ray cast (objects.shadow_reference) finds in an object's shadow, ≥ 98 % away
    from shadow edges and contact points."""
    from scipy.ndimage import binary_dilation

    from terrascape.generate import hills
    from terrascape.objects import builtin_meshes, surface_height, surface_normal
    from terrascape.objects.shadow_reference import boundary_band, shadow_reference

    heights = hills(65, count=40, seed=4)
    hm = Heightmap(heights.heights * (8.0 / max(float(np.ptp(heights.heights)), 1e-6)),
                   spacing=(1.0, 1.0))
    meshes = builtin_meshes()
    names = ["conifer", "broadleaf", "house", "conifer", "bush"]
    kinds = list(dict.fromkeys(names))
    xz = np.array([[20.0, 30.0], [38.0, 24.0], [30.0, 44.0], [46.0, 40.0], [14.0, 48.0]])
    y = surface_height(hm, xz[:, 0], xz[:, 1])
    inst = Instances(tuple(meshes[n] for n in kinds), [kinds.index(n) for n in names],
                     np.c_[xz[:, 0], y, xz[:, 1]], [1.0, 0.9, 0.6, 0.7, 1.0],
                     [0.0, 1.0, 0.4, 2.0, 0.0])
    size = (384, 256)
    cam = Camera.look_at((32, 45, 90), (32, 0, 36), aspect=size[0] / size[1], near=1.0,
                         far=500.0)
    sun = (60.0, 30.0)
    params = {"sun": sun, "impostor_pixels": 0, "haze": 0.0}
    r = OffscreenRenderer(gl_ctx, hm, size=size)
    try:
        bare = r.render(cam, "material", params)
        r.terrain.set_objects(inst)
        none = r.render(cam, "material", {**params, "object_shadows": "none"})
        casc = r.render(cam, "material", {**params, "object_shadows": "cascades"})
        ref = shadow_reference(cam, r.last_depth(), sun, instances=inst, heightmap=hm)
    finally:
        r.release()
    objects = np.abs(none.astype(int) - bare.astype(int)).max(axis=-1) > 0
    pts = np.nan_to_num(ref.points)
    n = surface_normal(hm, pts[..., 0].ravel(), pts[..., 2].ravel()).reshape(*size[::-1], 3)
    sunlit = n @ sun_direction(*sun) > 0.3  # where a cast shadow visibly darkens
    keep = (ref.surface & ~binary_dilation(objects, iterations=2) & ~ref.terrain_shadow
            & ~boundary_band(ref.object_shadow, 1) & sunlit)
    measured = luma(casc) < 0.8 * luma(none)
    assert ref.object_shadow[keep].sum() > 300
    agreement = (measured[keep] == ref.object_shadow[keep]).mean()
    assert agreement >= 0.98, agreement


@pytest.mark.gl
def test_objects_in_a_ridges_shadow_are_dark_and_the_others_lit(gl_ctx, box_mesh):
    """The terrain's shadow on objects (ray-cast through the height texture): a box behind
    a ridge, away from the sun, gets only sky light on its sunward face; one in the open
    keeps the sun."""
    n = 97
    h = np.zeros((n, n), np.float32)
    h[:, 40:44] = 20.0  # a north-south wall of 20 m at x = 40..43
    hm = Heightmap(h, spacing=(1.0, 1.0))
    mesh = box_mesh(size=(4.0, 6.0, 4.0), color=(0.5, 0.5, 0.5))
    # sun in the west, 30° up: the wall's shadow reaches 34 m east of it
    sun = (270.0, 30.0)
    inst = Instances((mesh,), [0, 0], [[52.0, 0.0, 30.0], [85.0, 0.0, 30.0]], [1.0, 1.0],
                     [0.0, 0.0])
    size = (160, 120)
    # east of the wall, south of the boxes: it sees their west faces
    cam = Camera.look_at((46.0, 8.0, 5.0), (68.0, 3.0, 30.0), fov_y=60.0, near=0.5,
                         far=400.0, aspect=size[0] / size[1])
    params = {"sun": sun, "haze": 0.0, "impostor_pixels": 0, "object_shadows": "none"}
    r = OffscreenRenderer(gl_ctx, hm, size=size)
    try:
        r.terrain.set_objects(inst)
        shaded = r.render(cam, "plain", params)
        lit = r.render(cam, "plain", {**params, "shadows": False})
        # the other variant: the terrain drawn into the cascades, its sweep off
        cascaded = r.render(cam, "plain", {**params, "shadows": False, "cascade_terrain": True,
                                           "object_shadows": "cascades"})
    finally:
        r.release()
    ground = cam.project([[62.0, 0.0, 45.0], [92.0, 0.0, 45.0]], size)
    assert ((ground[:, 0] > 2) & (ground[:, 0] < size[0] - 2) & (ground[:, 1] > 2)
            & (ground[:, 1] < size[1] - 2)).all()
    g = [luma(cascaded[int(y) - 1:int(y) + 2, int(x) - 1:int(x) + 2]).mean()
         / luma(lit[int(y) - 1:int(y) + 2, int(x) - 1:int(x) + 2]).mean() for x, y, _ in ground]
    assert g[0] < 0.7 and g[1] > 0.97, g  # the wall's shadow on the ground, from the cascades
    # the west (sunward) face of each box, 3 m up
    faces = cam.project([[50.0 - 0.05, 3.0, 30.0], [83.0 - 0.05, 3.0, 30.0]], size)
    ratios = []
    for x, y, _ in faces:
        row, col = int(y), int(x)
        patch = (slice(row - 1, row + 2), slice(col - 1, col + 2))
        ratios.append(luma(shaded[patch]).mean() / luma(lit[patch]).mean())
    behind, open_ = ratios
    assert behind < 0.7, ratios  # in the wall's shadow: sky light only
    assert behind > 0.15, ratios  # not black
    assert open_ > 0.97, ratios
