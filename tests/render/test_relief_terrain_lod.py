"""Screen-space level of detail of the terrain relief march (relief/terrain.glsl, relief_lod):
the same image as relief 16+8 where the relief texture is magnified, within a few colour
levels where it is minified, for fewer height fetches."""

import numpy as np
import pytest

from terrascape.camera import Camera, frame_terrain
from terrascape.generate import diamond_square

pytestmark = pytest.mark.gl

# The LOD's bounds were measured on the seed's city field (the terrain default is natural).
# The LOD decisions are compared pixel for pixel: under vertex lighting, so the daylight
# model's tone curve does not turn a last-bit difference of the unlit colour into a code.
BASE = {"relief_size": 64, "fog_density": 0.0, "sky": False, "self_shadow": False,
        "depth": 0.08, "relief_field": "city", "lighting": "vertex"}


@pytest.fixture(scope="module")
def scene(gl_ctx):
    from terrascape.render.terrain import TerrainRenderer

    hm = diamond_square(33, seed=3, roughness=0.3)
    r = TerrainRenderer(gl_ctx, hm)
    size = (128, 80)
    fbo = gl_ctx.framebuffer([gl_ctx.texture(size, 4)], gl_ctx.depth_renderbuffer(size))
    yield r, fbo, size, hm
    fbo.release()
    r.release()


def _draw(scene, cam, technique, **params):
    r, fbo, size, _ = scene
    r.render(fbo, cam, technique, {**BASE, **params})
    return np.frombuffer(fbo.read(components=4), np.uint8).reshape(size[1], size[0], 4)


def _fetches(scene, cam, **params):
    """(height fetches, mip level, terrain mask) per pixel."""
    from terrascape.render.relief_techniques import relief_variant

    img = _draw(scene, cam, relief_variant("relief", TERRAIN_OUTPUT_FETCHES=1), **params)
    return img[..., 0].astype(int), img[..., 1] / 255.0 * 16.0, img[..., 2] == 255


def test_height_texture_is_the_alpha_channel_of_the_relief_texture():
    from terrascape.render.relief_techniques import build_relief_height, build_relief_texture
    from terrascape.render.terrain import as_texture_data

    params = {"relief_field": "natural", "relief_size": 32, "seed": 0, "depth": 0.05}
    rgba = as_texture_data(build_relief_texture(None, params)).data
    height = as_texture_data(build_relief_height(None, params)).data
    assert height.shape == (32, 32, 1)
    assert np.array_equal(height[..., 0], rgba[..., 3])


def test_lod_equals_full_relief_where_the_texture_is_magnified(scene):
    # Close, oblique view: most relief texels cover several pixels (mip level <= 0).
    cam = Camera.look_at((4.0, 6.0, 4.0), (12.0, 0.0, 12.0), aspect=1.6, fov_y=50)
    full = _draw(scene, cam, "relief", uv_scale=2.0, relief_lod=False)
    lod = _draw(scene, cam, "relief", uv_scale=2.0)  # the default
    _, level, terrain = _fetches(scene, cam, uv_scale=2.0)
    magnified = terrain & (level == 0.0)
    assert magnified.mean() > 0.3
    assert np.array_equal(full[magnified], lod[magnified])


def test_lod_stays_close_to_full_relief_where_minified_with_fewer_fetches(scene):
    hm = scene[3]
    cam = frame_terrain(hm.extent, (hm.min, hm.max), azimuth=210.0, elevation=35.0,
                        aspect=1.6)
    # Relief texels of mip level ~3.6, rays of a few pixels: the LOD march does run.
    # Phong lighting as before the daylight default: the bounds below are on the relief
    # march, and daylight's filmic curve is steeper in the mid-tones where it differs.
    params = {"uv_scale": 8.0, "relief_field": "city", "depth": 0.2, "lighting": "vertex"}
    full = _draw(scene, cam, "relief", relief_lod=False, **params).astype(int)
    lod = _draw(scene, cam, "relief", **params).astype(int)  # the default
    n_full, level, terrain = _fetches(scene, cam, relief_lod=False, **params)
    n_lod, _, _ = _fetches(scene, cam, **params)
    assert terrain.mean() > 0.2 and np.median(level[terrain]) > 2.0  # minified
    diff = np.abs(full - lod)[..., :3].max(axis=-1)[terrain]
    assert diff.mean() < 1.5 and np.percentile(diff, 99) <= 6, (diff.mean(), diff.max())
    assert (diff > 4).mean() < 0.01
    # relief 16+8 pays ~19 fetches a pixel here; rays of a few mip-level texels need ~3.
    assert 2.0 < n_lod[terrain].mean() < 0.3 * n_full[terrain].mean()
    # ... and the displacement is still there: far from the undisplaced texture.
    from terrascape.render.relief_techniques import relief_variant

    flat = _draw(scene, cam, relief_variant("relief", TECHNIQUE=0), **params).astype(int)
    moved = np.abs(flat - full)[..., :3].max(axis=-1)[terrain]
    assert (moved > 4).mean() > 0.5


def test_parallax_lod_skips_only_sub_pixel_shifts(scene):
    hm = scene[3]
    cam = frame_terrain(hm.extent, (hm.min, hm.max), azimuth=210.0, elevation=35.0,
                        aspect=1.6)
    # Shifts of a few pixels: the LOD keeps parallax as it is (trilinear height fetch) ...
    wide = {"uv_scale": 4.0, "parallax_scale": 0.08, "parallax_bias": -0.08}
    full = _draw(scene, cam, "parallax", relief_lod=False, **wide)
    assert np.array_equal(full, _draw(scene, cam, "parallax", lod_nearest_from=-1.0, **wide))
    # ... and with the default nearest mip far away, within a few levels.
    _, level, terrain = _fetches(scene, cam, **wide)
    assert (level[terrain] >= 3.0).mean() > 0.2
    diff = np.abs(full.astype(int) - _draw(scene, cam, "parallax", **wide))[..., :3]
    diff = diff.max(axis=-1)[terrain]
    assert diff.mean() < 1.0 and (diff > 4).mean() < 0.01, (diff.mean(), (diff > 4).mean())
    # A shift far below a pixel: LOD draws the unshifted texture (no height fetch).
    tiny = {"uv_scale": 64.0, "parallax_scale": 1e-5, "parallax_bias": -1e-5, "depth": 0.08}
    lod = _draw(scene, cam, "parallax", **tiny).astype(int)
    from terrascape.render.relief_techniques import relief_variant

    flat = _draw(scene, cam, relief_variant("parallax", TECHNIQUE=0), **tiny).astype(int)
    assert np.abs(lod - flat).max() == 0
