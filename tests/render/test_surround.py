"""Beyond the terrain's edge: haze by default without a sea, the plane in the colour of the
terrain's lowest ground."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape.camera import Camera
from terrascape.heightmap import Heightmap
from terrascape.lighting.daylight import daylight
from terrascape.render.offscreen import OffscreenRenderer
from terrascape.texture.terrain_material import lowest_ground_albedo, lowest_ground_texture

pytestmark = pytest.mark.gl

SUN = (135.0, 30.0)


@pytest.fixture(scope="module")
def far_view(gl_ctx):
    """A small flat terrain seen from far away, looking away from it and 10° down: the
    lower half of the frame is what lies beyond the terrain."""
    hm = Heightmap(np.zeros((33, 33), np.float32))
    r = OffscreenRenderer(gl_ctx, hm, size=(64, 96))
    cam = Camera(position=(-200.0, 20.0, -200.0), yaw=225.0, pitch=-10.0, fov_y=40.0,
                 aspect=64 / 96, near=0.5, far=5000.0)

    def render(**params):
        return r.render(cam, "plain", {"sun": SUN, **params})[..., :3].astype(int)

    yield hm, render
    r.release()


def test_default_without_a_sea_is_haze(far_view):
    _, render = far_view
    default = render()
    assert np.array_equal(default, render(surround="fade"))
    assert np.abs(default - render(surround="plane"))[-20:].mean() > 3


def test_plane_has_the_colour_of_the_lowest_ground(far_view):
    hm, render = far_view
    img = render(surround="plane", haze=0.0)  # no haze: the ground's own colour
    albedo = lowest_ground_albedo(hm)
    # a flat terrain's lowest ground is grass/meadow: green over red over blue
    assert albedo[1] > albedo[0] > albedo[2]
    day = daylight(*SUN)
    radiance = albedo * day.surface_irradiance(np.array([0.0, 1.0, 0.0])) / np.pi
    expected = np.round(day.display(radiance) * 255.0)
    bottom = img[-12:].reshape(-1, 3)
    # textured ground (hex-tiled photo material) whose mean is that colour
    assert np.abs(bottom.mean(axis=0) - expected).max() <= 4
    assert bottom.std(axis=0).min() > 1.0


@pytest.fixture(scope="module")
def border_view(gl_ctx):
    """A flat terrain (its edge at the plane's height) seen from outside, 20° down across
    its near edge, which crosses the frame at row ``border``."""
    hm = Heightmap(np.zeros((65, 65), np.float32), (2.0, 2.0))
    r = OffscreenRenderer(gl_ctx, hm, size=(160, 120))
    cam = Camera.look_at((64.0, 30.0, -60.0), (64.0, 0.0, 20.0), fov_y=50.0, aspect=160 / 120)
    clip = cam.view_projection() @ np.array([64.0, 0.0, 0.0, 1.0])
    border = round((0.5 - 0.5 * clip[1] / clip[3]) * 120)

    def luminance(**params):
        img = r.render(cam, "material", {"sun": SUN, **params})[..., :3].astype(float)
        return img @ np.array([0.2126, 0.7152, 0.0722])

    yield border, luminance
    r.release()


def test_plane_is_textured_land_without_a_seam(border_view):
    border, luminance = border_view
    plane = luminance(surround="plane")
    outside = plane[border + 4:border + 30, 30:130]
    # a texture, not a flat colour: the hex-tiled photo ground varies from pixel to pixel
    assert outside.std(axis=1).mean() > 2.0
    rows = plane[:, 30:130].mean(axis=1)
    jumps = np.abs(np.diff(rows[border - 6:border + 6]))
    assert jumps.max() < 8.0
    inside = rows[border - 8:border - 2].mean()
    assert abs(rows[border + 2:border + 8].mean() - inside) < 10.0
    # the haze surround meets the same border with a jump: the test sees seams
    fade = luminance(surround="fade")[:, 30:130].mean(axis=1)
    assert np.abs(np.diff(fade[border - 6:border + 6])).max() > 30.0


def test_lowest_ground_texture_blends_the_layers_to_the_ground_albedo():
    hm = Heightmap(np.linspace(0.0, 40.0, 33 * 33, dtype=np.float32).reshape(33, 33))
    tex = lowest_ground_texture(hm, material_size=64)
    assert tex.shape == (64, 64, 4) and tex.dtype == np.uint8
    srgb = tex[..., :3].reshape(-1, 3) / 255.0
    linear = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)
    np.testing.assert_allclose(linear.mean(axis=0), lowest_ground_albedo(hm), rtol=0.03)
    assert srgb.std(axis=0).min() > 0.01  # a photo texture, not a flat colour
    assert np.array_equal(tex, lowest_ground_texture(hm, material_size=64))  # deterministic
