"""The default ``material`` technique and hex-tiled bump mapping on the GPU."""

from __future__ import annotations

import math

import numpy as np
import pytest

from terrascape.analysis.spectrum import radial_power_spectrum
from terrascape.camera import Camera
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.render.offscreen import OffscreenRenderer
from terrascape.render.techniques import get_technique, technique_names

pytestmark = pytest.mark.gl

SIZE = (256, 256)
N = 257  # flat plane, spacing 1 → 256 world units; material tile = 32 world units
FOV = 30.0
HEIGHT = 239.0  # 2·H·tan(15°) = 128 world units across 256 px: 2 px per world unit


def peak_ratio(image, period):
    """Power at ``1/period`` and harmonics over the median of nearby bands (see
    tests/texture/test_terrain_material.py): ≫ 3 for exact tiling, about 1 without."""
    grey = np.asarray(image, np.float64)[..., :3].mean(axis=-1)
    f, p = radial_power_spectrum(grey)
    best = 0.0
    for m in range(1, 5):
        target = m / period
        if target > 0.45:
            break
        k = int(np.argmin(np.abs(f - target)))
        if k < 10 or k + 11 > len(f):
            continue
        near = np.r_[p[k - 10:k - 1], p[k + 2:k + 11]]
        best = max(best, p[max(k - 1, 0):k + 2].max() / np.median(near))
    return best


def _overhead():
    return Camera.look_at((128.0, HEIGHT, 128.0), (128.0, 0.0, 128.0), fov_y=FOV, near=1.0,
                          far=1000.0, aspect=1.0)


@pytest.fixture(scope="module")
def plane(gl_ctx):
    r = OffscreenRenderer(gl_ctx, Heightmap(np.zeros((N, N), np.float32)), size=SIZE)
    yield r
    r.release()


def test_material_is_registered_with_its_parameters():
    assert "material" in technique_names()
    tech = get_technique("material")
    assert tech.program == "terrain/material"
    params = tech.parameters()
    for name in ("flow", "deposition", "wear", "water", "snow_line", "water_level",
                 "hex_rotation", "hex_contrast", "hex_sharpness", "blend_depth",
                 "detail_strength"):
        assert name in params


def test_default_material_render_has_no_texture_period(plane):
    img = plane.render(_overhead(), technique="material")
    px = 2.0 * 32.0  # pixels per material repeat
    assert img[..., :3].std() > 4  # textured, not flat
    assert peak_ratio(img, px) <= 3.0
    # the same view with plain wrap sampling (splat's layers wrapped) does show the period
    tiled = plane.render(_overhead(), technique="splat", params={"hex_tiling": False})
    assert peak_ratio(tiled, px) > 3.0
    assert np.array_equal(img, plane.render(_overhead(), technique="material"))


@pytest.mark.parametrize("technique", ["splat", "texture3d"])
def test_splat_and_texture3d_layers_show_no_tile_period(plane, technique):
    px = 2.0 * 32.0  # pixels per layer repeat (tile size 32 world units)
    hexed = plane.render(_overhead(), technique=technique)
    wrapped = plane.render(_overhead(), technique=technique, params={"hex_tiling": False})
    assert hexed[..., :3].std() > 3  # textured, not flat
    assert peak_ratio(wrapped, px) > 3.0  # the seed's wrapped layers repeat ...
    assert peak_ratio(hexed, px) <= 3.0  # ... hex-tiled they do not
    # the same colours: hex-tiling moves the texture around, it does not change it
    assert np.abs(hexed[..., :3].mean((0, 1)) - wrapped[..., :3].mean((0, 1))).max() < 6


def test_bump_detail_normals_have_no_grid_of_seams(plane):
    img = plane.render(_overhead(), technique="bump", params={"fog_density": 0.0})
    # v_uv repeats 16 times over 256 world units: 16 world units = 32 px
    assert img[..., :3].std() > 2
    assert peak_ratio(img, 32.0) <= 3.0


@pytest.fixture(scope="module")
def ramp(gl_ctx):
    # flat meadow on the left half, a 60° cliff on the right half
    x = np.arange(129, dtype=np.float64)
    h = np.where(x < 64, 20.0, 20.0 + (x - 64) * math.tan(math.radians(60)))
    hm = Heightmap(np.tile(h, (129, 1)).astype(np.float32))
    r = OffscreenRenderer(gl_ctx, hm, size=(128, 128))
    yield r, hm
    r.release()


def test_rock_on_the_cliff_grass_on_the_flat_and_masks(ramp):
    r, hm = ramp
    cam = Camera.look_at((40.0, 160.0, 64.0), (40.0, 20.0, 64.0), fov_y=40.0, near=1.0,
                         far=1000.0, aspect=1.0)
    flat = {"lighting": "none", "sky": False, "fog_density": 0.0}
    img = r.render(cam, technique="material", params=flat).astype(np.float64)
    green = img[..., 1] - 0.5 * (img[..., 0] + img[..., 2])
    assert green.mean() > 15  # the flat half is grass/meadow
    side = Camera.look_at((20.0, 60.0, 64.0), (100.0, 60.0, 64.0), fov_y=30.0, near=1.0,
                          far=1000.0, aspect=1.0)
    cliff = r.render(side, technique="material", params=flat).astype(np.float64)
    centre = cliff[40:88, 40:88]
    grey = np.abs(centre[..., 1] - centre[..., 0]).mean()
    assert grey < 12 and centre[..., 1].mean() - 0.5 * (centre[..., 0] + centre[..., 2]).mean() < 8
    # a water mask over the flat half turns it blue
    water = np.zeros(hm.shape, np.float32)
    water[:, :60] = 1.0
    wet = r.render(cam, technique="material", params={**flat, "water": water})
    wet = wet.astype(np.float64)
    assert (wet[..., 2] - wet[..., 0]).mean() > (img[..., 2] - img[..., 0]).mean() + 15
    with pytest.raises(InvalidParameterError, match="NaN"):
        r.render(cam, technique="material",
                 params={"flow": np.full(hm.shape, np.nan, np.float32)})


def test_a_mask_changed_only_inside_rebuilds_the_weights(ramp):
    # numpy's repr of a large array shows only its corners; the texture must still follow
    r, hm = ramp
    cam = Camera.look_at((40.0, 160.0, 64.0), (40.0, 20.0, 64.0), fov_y=40.0, near=1.0,
                         far=1000.0, aspect=1.0)
    flat = {"lighting": "none", "sky": False, "fog_density": 0.0}
    dry = np.zeros(hm.shape, np.float32)
    wet = dry.copy()
    wet[50:80, 20:60] = 1.0
    assert repr(dry) == repr(wet)
    a = r.render(cam, technique="material", params={**flat, "water": dry}).astype(int)
    b = r.render(cam, technique="material", params={**flat, "water": wet}).astype(int)
    assert (b[..., 2] - b[..., 0]).mean() > (a[..., 2] - a[..., 0]).mean() + 5


def _all_layers_trilinear():
    """The material technique as it was before the viewer's cuts: every layer sampled per
    pixel, trilinear layer textures (the reference the cheaper default must match)."""
    from dataclasses import replace

    tech = get_technique("material")

    def trilinear(builder):
        def wrapped(hm, params):
            return replace(builder(hm, params), mip_blend=True)
        return wrapped

    slots = tuple(replace(s, builder=trilinear(s.builder))
                  if s.uniform in ("u_layers", "u_normals") else s for s in tech.textures)
    return replace(tech, name="material_reference", textures=slots,
                   defines={**tech.defines, "MATERIAL_TOP_LAYERS": 7})


def test_three_heaviest_layers_and_nearest_mips_look_like_every_layer(gl_ctx):
    # The default samples a pixel's 3 heaviest layers with nearest-mip reads (a third of
    # the texture reads); the picture must stay that of every layer, trilinear.
    from terrascape.generate.registry import generate

    hm = generate("diamond-square", 129, seed=3, spacing=2.0)
    w, d = hm.extent
    cam = Camera.look_at((-0.1 * w, hm.max + 0.3 * w, -0.1 * d), (0.6 * w, hm.min, 0.6 * d),
                         fov_y=50.0, near=1.0, far=4.0 * w, aspect=1.6)
    fast = OffscreenRenderer(gl_ctx, hm, size=(320, 200))
    ref = OffscreenRenderer(gl_ctx, hm, size=(320, 200))
    try:
        a = fast.render(cam, technique="material")[..., :3].astype(int)
        b = ref.render(cam, technique=_all_layers_trilinear())[..., :3].astype(int)
    finally:
        fast.release()
        ref.release()
    diff = np.abs(a - b)
    assert a.std() > 10  # a textured landscape, not an empty frame
    assert diff.mean() < 1.5
    assert np.percentile(diff, 99) <= 12
