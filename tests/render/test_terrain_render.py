"""Terrain renderer: pixels against CPU evaluations, determinism, indices, culling, errors."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape.camera import Camera
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.lighting.normals import unpack_normals
from terrascape.lighting.sun import sun_direction
from terrascape.render.offscreen import OffscreenRenderer, render_to_array
from terrascape.render.shaders import available_programs, load_program
from terrascape.render.techniques import technique_names

pytestmark = pytest.mark.gl

N = 17  # flat test plane: 17×17 vertices, spacing 1 → 16×16 world units
SIZE = (96, 96)
FLAT = {"sky": False, "fog_density": 0.0, "lighting": "none"}


def _overhead(height=50.0, centre=(8.0, 0.0, 8.0), fov=19.0):
    # look_at straight down clamps pitch to -89.9°: practically a top view, north (-Z) up.
    return Camera.look_at(
        (centre[0], height, centre[2]),
        centre,
        fov_y=fov,
        near=1.0,
        far=200.0,
        aspect=SIZE[0] / SIZE[1],
    )


def _ground_points(camera, size, plane_y=0.0):
    """World point on y = plane_y seen through every pixel centre: (h, w, 3)."""
    w, h = size
    px, py = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    ndc = np.stack([px / w * 2 - 1, 1 - py / h * 2], -1)
    inv = np.linalg.inv(camera.view_projection())

    def unproject(z):
        pts = np.concatenate(
            [ndc, np.full((*ndc.shape[:2], 1), z), np.ones((*ndc.shape[:2], 1))], -1
        )
        q = pts @ inv.T
        return q[..., :3] / q[..., 3:4]

    a, b = unproject(-1.0), unproject(1.0)
    t = (plane_y - a[..., 1]) / (b[..., 1] - a[..., 1])
    return a + (b - a) * t[..., None]


@pytest.fixture(scope="module")
def flat(gl_ctx):
    r = OffscreenRenderer(gl_ctx, Heightmap(np.zeros((N, N), np.float32)), size=SIZE)
    yield r
    r.release()


def _gradient_texture():
    rows, cols = np.mgrid[0:N, 0:N]
    tex = np.zeros((N, N, 3), np.uint8)
    tex[..., 0] = cols * 15
    tex[..., 1] = rows * 15
    tex[..., 2] = 128
    return tex


def test_every_technique_program_compiles(gl_ctx):
    from terrascape.render.techniques import get_technique

    for name in technique_names():
        assert load_program(gl_ctx, get_technique(name).program).glo > 0
    assert {"plain", "regions", "texture3d", "splat", "bump"} <= set(technique_names())
    assert "sky" in available_programs()


def test_overhead_view_reproduces_texture(flat):
    flat.terrain.set_texture("u_color_tex", _gradient_texture())
    cam = _overhead()
    img = flat.render(cam, "plain", FLAT)
    p = _ground_points(replace_aspect(cam), SIZE)
    inside = (p[..., 0] > 0.3) & (p[..., 0] < 15.7) & (p[..., 2] > 0.3) & (p[..., 2] < 15.7)
    assert inside.sum() > 0.5 * inside.size
    # bilinear filtering of a linear ramp is exact: R = 15·x, G = 15·z
    np.testing.assert_allclose(img[..., 0][inside], 15 * p[..., 0][inside], atol=2.0)
    np.testing.assert_allclose(img[..., 1][inside], 15 * p[..., 2][inside], atol=2.0)
    np.testing.assert_allclose(img[..., 2][inside], 128, atol=1.0)
    # top-left of the image is the north-west corner (x, z small): row 0 is the top
    assert img[5, 5, 0] < img[5, -5, 0] and img[5, 5, 1] < img[-5, 5, 1]


def replace_aspect(cam):
    from dataclasses import replace

    return replace(cam, aspect=SIZE[0] / SIZE[1])


def test_same_inputs_same_pixels(gl_ctx, rng):
    hm = Heightmap(rng.random((33, 33)).astype(np.float32) * 4, (0.5, 0.5))
    a = render_to_array(hm, size=(64, 48), technique="regions", ctx=gl_ctx)
    b = render_to_array(hm, size=(64, 48), technique="regions", ctx=gl_ctx)
    assert a.dtype == np.uint8 and a.shape == (48, 64, 4)
    np.testing.assert_array_equal(a, b)
    assert (a[..., 3] == 255).all()


def test_lightmap_matches_cpu(flat, gl_ctx):
    from terrascape.lighting.shadows import lightmap

    hm = Heightmap(np.tile(0.4 * np.arange(N, dtype=np.float32), (N, 1)))  # plane rising east
    r = OffscreenRenderer(gl_ctx, hm, size=SIZE)
    try:
        r.terrain.set_texture("u_color_tex", np.full((4, 4, 3), 255, np.uint8))
        sun = (250.0, 40.0)  # from the west: the slope faces away from it
        img = r.render(_overhead(), "plain", {**FLAT, "lighting": "lightmap", "sun": sun})
        expected = lightmap(hm, *sun, shadows=False)
        assert np.ptp(expected) < 1e-6  # a plane has one value
        centre = img[
            SIZE[1] // 2 - 10 : SIZE[1] // 2 + 10, SIZE[0] // 2 - 10 : SIZE[0] // 2 + 10, 0
        ]
        np.testing.assert_allclose(centre, expected[0, 0] * 255, atol=1.5)
    finally:
        r.release()


def test_phong_matches_cpu(flat):
    flat.terrain.set_texture("u_color_tex", np.full((2, 2, 3), 255, np.uint8))
    cam = _overhead(height=12.0, fov=70.0)
    sun = (160.0, 55.0)
    params = {
        **FLAT,
        "lighting": "vertex",
        "sun": sun,
        "ka": 0.2,
        "kd": 0.5,
        "ks": 0.25,
        "shininess": 8.0,
        "specular_color": (1.0, 0.5, 0.25),
    }
    img = flat.render(cam, "plain", params).astype(np.float64) / 255
    p = _ground_points(replace_aspect(cam), SIZE)
    L = sun_direction(*sun)
    N_ = np.array([0.0, 1.0, 0.0])
    V = cam.eye - p
    V /= np.linalg.norm(V, axis=-1, keepdims=True)
    R = 2 * np.dot(N_, L) * N_ - L
    spec = np.maximum(V @ R, 0) ** 8
    expected = 0.2 + 0.5 * max(L @ N_, 0) + 0.25 * spec[..., None] * np.array([1.0, 0.5, 0.25])
    inside = (p[..., 0] > 0.5) & (p[..., 0] < 15.5) & (p[..., 2] > 0.5) & (p[..., 2] < 15.5)
    assert spec[inside].max() > 0.3  # the highlight is in view: the test can fail
    np.testing.assert_allclose(img[inside][:, :3], np.minimum(expected[inside], 1), atol=2 / 255)


def test_bump_uses_tangent_frame(flat):
    # a constant tangent-space normal tilted toward +u and −v
    nt = np.array([0.45, -0.3, 1.0])
    packed = np.empty((8, 8, 4), np.uint8)
    packed[..., :3] = np.rint((nt / np.linalg.norm(nt) * 0.5 + 0.5) * 255)
    packed[..., 3] = 128
    n_q = unpack_normals(packed)[0, 0].astype(np.float64)
    flat.terrain.set_texture("u_normal_height", packed)
    flat.terrain.set_texture("u_color_tex", np.full((2, 2, 3), 255, np.uint8))
    sun = (100.0, 30.0)
    img = flat.render(
        _overhead(),
        "bump",
        {**FLAT, "lighting": "vertex", "sun": sun, "ka": 0.1, "kd": 0.8, "ks": 0.0},
    )
    # T = +X, B = +Z, N = +Y  ⇒  n_world = (n.x, n.z, n.y)
    n_w = np.array([n_q[0], n_q[2], n_q[1]])
    expected = 0.1 + 0.8 * max(sun_direction(*sun) @ n_w, 0.0)
    c = img[40:56, 40:56, :3].astype(np.float64) / 255
    np.testing.assert_allclose(c, expected, atol=2 / 255)
    # with the normal map's y flipped the result differs: B's sign is really used
    wrong = np.array([n_q[0], -n_q[2], n_q[1]])
    assert abs(0.1 + 0.8 * max(sun_direction(*sun) @ wrong, 0) - expected) > 0.02
    flat.terrain._pinned.discard("u_normal_height")


def test_default_normal_map_perturbs_shading(gl_ctx):
    # the built-in rock normal map (pack_normal_height) varies the lighting of a flat plane;
    # bump_strength 0 gives back the uniform vertex-normal shading
    hm = Heightmap(np.zeros((9, 9), np.float32))
    cam = _overhead(height=25.0, centre=(4.0, 0.0, 4.0))
    kw = {"technique": "bump", "size": (32, 32), "ctx": gl_ctx, "camera": cam}
    base = {
        **FLAT,
        "lighting": "vertex",
        "ks": 0.0,
        "textures": {"u_color_tex": np.full((2, 2, 3), 255, np.uint8)},
    }
    a = render_to_array(hm, params={**base, "uv_scale": 2.0}, **kw)
    b = render_to_array(hm, params={**base, "bump_strength": 0.0}, **kw)
    centre_a, centre_b = a[8:24, 8:24, :3].astype(int), b[8:24, 8:24, :3].astype(int)
    assert np.ptp(centre_b[..., 0]) <= 1
    assert np.ptp(centre_a[..., 0]) > 5


def test_set_indices_draws_only_given_triangles(flat):
    flat.terrain.set_texture("u_color_tex", np.full((2, 2, 3), 200, np.uint8))
    cam = _overhead()
    full = flat.render(cam, "plain", FLAT)
    tris = flat.terrain.mesh.triangles.reshape(N - 1, N - 1, 2, 3)
    flat.terrain.set_indices(tris[:, : (N - 1) // 2])  # west half of the cells
    half = flat.render(cam, "plain", FLAT)
    assert flat.terrain.last_stats["triangles"] == (N - 1) * (N - 1)
    p = _ground_points(replace_aspect(cam), SIZE)
    west = (p[..., 0] > 1) & (p[..., 0] < 7) & (p[..., 2] > 1) & (p[..., 2] < 15)
    east = (p[..., 0] > 9) & (p[..., 0] < 15) & (p[..., 2] > 1) & (p[..., 2] < 15)
    np.testing.assert_array_equal(half[west], full[west])
    assert (half[east][:, 0] != 200).all() and (full[east][:, 0] == 200).all()
    flat.terrain.set_indices(None)
    np.testing.assert_array_equal(flat.render(cam, "plain", FLAT), full)
    with pytest.raises(InvalidParameterError, match="in \\[0, 289\\)"):
        flat.terrain.set_indices([0, 1, 289])
    with pytest.raises(InvalidParameterError, match="multiple of 3"):
        flat.terrain.set_indices([0, 1])
    with pytest.raises(InvalidParameterError, match="integers"):
        flat.terrain.set_indices(np.zeros(3))


def test_frustum_culling_keeps_the_image(gl_ctx, rng):
    hm = Heightmap(rng.random((65, 65)).astype(np.float32) * 3)
    # more pixels than the grid has vertices: the grid is hazed per vertex, as the same
    # triangles set as a triangulation are (TerrainRenderer._haze_per_vertex)
    r = OffscreenRenderer(gl_ctx, hm, size=(72, 72), chunk_size=17)
    try:
        cam = Camera.look_at((5, 20, 5), (20, 0, 20), fov_y=40, near=0.5, far=500, aspect=1)
        culled = r.render(cam, "plain")
        stats = dict(r.terrain.last_stats)
        r.terrain.set_indices(r.terrain.mesh.triangles)
        full = r.render(cam, "plain")
        assert stats["chunks_culled"] > 0 and stats["chunks"] > 0
        np.testing.assert_array_equal(culled, full)
    finally:
        r.release()


def test_wireframe_overlay_draws_edges(flat):
    flat.terrain.set_texture("u_color_tex", np.full((2, 2, 3), 255, np.uint8))
    cam = _overhead()
    params = {**FLAT, "wireframe": True, "wireframe_color": (1.0, 0.0, 0.0, 1.0)}
    img = flat.render(cam, "plain", params)
    plain = flat.render(cam, "plain", FLAT)
    red = (img[..., 0] == 255) & (img[..., 1] == 0)
    assert not ((plain[..., 0] == 255) & (plain[..., 1] == 0)).any()
    # 16 cells per side seen over ~90 px: every ~5.6 px a grid line ⇒ many red pixels,
    # yet most pixels stay white (lines are 1 px wide)
    assert 0.15 < red.mean() < 0.6
    p = _ground_points(replace_aspect(cam), SIZE)
    near_line = np.minimum(
        np.abs(p[..., 0] - np.round(p[..., 0])), np.abs(p[..., 2] - np.round(p[..., 2]))
    )
    diag = np.abs((p[..., 0] + p[..., 2]) - np.round(p[..., 0] + p[..., 2])) / np.sqrt(2)
    far_from_edges = (np.minimum(near_line, diag) > 0.25) & (p[..., 0] > 0) & (p[..., 0] < 16)
    assert not red[far_from_edges & (p[..., 2] > 0) & (p[..., 2] < 16)].any()


def test_sky_gradient(gl_ctx):
    hm = Heightmap(np.zeros((5, 5), np.float32))
    cam = Camera.look_at((2, 0.5, 30), (2, 3, 0), fov_y=60, aspect=1.0, near=0.1, far=100)
    img = render_to_array(
        hm, camera=cam, size=(32, 32), ctx=gl_ctx, sun=(0, 5),
        # the colour-gradient sky of the non-daylight modes (daylight is the default now;
        # its sky is checked in tests/render/test_daylight_render.py)
        params={"fog_density": 0.0, "lighting": "vertex"},
    )
    top, low = img[0, 16, :3].astype(int), img[-1, 16, :3].astype(int)
    # zenith is bluer/darker than the horizon colour
    assert top[2] - top[0] > low[2] - low[0]
    assert top.sum() < low.sum()


def test_bad_inputs_raise_typed_errors(flat, gl_ctx):
    t = flat.terrain
    with pytest.raises(InvalidParameterError, match="1 to 4 channels"):
        t.set_texture("u_color_tex", np.zeros((4, 4, 5), np.uint8))
    with pytest.raises(InvalidParameterError, match="dimensions"):
        t.set_texture("u_color_tex", np.zeros((4,), np.uint8))
    with pytest.raises(InvalidParameterError, match="dtype"):
        t.set_texture("u_color_tex", np.zeros((4, 4, 3), np.int64))
    with pytest.raises(InvalidParameterError, match="zero-size"):
        t.set_texture("u_color_tex", np.zeros((0, 4, 3), np.uint8))
    with pytest.raises(InvalidParameterError, match=r"unknown technique 'nope'.*plain"):
        flat.render(None, "nope")
    with pytest.raises(InvalidParameterError, match="unknown parameter 'kss'"):
        flat.render(None, "plain", {"kss": 1})
    with pytest.raises(InvalidParameterError, match="lighting"):
        flat.render(None, "plain", {"lighting": "sun"})
    with pytest.raises(InvalidParameterError, match="finite"):
        flat.render(None, "plain", {"ka": float("nan")})
    hm = Heightmap(np.zeros((3, 3), np.float32))
    with pytest.raises(InvalidParameterError, match="output size"):
        render_to_array(hm, size=(0, 10), ctx=gl_ctx)
    with pytest.raises(InvalidParameterError, match="exceeds"):
        render_to_array(hm, size=(100_000, 10), ctx=gl_ctx)
    with pytest.raises(InvalidParameterError, match="finite"):
        Camera.look_at((float("nan"), 1, 1), (0, 0, 0))
    with pytest.raises(InvalidParameterError, match="camera"):
        render_to_array(hm, camera="above", size=(8, 8), ctx=gl_ctx)
    with pytest.raises(InvalidParameterError, match="Heightmap"):
        render_to_array(np.zeros((3, 3)), size=(8, 8), ctx=gl_ctx)


def test_camera_inside_terrain_is_fine(gl_ctx):
    hm = Heightmap(np.full((9, 9), 5.0, np.float32))
    cam = Camera.look_at((4, 2, 4), (6, 2, 6), aspect=1, near=0.1, far=100)
    img = render_to_array(hm, camera=cam, size=(16, 16), ctx=gl_ctx)
    assert img.shape == (16, 16, 4)


def _far_terrain(rng_seed=3, side=257):
    from terrascape.generate import diamond_square

    return diamond_square(side, seed=rng_seed, roughness=0.6).normalised(0.0, 30.0)


# The tests below compare renderer options on a far overview (several triangles per pixel):
# the orbit overview at 35° that was the default camera before the landscape view.
def _on_and_off(renderer, switch, cam, tech, params=None):
    """(image, stats) with the renderer option ``switch`` on, then with it off."""
    out = []
    for value in (True, False):
        setattr(renderer.terrain, switch, value)
        out.append((renderer.render(cam, tech, params), dict(renderer.terrain.last_stats)))
    return out


@pytest.mark.parametrize("tech", ["plain", "bump"])
def test_small_triangle_cull_draws_the_same_image_from_a_fraction_of_the_triangles(gl_ctx, tech):
    # 257² seen whole at 160×90: cells project to well under a pixel.
    r = OffscreenRenderer(gl_ctx, _far_terrain(), size=(160, 90))
    try:
        (culled_img, stats), (full_img, full_stats) = _on_and_off(
            r, "small_triangle_cull", r.default_camera(elevation=35.0), tech)
    finally:
        r.release()
    assert stats["chunks_small_cull"] == stats["chunks"] > 0
    assert stats["triangles"] == full_stats["triangles_drawn"] == 2 * 256 * 256
    # most triangles hold no pixel centre at this size ...
    assert stats["triangles_drawn"] < 0.5 * stats["triangles"]
    # ... and they drew nothing: the same image, bit for bit
    np.testing.assert_array_equal(culled_img, full_img)


def test_small_triangle_cull_leaves_close_views_and_lod_meshes_alone(gl_ctx):
    r = OffscreenRenderer(gl_ctx, _far_terrain(side=65), size=(160, 90), small_triangle_cull=True)
    try:
        cam = Camera.look_at((20, 40, 20), (32, 10, 32), fov_y=50, aspect=16 / 9)
        r.render(cam, "plain")
        assert r.terrain.last_stats["chunks_small_cull"] == 0
        r.terrain.set_indices(r.terrain.mesh.triangles)  # LOD meshes are never culled
        r.render(r.default_camera(elevation=35.0), "plain")
        assert r.terrain.last_stats["chunks_small_cull"] == 0
    finally:
        r.release()


def test_small_triangle_cull_is_on_by_default_on_software_rasterisers(gl_ctx):
    from terrascape.render.context import describe_context

    r = OffscreenRenderer(gl_ctx, _far_terrain(side=33), size=(32, 32))
    try:
        software = "llvmpipe" in describe_context(gl_ctx)["renderer"].lower()
        assert r.terrain.small_triangle_cull is software
    finally:
        r.release()


@pytest.mark.parametrize("tech", ["regions", "splat", "relief", "bump"])
def test_deferred_shading_draws_what_forward_shading_draws(gl_ctx, tech):
    r = OffscreenRenderer(gl_ctx, _far_terrain(), size=(160, 90), small_triangle_cull=True)
    try:
        # Relief under the daylight default: its tone curve is steepest in the mid-tones the
        # relief texture's LOD differences fall in; the geometry buffer is what is compared,
        # so relief is compared under Phong lighting as before the daylight default.
        params = {"lighting": "vertex"} if tech == "relief" else None
        (deferred, stats), (forward, _) = _on_and_off(
            r, "deferred_shading", r.default_camera(elevation=35.0), tech, params)
    finally:
        r.release()
    from terrascape.render.techniques import get_technique

    # only techniques with heavy per-pixel shading take the deferred path
    assert stats.get("deferred", 0) == int(get_technique(tech).deferred)
    diff = np.abs(deferred.astype(int) - forward.astype(int)).max(-1)
    # The same surface attributes per pixel; only the texture level of detail differs: its
    # derivatives come from neighbouring pixels here, from each tiny triangle's own plane
    # in forward shading (this 257² map puts several triangles in every pixel).
    assert diff.mean() < 1.0
    assert np.percentile(diff, 99) <= 16
    assert (diff > 16).mean() < 0.02
    assert (diff == 0).mean() > 0.8


@pytest.mark.parametrize("lighting", ["daylight", "vertex"])
def test_deferred_frames_without_sky_keep_the_background_of_forward_frames(gl_ctx, lighting):
    """No sky drawn: the pixels without terrain keep the frame's clear (horizon) colour in a
    deferred frame as in a forward one; the deferred pass's depth copy must not write colour
    (it once painted them black)."""
    r = OffscreenRenderer(gl_ctx, _far_terrain(side=65), size=(160, 90), deferred_shading=True,
                          small_triangle_cull=True)
    try:
        cam = Camera.look_at((-10, 30, -10), (32, 5, 32), fov_y=50, aspect=16 / 9)
        params = {"sky": False, "lighting": lighting}
        deferred = r.render(cam, "material", params)
        assert r.terrain.last_stats["deferred"] == 1
        depth = r.last_depth()
        forward = r.render(cam, "plain", params)
        assert "deferred" not in r.terrain.last_stats
    finally:
        r.release()
    background = depth >= 1.0
    assert 0.1 < background.mean() < 0.9  # terrain and background both in the frame
    assert deferred[..., :3][background].max(-1).min() > 60  # never black
    np.testing.assert_array_equal(deferred[background], forward[background])


def test_deferred_shading_follows_the_technique_and_the_switch(gl_ctx):
    r = OffscreenRenderer(gl_ctx, _far_terrain(side=65), size=(160, 90), deferred_shading=True,
                          small_triangle_cull=True)
    try:
        cam = Camera.look_at((20, 40, 20), (32, 10, 32), fov_y=50, aspect=16 / 9)
        close = r.render(cam, "regions")  # close views too: one shading per pixel
        assert r.terrain.last_stats["deferred"] == 1
        r.render(cam, "plain")  # a cheap technique is shaded forward
        assert "deferred" not in r.terrain.last_stats
        r.terrain.set_indices(r.terrain.mesh.triangles)  # LOD triangulations as well
        assert np.array_equal(r.render(cam, "regions"), close)
        assert r.terrain.last_stats["deferred"] == 1
        r.terrain.deferred_shading = False
        forward = r.render(cam, "regions")
        assert "deferred" not in r.terrain.last_stats
        # the same shading; texture LOD from neighbouring pixels instead of each small far
        # triangle's own plane: a level or two off over the far distance, nothing visible
        diff = np.abs(forward.astype(int) - close.astype(int)).max(-1)
        assert diff.mean() < 1.5 and (diff > 16).mean() < 0.02 and (diff == 0).mean() > 0.6
    finally:
        r.release()


def test_small_triangle_cull_on_a_map_of_odd_size(gl_ctx, rng):
    # 300×211 vertices: edge chunks of 44 and 83 rows/cols, bands cut short at the edges
    from scipy.ndimage import gaussian_filter

    h = gaussian_filter(rng.random((211, 300)), 3).astype(np.float32) * 40.0
    r = OffscreenRenderer(gl_ctx, Heightmap(h), size=(120, 80))
    try:
        (culled, stats), (full, _) = _on_and_off(
            r, "small_triangle_cull", r.default_camera(elevation=35.0), "plain")
    finally:
        r.release()
    np.testing.assert_array_equal(culled, full)
    assert stats["chunks_small_cull"] > 0
    assert stats["triangles_drawn"] < stats["triangles"]
