"""Beyond the terrain's edge: haze by default without a sea, the plane in the colour of the
terrain's lowest ground."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape.camera import Camera
from terrascape.heightmap import Heightmap
from terrascape.lighting.daylight import daylight
from terrascape.render.offscreen import OffscreenRenderer
from terrascape.texture.terrain_material import lowest_ground_albedo

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
    assert np.abs(bottom - expected).max() <= 3
