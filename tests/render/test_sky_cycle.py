"""The sky and the light through a day on the GPU: noon, sunset, night with stars and moon."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from terrascape.camera import Camera
from terrascape.heightmap import Heightmap
from terrascape.lighting.daylight import daylight
from terrascape.lighting.solar_position import sky_at
from terrascape.lighting.sun import sun_direction
from terrascape.render.offscreen import OffscreenRenderer

pytestmark = pytest.mark.gl

SIZE = (160, 96)
LUMA = np.array([0.2126, 0.7152, 0.0722])


@pytest.fixture(scope="module")
def hills():
    y, x = np.mgrid[0:65, 0:65] / 64.0
    h = 6.0 * np.sin(3.0 * x) * np.cos(2.0 * y) + 4.0 * np.sin(5 * y + 1.0)
    return Heightmap((h - h.min()).astype(np.float32), (4.0, 4.0))


def _sky_camera(hm, azimuth: float, pitch: float = 20.0, fov: float = 60.0) -> Camera:
    """Standing above the terrain's centre, looking toward ``azimuth`` ``pitch``° up."""
    ex, ez = hm.extent
    eye = np.array([ex / 2, hm.max + 30.0, ez / 2])
    return Camera.look_at(eye, eye + 100.0 * sun_direction(azimuth, pitch), fov_y=fov,
                          aspect=SIZE[0] / SIZE[1], near=0.5, far=2000.0)


def _render(ctx, hm, cam, params, technique="plain"):
    r = OffscreenRenderer(ctx, hm, size=SIZE)
    try:
        return r.render(cam, technique, {"haze": 0.0, **params})[..., :3].astype(np.float64)
    finally:
        r.release()


def _rays(cam: Camera, size) -> np.ndarray:
    w, h = size
    xs = (np.arange(w) + 0.5) / w * 2 - 1
    ys = 1 - (np.arange(h) + 0.5) / h * 2
    xx, yy = np.meshgrid(xs, ys)
    inv = np.linalg.inv(cam.view_projection())
    def unproject(z):
        p = np.stack([xx, yy, np.full_like(xx, z), np.ones_like(xx)], -1) @ inv.T
        return p[..., :3] / p[..., 3:]
    d = unproject(1.0) - unproject(-1.0)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def test_sky_table_matches_the_analytic_sky(gl_ctx, hills):
    """The sky sampled from its radiance table equals the Preetham model evaluated per
    pixel on the CPU (display values, within 2 levels in 99 % of the sky)."""
    cam = _sky_camera(hills, 100.0, pitch=35.0)
    img = _render(gl_ctx, hills, cam, {"sun": (120.0, 30.0)})
    day = daylight(120.0, 30.0)
    rays = _rays(cam, SIZE)
    up = rays[..., 1] > 0.02
    ref = day.display(day.sky_radiance(rays[up])) * 255.0
    diff = np.abs(img[up] - ref).max(axis=-1)
    disc = rays[up] @ day.sun_dir > np.cos(np.radians(1.0))
    assert np.quantile(diff[~disc], 0.99) <= 2.0, np.quantile(diff, [0.5, 0.99, 1.0])


def test_noon_sky_is_blue_and_sunset_is_warmer_toward_the_sun(gl_ctx, hills):
    noon = sky_at("2026-06-21T12:00", 45.8, 16.0)
    img = _render(gl_ctx, hills, _sky_camera(hills, 0.0, pitch=30.0), {"sun": noon.sun,
                                                                       "sky_state": noon})
    top = img[:20].reshape(-1, 3).mean(0)
    assert top[2] > top[1] > top[0] and top[2] > 150
    dusk = sky_at("2026-06-21T19:45", 45.8, 16.0)
    assert -1.0 < dusk.sun_elevation < 2.0
    toward = _render(gl_ctx, hills, _sky_camera(hills, dusk.sun_azimuth, pitch=8.0),
                     {"sun": dusk.sun, "sky_state": dusk})
    away = _render(gl_ctx, hills, _sky_camera(hills, dusk.sun_azimuth + 180.0, pitch=8.0),
                   {"sun": dusk.sun, "sky_state": dusk})
    def warmth(im):
        band = im[30:60].reshape(-1, 3).mean(0)  # just above the horizon
        return band[0] / band[2]
    assert warmth(toward) > warmth(away) + 0.1, (warmth(toward), warmth(away))


@pytest.fixture(scope="module")
def night_images(gl_ctx, hills):
    state = sky_at("2026-06-21T23:30", 45.8, 16.0)
    assert state.sun_elevation < -18.0
    cam = _sky_camera(hills, 0.0, pitch=25.0, fov=70.0)
    params = {"sun": state.sun, "sky_state": state, "seed": 3}
    a = _render(gl_ctx, hills, cam, params)
    b = _render(gl_ctx, hills, cam, params)
    c = _render(gl_ctx, hills, cam, {**params, "seed": 4})
    return a, b, c


def test_night_sky_is_dark_blue_with_deterministic_stars(night_images):
    a, b, c = night_images
    sky = a[:40]
    median = np.median(sky.reshape(-1, 3), axis=0)
    assert median[2] > median[0] and median[2] > median[1]
    assert 0 < median @ LUMA < 60
    lum = sky @ LUMA
    peaks = (lum == ndimage.maximum_filter(lum, size=5)) & (lum > np.median(lum) + 25)
    assert 15 <= peaks.sum() <= 600, peaks.sum()
    assert np.array_equal(a, b)  # still renders do not twinkle
    assert not np.array_equal(a[:40], c[:40])  # the seed places the stars


def test_terrain_at_night_is_dim_blue_grey_not_black(gl_ctx, hills):
    state = sky_at("2026-06-21T23:30", 45.8, 16.0)
    ex, ez = hills.extent
    cam = Camera.look_at((ex / 2, hills.max + 200.0, ez / 2 + 1.0), (ex / 2, 0.0, ez / 2),
                         fov_y=30.0, aspect=SIZE[0] / SIZE[1], near=1.0, far=2000.0)
    grey = np.full((*hills.shape, 3), 150, np.uint8)
    params = {"sun": state.sun, "sky_state": state, "textures": {"u_color_tex": grey}}
    img = _render(gl_ctx, hills, cam, params)
    mean = img.reshape(-1, 3).mean(0)
    assert mean @ LUMA > 12  # not pitch black
    assert mean[2] >= mean[0]  # blue-grey, not brown
    day = _render(gl_ctx, hills, cam, {**params, "sky_state": sky_at("2026-06-21T12:00", 45.8)})
    assert mean @ LUMA < 0.6 * day.reshape(-1, 3).mean(0) @ LUMA


def test_moon_disc_shows_its_phase(gl_ctx, hills):
    # 2024-04-16 21:00 UTC at 45.8 N 16 E: a waxing gibbous moon (~62 % lit) in the south.
    import datetime as dt

    state = sky_at(dt.datetime(2024, 4, 16, 21, 0, tzinfo=dt.UTC), 45.8, 16.0)
    assert state.sun_elevation < -10 and state.moon_elevation > 20
    cam = _sky_camera(hills, state.moon_azimuth, pitch=state.moon_elevation, fov=4.0)
    img = _render(gl_ctx, hills, cam, {"sun": state.sun, "sky_state": state})
    lum = img @ LUMA
    bright = lum > 0.5 * lum.max()
    assert lum.max() > 150
    # the lit part covers part of a disc: fewer pixels than the whole disc would
    radius_px = 0.6 / 4.0 * SIZE[1]
    frac = bright.sum() / (np.pi * radius_px**2)
    assert 0.3 < frac < 0.9, frac
