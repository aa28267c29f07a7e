"""Relief techniques registered into the terrain renderer (planar-mapped, tiled)."""

import numpy as np
import pytest

from terrascape.camera import Camera
from terrascape.generate import diamond_square

pytestmark = pytest.mark.gl

NAMES = ["parallax", "parallax_limited", "steep_parallax", "pom", "relief", "interval",
         "relief_by_distance"]


def test_relief_techniques_are_registered():
    from terrascape.render.techniques import get_technique, technique_names

    for name in NAMES:
        assert name in technique_names()
        tech = get_technique(name)
        assert tech.program == "relief/terrain"
        assert {"depth", "linear_steps", "binary_steps", "self_shadow"} <= set(
            tech.parameters()
        )


@pytest.fixture(scope="module")
def terrain(gl_ctx):
    from terrascape.render.terrain import TerrainRenderer

    hm = diamond_square(33, seed=3, roughness=0.3)
    r = TerrainRenderer(gl_ctx, hm)
    size = (96, 64)
    fbo = gl_ctx.framebuffer([gl_ctx.texture(size, 4)], gl_ctx.depth_renderbuffer(size))
    # Close, oblique view so relief texels cover several pixels.
    cam = Camera.look_at((4.0, 6.0, 4.0), (12.0, 0.0, 12.0), aspect=1.5, fov_y=50)
    yield r, fbo, cam, size
    fbo.release()
    r.release()


def _draw(terrain, technique, **params):
    r, fbo, cam, size = terrain
    base = {"relief_size": 64, "uv_scale": 4.0, "fog_density": 0.0, "sky": False}
    r.render(fbo, cam, technique, {**base, **params})
    return np.frombuffer(fbo.read(components=4), np.uint8).reshape(size[1], size[0], 4)


def test_relief_on_terrain_differs_from_flat_and_follows_parameters(terrain):
    flat = _draw(terrain, "relief", depth=1e-4, self_shadow=False)
    deep = _draw(terrain, "relief", depth=0.08, self_shadow=False)
    shadowed = _draw(terrain, "relief", depth=0.08, self_shadow=True)
    diff = np.abs(deep.astype(int) - flat.astype(int))[..., :3]
    assert (diff.max(axis=-1) > 8).mean() > 0.2  # the displacement moves the city blocks
    assert shadowed[..., :3].astype(int).sum() < deep[..., :3].astype(int).sum()
    for name in ("parallax", "parallax_limited", "pom", "interval", "relief_by_distance"):
        img = _draw(terrain, name, depth=0.08)
        assert img[..., :3].std() > 5


def test_relief_field_validation(terrain):
    from terrascape.errors import InvalidParameterError

    with pytest.raises(InvalidParameterError, match="relief_field"):
        _draw(terrain, "relief", relief_field="bricks")
