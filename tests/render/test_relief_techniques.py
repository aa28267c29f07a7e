"""Relief techniques registered into the terrain renderer (planar-mapped, tiled)."""

import warnings

import numpy as np
import pytest

from terrascape.camera import Camera
from terrascape.generate import diamond_square

pytestmark = pytest.mark.gl

NAMES = ["parallax", "parallax_limited", "steep_parallax", "pom", "relief", "interval",
         "relief_by_distance", "cone", "minmax"]


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
    # The seed's city field: walls and flat roofs make displacement and shadows unmistakable.
    base = {"relief_size": 64, "uv_scale": 4.0, "fog_density": 0.0, "sky": False,
            "relief_field": "city"}
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


def test_terrain_relief_defaults_to_a_natural_field(terrain):
    from terrascape.relief.fields import natural_field
    from terrascape.render.relief_techniques import RELIEF_DEFAULTS, _relief_heights

    assert RELIEF_DEFAULTS["relief_field"] == "natural"
    params = {"relief_field": "natural", "relief_size": 64, "seed": 0}
    np.testing.assert_array_equal(_relief_heights(params), natural_field(64, seed=0))
    natural = _draw(terrain, "relief", depth=0.08, relief_field=RELIEF_DEFAULTS["relief_field"])
    city = _draw(terrain, "relief", depth=0.08)
    assert np.abs(natural.astype(int) - city.astype(int)).max() > 30
    photo = _draw(terrain, "relief", depth=0.08, relief_field="photo")
    assert photo[..., :3].std() > 5


def test_relief_field_validation(terrain):
    from terrascape.errors import InvalidParameterError

    with pytest.raises(InvalidParameterError, match="relief_field"):
        _draw(terrain, "relief", relief_field="bricks")


def test_cone_on_terrain_agrees_with_relief_and_is_not_flat(terrain):
    # Cone stepping and relief 16+8 trace the same surface: they agree on most pixels,
    # and both differ clearly from the undisplaced texture.
    relief = _draw(terrain, "relief", depth=0.08, self_shadow=False).astype(int)
    cone = _draw(terrain, "cone", depth=0.08, self_shadow=False, cone_steps=64).astype(int)
    flat = _draw(terrain, "relief", depth=1e-4, self_shadow=False).astype(int)
    close = (np.abs(cone - relief)[..., :3].max(axis=-1) <= 12).mean()
    moved = (np.abs(cone - flat)[..., :3].max(axis=-1) > 8).mean()
    assert close > 0.85 and moved > 0.2, (close, moved)


def test_minmax_on_terrain_uses_its_mip_chain_and_agrees_with_relief(terrain):
    # The exact tracer and relief 16+8 (close to exact at these angles) see the same surface;
    # a broken pyramid (e.g. levels uniform or mip chain missing) would leave it flat.
    relief = _draw(terrain, "relief", depth=0.08, self_shadow=False).astype(int)
    exact = _draw(terrain, "minmax", depth=0.08, self_shadow=False).astype(int)
    flat = _draw(terrain, "relief", depth=1e-4, self_shadow=False).astype(int)
    close = (np.abs(exact - relief)[..., :3].max(axis=-1) <= 12).mean()
    moved = (np.abs(exact - flat)[..., :3].max(axis=-1) > 8).mean()
    assert close > 0.8 and moved > 0.2, (close, moved)
    r = terrain[0]
    assert r._mip_levels["u_minmax"] == 7  # 64² relief texture: 64, 32, …, 1


def test_unavailable_technique_falls_back_to_plain_with_one_warning(terrain):
    """A program this GL cannot compile renders as plain texturing, warning once."""
    from terrascape.render.techniques import Technique, TechniqueFallbackWarning, get_technique

    relief = get_technique("relief")
    broken = Technique("broken_for_test", "relief/terrain", textures=relief.textures,
                       defaults=relief.defaults, defines={"TECHNIQUE": "1 +"},
                       description="does not compile")  # passed directly, not registered
    r = terrain[0]
    with pytest.warns(TechniqueFallbackWarning, match="broken_for_test"):
        first = _draw(terrain, broken)
    assert r.drawn_technique == "plain"
    assert r.drawn.requested == "broken_for_test" and r.drawn.fell_back
    assert "compile" in r.drawn.reason
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the second frame does not warn again
        second = _draw(terrain, broken)
    r, fbo, cam, size = terrain
    r.render(fbo, cam, "plain", {"uv_scale": 4.0, "fog_density": 0.0, "sky": False})
    expected = np.frombuffer(fbo.read(components=4), np.uint8).reshape(size[1], size[0], 4)
    assert np.array_equal(first, expected) and np.array_equal(second, expected)


def test_explicit_mip_chain_is_validated():
    from terrascape.errors import InvalidParameterError
    from terrascape.render.techniques import TextureData
    from terrascape.render.terrain import as_texture_data

    base = np.zeros((8, 8, 2), np.float32)
    good = TextureData(base, levels=(np.zeros((4, 4, 2), np.float32),
                                     np.zeros((2, 2, 2), np.float32)))
    assert len(as_texture_data(good).levels) == 2
    with pytest.raises(InvalidParameterError, match="mip level 1"):
        as_texture_data(TextureData(base, levels=(np.zeros((3, 4, 2), np.float32),)))
