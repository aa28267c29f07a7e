"""Stencil shadow volumes on pixels: against the CPU ray cast and the analytic shadow of a box
on flat ground; the fallback without a stencil buffer."""

import warnings

import numpy as np
import pytest
from scipy.spatial import Delaunay

from terrascape.camera import Camera
from terrascape.heightmap import Heightmap
from terrascape.lighting.sun import sun_direction
from terrascape.objects import Instances, ObjectMesh
from terrascape.objects.shadow_reference import agreement, boundary_band, shadow_reference

pytestmark = pytest.mark.gl

SIZE = (200, 150)
SUN = (45.0, 35.0)  # the shadows fall toward the camera


def box(size):
    """Closed box (8 shared corners), foot at the origin, counter-clockwise from outside."""
    sx, sy, sz = size[0] / 2, size[1], size[2] / 2
    p = np.array([[x, y, z] for y in (0, sy) for z in (-sz, sz) for x in (-sx, sx)], np.float32)
    # corners: 0..3 bottom (x, z) = (-,-) (+,-) (-,+) (+,+); 4..7 the same on top
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4),
             (1, 5, 7, 3)]
    idx = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    n = p - p.mean(axis=0)
    return ObjectMesh("test-box", p, n / np.linalg.norm(n, axis=1, keepdims=True),
                      np.full_like(p, 0.7), idx)


@pytest.fixture(scope="module")
def scene(gl_ctx):
    from terrascape.render.offscreen import OffscreenRenderer

    hm = Heightmap(np.zeros((97, 97), np.float32), spacing=(1.0, 1.0))
    r = OffscreenRenderer(gl_ctx, hm, size=SIZE)
    boxes = Instances((box((10.0, 16.0, 8.0)),), [0, 0], [[48, 0, 48], [25, 0, 72]],
                      [1.0, 0.8], [0.0, 0.6])
    r.terrain.set_objects(boxes)
    cam = Camera.look_at((45, 70, 100), (42, 0, 55), aspect=SIZE[0] / SIZE[1], near=1.0,
                         far=1000.0)
    yield r, hm, boxes, cam
    r.release()


def test_box_is_outward():
    b = box((2, 2, 2))
    tri = b.positions[b.indices]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    assert np.all(np.einsum("ij,ij->i", n, tri.mean(axis=1) - [0, 1, 0]) > 0)


@pytest.mark.parametrize("technique", ["plain", "material"])  # forward, deferred
def test_volumes_match_the_ray_cast(scene, technique):
    r, _, boxes, cam = scene
    r.render(cam, technique, {"object_shadows": "volumes", "sun": SUN})
    count = r.last_shadow_count()
    ref = shadow_reference(cam, r.last_depth(), SUN, instances=boxes)
    surface = ref.surface
    assert surface.mean() > 0.5 and ref.object_shadow.sum() > 300  # a real shadow
    assert agreement(count > 0, ref.object_shadow, surface) >= 0.995
    # away from the shadow's edge they agree on every pixel
    inner = surface & ~boundary_band(ref.object_shadow, 1)
    assert agreement(count > 0, ref.object_shadow, inner) == 1.0


def _analytic_shadow(boxes, sun):
    """Ground points (x, z) inside the shadow of each box: the convex hull of its footprint
    and its top corners projected along the sun onto y = 0."""
    d = np.asarray(sun_direction(*sun), np.float64)
    hulls = []
    for tri in np.split(boxes.world_triangles().reshape(-1, 3), len(boxes)):
        corners = np.unique(tri.astype(np.float64), axis=0)
        ground = corners[:, [0, 2]] - corners[:, 1:2] / d[1] * d[[0, 2]]
        hulls.append(Delaunay(ground))
    return hulls


@pytest.mark.parametrize("technique", ["plain", "material"])
def test_shadow_lies_where_the_box_projects_it(scene, technique):
    r, _, boxes, cam = scene
    params = {"sun": SUN, "fog_density": 0.0}
    lit = r.render(cam, technique, {**params, "object_shadows": "none"}).astype(float)
    shaded = r.render(cam, technique, {**params, "object_shadows": "volumes"}).astype(float)
    from terrascape.objects.shadow_reference import surface_points

    pts = surface_points(cam, r.last_depth())
    # ground pixels (not the boxes' own faces): surface points at height 0
    on_ground = np.isfinite(pts).all(axis=-1) & (np.abs(np.nan_to_num(pts[..., 1])) < 0.05)
    xz = np.where(on_ground[..., None], pts[..., [0, 2]], -1e9)
    inside = np.zeros(on_ground.shape, bool)
    for hull in _analytic_shadow(boxes, SUN):
        inside |= hull.find_simplex(xz) >= 0
    edge = boundary_band(inside, 1)
    luma_lit = lit[..., :3].mean(axis=-1)
    luma = shaded[..., :3].mean(axis=-1)
    core = inside & ~edge & on_ground
    out = ~inside & ~edge & on_ground
    assert core.sum() > 500
    # inside: only sky light is left (much darker); outside: the same pixels as without
    assert np.all(luma[core] < 0.75 * luma_lit[core])
    assert np.array_equal(shaded[out], lit[out])
    count = r.last_shadow_count()
    assert np.all(count[core] > 0) and np.all(count[out] == 0)


def test_no_stencil_falls_back_with_one_warning(scene, gl_ctx):
    from terrascape.render.context import current
    from terrascape.render.shadow_volumes import FALLBACK_MODE, ShadowVolumeFallbackWarning
    from terrascape.render.terrain import TerrainRenderer

    _, hm, boxes, cam = scene
    with current(gl_ctx):
        t = TerrainRenderer(gl_ctx, hm)
        t.set_objects(boxes)
        color = gl_ctx.renderbuffer(SIZE, 4)
        depth = gl_ctx.depth_renderbuffer(SIZE)
        fbo = gl_ctx.framebuffer([color], depth)

        def frame(mode):
            t.render(fbo, cam, "plain", {"object_shadows": mode, "sun": SUN})
            return np.frombuffer(fbo.read(components=4), np.uint8)

        with pytest.warns(ShadowVolumeFallbackWarning, match="stencil") as caught:
            first = frame("volumes")
            second = frame("volumes")
        assert len([w for w in caught if w.category is ShadowVolumeFallbackWarning]) == 1
        assert np.array_equal(first, second)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            assert np.array_equal(first, frame(FALLBACK_MODE))
        t.release()
        fbo.release()
        color.release()
        depth.release()


def test_bad_mode_is_a_clear_error(scene):
    from terrascape.errors import InvalidParameterError

    r, _, _, cam = scene
    with pytest.raises(InvalidParameterError, match="object_shadows must be one of"):
        r.render(cam, "plain", {"object_shadows": "stencil"})


def _trees_on_hills():
    from terrascape.generate import hills
    from terrascape.objects import builtin_meshes, surface_height

    heights = hills(65, count=40, seed=4)
    hm = Heightmap(heights.heights * (8.0 / max(float(np.ptp(heights.heights)), 1e-6)),
                   spacing=(1.0, 1.0))
    meshes = builtin_meshes()
    names = ["conifer", "broadleaf", "house", "conifer", "bush"]
    xz = np.array([[20.0, 30.0], [38.0, 24.0], [30.0, 44.0], [46.0, 40.0], [14.0, 48.0]])
    y = surface_height(hm, xz[:, 0], xz[:, 1])
    inst = Instances(tuple(meshes[n] for n in dict.fromkeys(names)),
                     [list(dict.fromkeys(names)).index(n) for n in names],
                     np.c_[xz[:, 0], y, xz[:, 1]], [1.0, 0.9, 0.6, 0.7, 1.0],
                     [0.0, 1.0, 0.4, 2.0, 0.0])
    return hm, inst


def test_built_in_trees_and_a_house_on_hills_match_the_ray_cast(gl_ctx):
    from terrascape.render.offscreen import OffscreenRenderer

    hm, inst = _trees_on_hills()
    r = OffscreenRenderer(gl_ctx, hm, size=SIZE)
    try:
        r.terrain.set_objects(inst)
        cam = Camera.look_at((32, 45, 90), (32, 0, 36), aspect=SIZE[0] / SIZE[1], near=1.0,
                             far=500.0)
        sun = (60.0, 30.0)
        r.render(cam, "material", {"object_shadows": "volumes", "sun": sun,
                                   "impostor_pixels": 0})
        ref = shadow_reference(cam, r.last_depth(), sun, instances=inst)
        assert ref.object_shadow.sum() > 400
        assert agreement(r.last_shadow_count() > 0, ref.object_shadow, ref.surface) >= 0.995
    finally:
        r.release()


@pytest.mark.parametrize("sun", [(60.0, 10.0), (60.0, 30.0)])
def test_tree_faces_the_sun_grazes_agree_with_the_ray_cast_close_up(gl_ctx, sun):
    """Seen from close by, many tree faces are lit at a grazing angle. A surface point read
    from the depth buffer lies a fraction of a depth step under its face, and the ray cast
    used to find that very face in the way (97.6 % agreement at the 10° sun); a triangle
    whose plane passes through the ray's start no longer counts."""
    from terrascape.render.offscreen import OffscreenRenderer

    hm, inst = _trees_on_hills()
    r = OffscreenRenderer(gl_ctx, hm, size=SIZE)
    try:
        r.terrain.set_objects(inst)
        cam = Camera.look_at((32, 20, 70), (30, 6, 36), aspect=SIZE[0] / SIZE[1], near=1.0,
                             far=500.0)
        r.render(cam, "material", {"object_shadows": "volumes", "sun": sun,
                                   "impostor_pixels": 0})
        count = r.last_shadow_count() > 0
        ref = shadow_reference(cam, r.last_depth(), sun, instances=inst)
        assert ref.object_shadow.sum() > 2000
        # misses (ray cast shadowed, count 0) were 404 pixels of 30 000 at the 10° sun
        assert (ref.surface & ref.object_shadow & ~count).sum() <= 30
        assert agreement(count, ref.object_shadow, ref.surface) >= 0.998
    finally:
        r.release()


def test_render_cli_with_volumes_equals_the_api(gl_ctx, tmp_path):
    from PIL import Image

    from terrascape.cli.app import run_app
    from terrascape.generate.registry import VIEW_SPACING, generate
    from terrascape.objects import scatter
    from terrascape.render.offscreen import render_to_array

    args = ["render", "--generate", "fbm", "--gen-size", "65", "--seed", "4", "--size",
            "96x64", "-q", "--objects", "default"]
    out, flat_out = tmp_path / "volumes.png", tmp_path / "none.png"
    assert run_app([*args, "-o", str(out), "--object-shadows", "volumes"]) == 0
    assert run_app([*args, "-o", str(flat_out), "--object-shadows", "none"]) == 0
    img = np.asarray(Image.open(out))
    hm = generate("fbm", 65, seed=4, spacing=VIEW_SPACING)
    ref = render_to_array(hm, size=(96, 64), ctx=gl_ctx, objects=scatter(hm, seed=4),
                          params={"seed": 4, "object_shadows": "volumes"})
    np.testing.assert_array_equal(img, ref[..., :3])
    # the objects' shadows darken the frame
    none = np.asarray(Image.open(flat_out)).astype(float)
    assert (img.astype(float).mean(axis=-1) < 0.85 * none.mean(axis=-1)).mean() > 0.005


def test_infinite_far_plane_counts_alone_and_keeps_the_pictures(scene):
    """The frame is drawn with the infinite far plane: the count needs no depth clamping
    (the same stencil without it), and the picture is the one a finite far plane draws
    wherever the count is zero."""
    from terrascape.render.context import current
    from terrascape.render.shadow_volumes import ShadowVolumes
    from terrascape.render.stencil import read_stencil

    r, _, _, cam = scene
    params = {"sun": SUN, "fog_density": 0.0}
    lit = r.render(cam, "plain", {**params, "object_shadows": "none"})
    assert not r.terrain.last_camera.infinite_far
    shaded = r.render(cam, "plain", {**params, "object_shadows": "volumes"})
    drawn = r.terrain.last_camera
    assert drawn.infinite_far and drawn.far == cam.far
    count = r.last_shadow_count()
    assert (count > 0).sum() > 300
    with current(r.ctx):
        ShadowVolumes.of(r.terrain).count(r._stencil.fbo, drawn.view_projection(),
                                          depth_clamp=False)
        unclamped = read_stencil(r._stencil.fbo)
    np.testing.assert_array_equal(unclamped, count)
    outside = count == 0
    # the sky's view rays come from another matrix: a rounding step on a few pixels at most
    diff = np.abs(shaded[outside].astype(int) - lit[outside].astype(int))
    assert diff.max() <= 1 and (diff > 0).mean() < 1e-3
    # the depth handed back is in the caller's (finite) camera: the same surface points
    from terrascape.objects.shadow_reference import surface_points

    r.render(cam, "plain", {**params, "object_shadows": "none"})
    finite_depth = r.last_depth()
    r.render(cam, "plain", {**params, "object_shadows": "volumes"})
    a, b = surface_points(cam, finite_depth), surface_points(cam, r.last_depth())
    both = np.isfinite(a).all(axis=-1) & np.isfinite(b).all(axis=-1)
    assert both.mean() > 0.5
    assert np.nanmax(np.abs(a[both] - b[both])) < 0.05


def _off_screen_scene(gl_ctx):
    """Flat ground seen from above; a tall box off screen toward the sun, whose shadow falls
    into the view, and another off screen away from the sun, whose shadow cannot."""
    from terrascape.render.offscreen import OffscreenRenderer

    hm = Heightmap(np.zeros((129, 129), np.float32), spacing=(1.0, 1.0))
    r = OffscreenRenderer(gl_ctx, hm, size=SIZE)
    boxes = Instances((box((6.0, 40.0, 6.0)),), [0, 0], [[70, 0, 30], [96, 0, 100]],
                      [1.0, 1.0], [0.3, 0.0])
    r.terrain.set_objects(boxes)
    cam = Camera.look_at((34, 38, 78), (34, 0, 62), aspect=SIZE[0] / SIZE[1], near=1.0,
                         far=500.0, fov_y=40.0)
    return r, boxes, cam


def test_a_caster_off_screen_still_shadows_the_view(gl_ctx):
    from terrascape.objects.silhouette import bounding_spheres
    from terrascape.render.objects import sphere_in_frustum
    from terrascape.render.shadow_volumes import ShadowVolumes

    r, boxes, cam = _off_screen_scene(gl_ctx)
    try:
        centres, radii = bounding_spheres(boxes)
        assert not sphere_in_frustum(cam.frustum_planes(), centres, radii).any()
        params = {"sun": SUN, "fog_density": 0.0}
        lit = r.render(cam, "plain", {**params, "object_shadows": "none"}).astype(float)
        shaded = r.render(cam, "plain", {**params, "object_shadows": "volumes"})
        stats = r.terrain.last_stats
        assert stats["shadow_volume_casters"] == 1 and stats["shadow_volume_culled"] == 1
        count = r.last_shadow_count()
        ref = shadow_reference(cam, r.last_depth(), SUN, instances=boxes)
        assert ref.object_shadow.sum() > 1000  # the off-screen box's shadow is in view
        assert agreement(count > 0, ref.object_shadow, ref.surface) >= 0.995
        inner = ref.object_shadow & ~boundary_band(ref.object_shadow, 1)
        luma = shaded[..., :3].astype(float).mean(axis=-1)
        assert np.all(luma[inner] < 0.75 * lit[..., :3].mean(axis=-1)[inner])
        # culling changed nothing: the count of every volume is the same
        volumes = ShadowVolumes.of(r.terrain)
        volumes.cull = False
        try:
            full = r.render(cam, "plain", {**params, "object_shadows": "volumes"})
            assert r.terrain.last_stats["shadow_volume_culled"] == 0
            np.testing.assert_array_equal(r.last_shadow_count(), count)
            np.testing.assert_array_equal(full, shaded)
        finally:
            volumes.cull = True
    finally:
        r.release()


def test_looking_away_culls_every_volume(gl_ctx):
    r, _, _ = _off_screen_scene(gl_ctx)
    try:
        # toward the south-west, away from both boxes and their shadows
        away = Camera.look_at((30, 10, 90), (0, 0, 128), aspect=SIZE[0] / SIZE[1], near=1.0,
                              far=500.0)
        r.render(away, "plain", {"sun": SUN, "object_shadows": "volumes"})
        stats = r.terrain.last_stats
        assert stats["shadow_volume_culled"] == 2 and stats["shadow_volume_triangles"] == 0
        assert not r.last_shadow_count().any()
    finally:
        r.release()


@pytest.mark.parametrize("lighting", ["none", "vertex", "lightmap", "daylight"])
@pytest.mark.parametrize("technique", ["plain", "material", "bump", "relief"])
def test_volumes_darken_every_lighting_mode(scene, technique, lighting):
    """Forward (plain), deferred (material), bump-mapped and relief terrain: the ground in
    an object's shadow is darker under every lighting model, and nothing else changes."""
    from terrascape.objects.shadow_reference import surface_points

    r, _, _, cam = scene
    params = {"sun": SUN, "fog_density": 0.0, "lighting": lighting}
    lit = r.render(cam, technique, {**params, "object_shadows": "none"}).astype(float)
    shaded = r.render(cam, technique, {**params, "object_shadows": "volumes"}).astype(float)
    assert r.terrain.last_technique == technique
    count = r.last_shadow_count()
    pts = surface_points(cam, r.last_depth())
    ground = np.isfinite(pts).all(axis=-1) & (np.abs(np.nan_to_num(pts[..., 1])) < 0.05)
    ground &= ~boundary_band(ground, 1)  # not the boxes' faces just above the ground
    edge = boundary_band(count > 0, 1)
    core = (count > 0) & ~edge & ground
    out = (count == 0) & ~edge & ground
    assert core.sum() > 500 and out.sum() > 5000
    luma_lit, luma = lit[..., :3].mean(axis=-1), shaded[..., :3].mean(axis=-1)
    assert np.all(luma[core] < 0.8 * luma_lit[core])
    np.testing.assert_array_equal(shaded[out], lit[out])


@pytest.mark.parametrize("technique", ["plain", "material"])
def test_volumes_cut_at_the_lowest_surface_count_the_same(scene, technique):
    from terrascape.render.shadow_volumes import DEFAULT_REACH, ShadowVolumes

    r, _, boxes, cam = scene
    volumes = ShadowVolumes.of(r.terrain)
    params = {"object_shadows": "volumes", "sun": SUN}
    try:
        volumes.reach = "infinite"
        r.render(cam, technique, params)
        infinite = r.last_shadow_count().copy()
        volumes.reach = "floor"
        r.render(cam, technique, params)
        assert r.terrain.last_stats["shadow_volume_triangles"] > 0
        cut = r.last_shadow_count()
    finally:
        volumes.reach = DEFAULT_REACH
    assert (infinite > 0).sum() > 300
    assert ((cut > 0) == (infinite > 0)).mean() >= 0.9995
    ref = shadow_reference(cam, r.last_depth(), SUN, instances=boxes)
    assert agreement(cut > 0, ref.object_shadow, ref.surface) >= 0.995


def test_a_camera_below_the_cut_gets_the_volumes_to_infinity(scene):
    """A far cap at the cut must not cross the near plane (z-fail): a camera down there
    counts with the volumes to infinity, the same stencil as asked for them."""
    from terrascape.render.shadow_volumes import DEFAULT_REACH, ShadowVolumes

    r, _, _, _ = scene
    volumes = ShadowVolumes.of(r.terrain)
    # under the ground, looking up past the boxes' feet at their sides
    low = Camera.look_at((48, -0.9, 110), (40, 6, 48), aspect=SIZE[0] / SIZE[1], near=1.0,
                         far=1000.0)
    params = {"object_shadows": "volumes", "sun": SUN}
    try:
        counts = {}
        for reach in ("infinite", "floor"):
            volumes.reach = reach
            r.render(low, "plain", params)
            counts[reach] = r.last_shadow_count().copy()
    finally:
        volumes.reach = DEFAULT_REACH
    assert volumes._key[-1] is None  # no cut: the volumes to infinity were drawn
    assert (counts["infinite"] > 0).sum() > 100
    np.testing.assert_array_equal(counts["floor"], counts["infinite"])


def test_a_moving_sun_rebuilds_into_the_same_array_and_uploads_the_fresh_volumes(scene):
    """The rebuild of a moving sun writes into the previous rebuild's array; what reaches
    the GL buffer must still be exactly the volumes built from scratch for each sun."""
    from terrascape.objects.silhouette import shadow_volume
    from terrascape.render.shadow_volumes import ShadowVolumes

    r, _, boxes, _ = scene
    volumes = ShadowVolumes(r.ctx)
    try:
        arrays = []
        for az in (40.0, 41.0, 200.0, 40.0):
            d = sun_direction(az, 35.0)
            n = volumes.set_casters(boxes, d, floor=-1.0)
            fresh = shadow_volume(boxes, tuple(float(v) for v in d), None, -1.0)
            assert n == len(fresh) > 0
            uploaded = np.frombuffer(volumes._buffer.read(size=fresh.nbytes), np.float32)
            np.testing.assert_array_equal(uploaded.reshape(fresh.shape), fresh)
            arrays.append(volumes._scratch)
        assert all(a is arrays[0] for a in arrays)  # one allocation for all four suns
    finally:
        volumes.release()
