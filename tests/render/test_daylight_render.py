"""The daylight look on the GPU, checked against CPU evaluations: per-pixel shadows where the
CPU shadow sweep puts them, no black shadows, a sky without creases, water exactly below the
sea level, the world continuing beyond the terrain, supersampling."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape.camera import Camera
from terrascape.generate import diamond_square
from terrascape.heightmap import Heightmap
from terrascape.lighting.shadows import soft_shadow
from terrascape.render.atmosphere import sea_level_note
from terrascape.render.offscreen import OffscreenRenderer, downsample_srgb

pytestmark = pytest.mark.gl

SIZE = (128, 128)
LUMA = np.array([0.2126, 0.7152, 0.0722])


def _overhead(extent, height):
    cx, cz = extent[0] / 2, extent[1] / 2
    return Camera.look_at((cx, height, cz), (cx, 0.0, cz), fov_y=30.0, near=1.0,
                          far=height * 3, aspect=1.0)


def _pixels_of_samples(cam, hm: Heightmap, y):
    """Pixel (row, col) of every grid sample at height(s) ``y`` (grid, h × w)."""
    zz, xx = np.meshgrid(np.arange(hm.rows) * hm.spacing[1], np.arange(hm.cols) * hm.spacing[0],
                         indexing="ij")
    yy = np.broadcast_to(np.asarray(y, dtype=np.float64), xx.shape)
    p = cam.project(np.stack([xx, yy, zz], -1).reshape(-1, 3), SIZE)
    col = np.floor(p[:, 0]).astype(int).reshape(hm.shape)
    row = np.floor(p[:, 1]).astype(int).reshape(hm.shape)
    inside = (row >= 0) & (row < SIZE[1]) & (col >= 0) & (col < SIZE[0])
    return np.clip(row, 0, SIZE[1] - 1), np.clip(col, 0, SIZE[0] - 1), inside


@pytest.fixture(scope="module")
def wall():
    """A flat 97² plain with a north–south wall: the sun in the east casts its shadow west."""
    h = np.zeros((97, 97), np.float32)
    h[:, 60:63] = 12.0
    return Heightmap(h)


def test_shadow_pixels_coincide_with_the_cpu_shadow_sweep(gl_ctx, wall):
    r = OffscreenRenderer(gl_ctx, wall, size=SIZE)
    cam = _overhead(wall.extent, 260.0)
    grey = np.full((*wall.shape, 3), 150, np.uint8)
    common = {"sun": (90.0, 18.0), "sky": False, "haze": 0.0, "textures": {"u_color_tex": grey}}
    try:
        lit = r.render(cam, "plain", {**common, "shadows": False})[..., :3]
        shaded = r.render(cam, "plain", common)[..., :3]
    finally:
        r.release()
    vis = soft_shadow(wall, 90.0, 18.0, sun_radius_deg=0.5, samples=6)
    row, col, inside = _pixels_of_samples(cam, wall, wall.heights)
    ratio = (shaded @ LUMA + 1) / (lit @ LUMA + 1)
    gpu_dark = ratio[row, col] < 0.8
    # away from the penumbra edge (two samples), on the plain (not the wall itself)
    from scipy import ndimage

    cpu_dark = vis < 0.5
    core = ~(ndimage.binary_dilation(cpu_dark, iterations=2)
             & ndimage.binary_dilation(~cpu_dark, iterations=2))
    keep = inside & core & (wall.heights == 0)
    assert cpu_dark[keep].mean() > 0.1  # a real shadow in view
    agree = (gpu_dark == cpu_dark)[keep].mean()
    assert agree > 0.99, agree
    # shadowed pixels keep the blue sky light: not black, bluer than the sunlit ground
    sh = shaded[row[keep & cpu_dark], col[keep & cpu_dark]].astype(int)
    sun = shaded[row[keep & ~cpu_dark], col[keep & ~cpu_dark]].astype(int)
    assert sh.max(axis=1).min() > 30
    assert (sh[:, 2] - sh[:, 0]).mean() > (sun[:, 2] - sun[:, 0]).mean() + 5


def test_default_render_has_no_black_pixels(gl_ctx):
    hm = diamond_square(129, seed=5)
    r = OffscreenRenderer(gl_ctx, hm, size=SIZE, exaggeration=30.0)
    try:
        for sun in ((135.0, 10.0), (135.0, 50.0)):
            img = r.render(None, "plain", {"sun": sun})[..., :3].astype(int)
            assert img.max(axis=-1).min() > 20, sun
    finally:
        r.release()


def _sky_profile(gl_ctx, pitch, surround):
    hm = Heightmap(np.zeros((9, 9), np.float32))
    r = OffscreenRenderer(gl_ctx, hm, size=(64, 256))
    # far from the tiny terrain, looking away from the sun (the sun is in the south-east)
    cam = Camera(position=(4.0, 50.0, 4.0), yaw=315.0, pitch=pitch, fov_y=60.0,
                 aspect=0.25, near=0.5, far=100.0)
    try:
        img = r.render(cam, "plain", {"sun": (135.0, 30.0), "surround": surround})
    finally:
        r.release()
    return img[..., :3].astype(np.float64) @ LUMA


def test_sky_rows_are_monotone_without_a_kink(gl_ctx):
    # horizon in the middle of the frame; with "fade" the sky continues below it
    lum = _sky_profile(gl_ctx, 10.0, "fade")[:, 32]
    d = np.diff(lum)
    assert lum[-1] - lum[0] > 15  # brighter toward the horizon
    assert d.min() >= -1.0  # monotone up to 8-bit rounding
    # second differences: nowhere a crease beyond rounding (the old sky had one at the horizon)
    smooth = np.convolve(lum, np.ones(5) / 5, mode="valid")
    assert np.abs(np.diff(smooth, 2)).max() < 0.6


def test_nothing_empty_below_the_horizon(gl_ctx):
    """With the plane surround (a plane at the lowest height) the ground reaches the
    horizon: below it no pixel shows the sky."""
    fade = _sky_profile(gl_ctx, 10.0, "fade")
    plane = _sky_profile(gl_ctx, 10.0, "plane")
    rows = fade.shape[0]
    # horizon at row rows/2 - tan(10°)/tan(30°)·rows/2 (pitch up 10° in a 60° view)
    horizon = int(rows / 2 + np.tan(np.radians(10)) / np.tan(np.radians(30)) * rows / 2)
    above, below = slice(0, horizon - 4), slice(horizon + 8, rows)
    np.testing.assert_allclose(plane[above], fade[above], atol=1.0)  # the same sky
    assert (np.abs(plane[below] - fade[below]) > 3).all()  # ground, not sky


def test_default_camera_has_no_gap_to_the_horizon(gl_ctx):
    hm = diamond_square(129, seed=2)
    r = OffscreenRenderer(gl_ctx, hm, size=(160, 90), exaggeration=25.0)
    try:
        img = r.render(None, "plain", {"sky": False, "fog_color": (1.0, 0.0, 1.0),
                                       "fog_density": 0.0})
        day = r.render(None, "plain")
    finally:
        r.release()
    # sky=False: the clear colour (magenta) where nothing at all is drawn; with the sky pass
    # (default), every pixel is drawn: terrain, the surround plane or the sky
    empty = (img[..., 0] == 255) & (img[..., 1] == 0) & (img[..., 2] == 255)
    assert empty.any()  # the terrain alone does not fill the frame
    assert not ((day[..., 0] == 255) & (day[..., 1] == 0) & (day[..., 2] == 255)).any()


def _bowl():
    y, x = np.mgrid[0:65, 0:65].astype(np.float32)
    return Heightmap(((x - 32) ** 2 + (y - 32) ** 2) / 40.0)  # 0 in the middle, ~51 at corners


def test_water_exactly_below_the_sea_level(gl_ctx):
    hm = _bowl()
    sea = 12.0
    r = OffscreenRenderer(gl_ctx, hm, size=SIZE)
    cam = _overhead(hm.extent, 250.0)
    common = {"sun": (135.0, 40.0), "sky": False, "haze": 0.0}
    try:
        dry = r.render(cam, "plain", common)[..., :3].astype(int)
        wet = r.render(cam, "plain", {**common, "sea_level": sea})[..., :3].astype(int)
    finally:
        r.release()
    # > 6 codes: over the low ground the plain texture is itself water-blue, so the water
    # surface changes those pixels less than elsewhere
    changed = np.abs(wet - dry).max(-1) > 6
    h = hm.heights
    # where a sample is under water, its pixel is where the ray meets the water surface
    row, col, inside = _pixels_of_samples(cam, hm, np.minimum(h, sea))
    margin = 0.6  # heights within this of the shore line: the shore foam's width
    under, above = inside & (h < sea - margin), inside & (h > sea + margin)
    assert under.sum() > 200 and above.sum() > 200
    assert changed[row[under], col[under]].mean() > 0.99
    assert not changed[row[above], col[above]].any()


def test_sea_level_notes():
    hm = _bowl()
    assert sea_level_note(hm, None) is None and sea_level_note(hm, 10.0) is None
    assert "below the whole terrain" in sea_level_note(hm, -1.0)
    assert "above the whole terrain" in sea_level_note(hm, 1e3)


def test_water_depth_mask_draws_lakes(gl_ctx):
    hm = _bowl()
    depth = np.zeros(hm.shape, np.float32)
    depth[20:45, 20:45] = np.clip(8.0 - hm.heights[20:45, 20:45], 0.0, None)  # a lake
    r = OffscreenRenderer(gl_ctx, hm, size=SIZE)
    cam = _overhead(hm.extent, 250.0)
    common = {"sun": (135.0, 40.0), "sky": False, "haze": 0.0}
    try:
        dry = r.render(cam, "plain", common)[..., :3].astype(int)
        wet = r.render(cam, "plain", {**common, "water_depth": depth})[..., :3].astype(int)
    finally:
        r.release()
    changed = np.abs(wet - dry).max(-1) > 12
    surface = hm.heights + depth
    row, col, inside = _pixels_of_samples(cam, hm, surface)
    lake = inside & (depth > 0.6)
    land = inside & (depth == 0)
    from scipy import ndimage

    land &= ~ndimage.binary_dilation(depth > 0, iterations=2)
    assert lake.sum() > 100
    assert changed[row[lake], col[lake]].mean() > 0.98
    assert not changed[row[land], col[land]].any()


def test_high_quality_supersamples(gl_ctx):
    img = np.zeros((4, 6, 4), np.uint8)
    img[:2, :2] = 255
    out = downsample_srgb(img, 2)
    assert out.shape == (2, 3, 4)
    # mean in linear light: half white, half black → linear 0.5 → sRGB 188
    assert out[0, 0, 0] == 255 and out[0, 1, 0] == 0
    img[0, 0] = 0
    assert abs(int(downsample_srgb(img, 2)[0, 0, 0]) - 225) <= 1
    hm = diamond_square(65, seed=1)
    r = OffscreenRenderer(gl_ctx, hm, size=(64, 36), exaggeration=10.0, quality="high")
    try:
        assert r.fbo.size == (128, 72)
        assert r.render(None, "plain").shape == (36, 64, 4)
    finally:
        r.release()


def test_gpu_daylight_is_the_cpu_formula(gl_ctx):
    """A flat grey plane lit by the daylight model: the GPU pixel equals the CPU model's
    display value (same irradiance, exposure, tone curve and sRGB encoding)."""
    from terrascape.lighting.daylight import daylight, srgb_to_linear

    hm = Heightmap(np.zeros((17, 17), np.float32))
    grey = np.full((17, 17, 3), 150, np.uint8)
    r = OffscreenRenderer(gl_ctx, hm, size=(32, 32))
    cam = Camera.look_at((8.0, 40.0, 8.0), (8.0, 0.0, 8.0), fov_y=10.0, near=1.0, far=100.0,
                         aspect=1.0)
    try:
        for sun in ((135.0, 12.0), (200.0, 60.0)):
            img = r.render(cam, "plain", {"sun": sun, "sky": False, "haze": 0.0,
                                          "textures": {"u_color_tex": grey}})
            day = daylight(*sun)
            albedo = srgb_to_linear(np.full(3, 150 / 255.0))
            e = day.surface_irradiance(np.array([0.0, 1.0, 0.0]), 1.0, 1.0)
            want = np.rint(day.display(albedo * e / np.pi) * 255)
            got = img[8:24, 8:24, :3].reshape(-1, 3).astype(float)
            assert np.abs(got - want).max() <= 2, (sun, got.mean(0), want)
    finally:
        r.release()


def test_skirts_close_the_terrain_side(gl_ctx):
    """From beyond the edge, below the terrain's border, a daylight frame shows the
    terrain's side wall (down past its lowest point), not the clear colour under it."""
    h = np.full((17, 17), 10.0, np.float32)
    h[0, 0] = 0.0  # the lowest point, in the far corner: the skirts reach down to it
    hm = Heightmap(h)
    r = OffscreenRenderer(gl_ctx, hm, size=(64, 64))
    cam = Camera.look_at((8.0, 14.0, 60.0), (8.0, 5.0, 16.0), fov_y=40.0, near=0.5,
                         far=200.0, aspect=1.0)
    magenta = {"sky": False, "fog_color": (1.0, 0.0, 1.0), "fog_density": 0.0}
    try:
        day = r.render(cam, "plain", magenta)
        old = r.render(cam, "plain", {**magenta, "lighting": "vertex"})
    finally:
        r.release()
    top, bottom = cam.project([[8.0, 10.0, 16.0], [8.0, 0.5, 16.0]], (64, 64))[:, 1]
    rows = slice(int(top) + 2, int(bottom) - 1)
    assert bottom - top > 6

    def empty(img):
        return (img[rows, 32, 0] == 255) & (img[rows, 32, 1] == 0) & (img[rows, 32, 2] == 255)

    assert empty(old).all()  # without skirts: nothing below the border
    assert not empty(day).any()
