"""Photo material layers, hex-tiling and the default terrain material blend (CPU)."""

import math

import numpy as np
import pytest

from terrascape.analysis.spectrum import radial_power_spectrum
from terrascape.errors import InvalidParameterError
from terrascape.generate import diamond_square
from terrascape.heightmap import Heightmap
from terrascape.texture import (
    MATERIAL_LAYERS,
    MaterialRules,
    hex_tile,
    material_texture,
    material_weights,
    photo_material_layers,
    region_texture,
)
from terrascape.texture.photo_materials import periodic_component

L = {name: k for k, name in enumerate(MATERIAL_LAYERS)}


def peak_ratio(image, period):
    """Power at a texture period's frequency and its harmonics over the local median.

    For each harmonic ``m/period`` (m = 1..4, below 0.45 cycles/pixel) the radially averaged
    band at that frequency is divided by the median of the bands 2..10 away on both sides
    (the nearest bands are skipped: the Hann window spreads a line over them); the largest
    ratio is returned. Exact tiling gives ratios far above 3, a period-free texture about 1.
    """
    grey = np.asarray(image, np.float64)
    if grey.ndim == 3:
        grey = grey[..., :3].mean(axis=-1)
    f, p = radial_power_spectrum(grey)
    best = 0.0
    for m in range(1, 5):
        target = m / period
        if target > 0.45:
            break
        k = int(np.argmin(np.abs(f - target)))
        if k < 10 or k + 11 > len(f):
            continue
        band = p[max(k - 1, 0):k + 2].max()
        near = np.r_[p[k - 10:k - 1], p[k + 2:k + 11]]
        best = max(best, band / np.median(near))
    return best


def test_peak_ratio_sees_a_tiled_texture():
    # the measure must catch plain tiling, or the no-peak tests below could not fail
    layers = photo_material_layers(64)
    tiled = np.tile(layers.albedo[L["rock"], ..., :3], (8, 8, 1))
    assert peak_ratio(tiled, 64) > 3.0


def test_photo_layers_tile_seamlessly_and_are_cached():
    layers = photo_material_layers(128, seed=2)
    assert layers.albedo.shape == (len(MATERIAL_LAYERS), 128, 128, 4)
    assert layers.normals.dtype == np.uint8 and not layers.albedo.flags.writeable
    assert photo_material_layers(128, seed=2) is layers
    for k, name in enumerate(MATERIAL_LAYERS):
        h = layers.albedo[k, ..., 3].astype(np.float64)
        for axis in (0, 1):
            interior = np.abs(np.diff(h, axis=axis)).mean()
            wrap = np.abs(np.take(h, 0, axis=axis) - np.take(h, -1, axis=axis)).mean()
            assert wrap < 1.5 * interior + 0.5, (name, axis, wrap, interior)
    # normals are unit vectors facing up; rock has more relief than water
    n = layers.normals[..., :3].astype(np.float64) / 255 * 2 - 1
    assert np.all(n[..., 2] > 0.2)
    tilt = np.hypot(n[..., 0], n[..., 1]).mean(axis=(1, 2))
    assert tilt[L["rock"]] > 3 * tilt[L["water"]]
    # grass is green, snow bright, water blue
    mean = layers.albedo[..., :3].mean(axis=(1, 2))
    assert mean[L["grass"], 1] > mean[L["grass"], 0] and mean[L["grass"], 1] > mean[L["grass"], 2]
    assert mean[L["snow"]].min() > 200 and mean[L["water"], 2] > mean[L["water"], 0]
    with pytest.raises(InvalidParameterError, match="power of two"):
        photo_material_layers(100)


def test_periodic_component_removes_the_border_jump():
    ramp = np.tile(np.linspace(0.0, 1.0, 32), (32, 1))
    p = periodic_component(ramp)
    assert abs(p[:, 0] - p[:, -1]).mean() < 0.2 * abs(ramp[:, 0] - ramp[:, -1]).mean()
    assert p.mean() == pytest.approx(ramp.mean())


def test_hex_tile_has_no_period_and_is_deterministic():
    tex = photo_material_layers(64).albedo[L["scree"]].astype(np.float32)
    out = hex_tile(tex, (512, 512), tile=64.0, seed=3, luminance_channel=3)
    assert out.shape == (512, 512, 4)
    assert peak_ratio(out, 64) <= 3.0
    plain = np.tile(tex, (8, 8, 1))
    assert peak_ratio(plain, 64) > 3.0
    assert np.array_equal(out, hex_tile(tex, (512, 512), tile=64.0, seed=3, luminance_channel=3))
    assert not np.array_equal(out, hex_tile(tex, (512, 512), tile=64.0, seed=4,
                                            luminance_channel=3))
    # a constant exemplar stays constant (weights are a partition of unity)
    flat = hex_tile(np.full((8, 8), 7.0), (20, 20), tile=4.0)
    np.testing.assert_allclose(flat, 7.0, atol=1e-4)
    with pytest.raises(InvalidParameterError, match="NaN"):
        hex_tile(np.full((8, 8), np.nan), (4, 4))


@pytest.fixture(scope="module")
def terrain():
    return diamond_square(257, roughness=0.6, seed=11, spacing=4.0).normalised(0, 400)


def test_rock_on_steep_samples_grass_on_flats(terrain):
    w = material_weights(terrain)
    assert w.shape == (len(MATERIAL_LAYERS), *terrain.shape) and w.dtype == np.float32
    np.testing.assert_allclose(w.sum(axis=0), 1.0, atol=1e-5)
    slope = np.degrees(terrain.slope())
    steep, flat = slope > 45, slope < 15
    assert steep.sum() > 50 and flat.sum() > 50
    assert w[L["rock"]][steep].mean() > 0.5 > 0.02 > w[L["rock"]][flat].mean()
    green = w[L["grass"]] + w[L["meadow"]]
    low = flat & (terrain.heights < 250)
    assert green[low].mean() > 0.8


def test_snow_only_above_the_snow_line_and_water_only_below_level(terrain):
    rules = MaterialRules(snow_line=300.0, water_level=60.0)
    w = material_weights(terrain, rules=rules)
    h = terrain.heights
    assert np.all(w[L["snow"]][h <= 300.0] == 0)
    assert w[L["snow"]][(h > 330) & (np.degrees(terrain.slope()) < 20)].mean() > 0.5
    assert np.all(w[L["water"]][h > 60.0] == 0) and np.all(w[L["water"]][h <= 60.0] == 1)
    assert np.all(material_weights(terrain)[L["water"]] == 0)  # no water by default


def test_masks_drive_sediment_wear_and_water(terrain):
    shape = terrain.shape
    flow = np.zeros(shape, np.float32)
    flow[:, 100:104] = 50.0
    wear = np.zeros(shape, np.float32)
    wear[10:20, 10:20] = 1.0
    water = np.zeros(shape, np.float32)
    water[200:210, 200:210] = 1.0
    w = material_weights(terrain, masks={"flow": flow, "wear": wear, "water": water})
    gentle = np.degrees(terrain.slope()) < 10
    assert w[L["sediment"]][:, 100:104][gentle[:, 100:104]].mean() > 0.5
    assert w[L["sediment"]][:, :90].max() == 0
    assert (w[L["grass"]] + w[L["meadow"]])[10:20, 10:20].max() < 1e-6
    np.testing.assert_allclose(w[L["water"]][200:210, 200:210], 1.0)
    deposit = np.zeros(shape, np.float32)
    deposit[50:70, 50:70] = 2.0     # a thick deposit ...
    deposit[150:170, 150:170] = 0.2  # ... and a thin film
    wd = material_weights(terrain, masks={"deposition": deposit})
    rockless = w[L["rock"]] < 0.01
    core = rockless[55:65, 55:65]
    # With no running water a thick deposit is a floodplain: mostly meadow, some bare
    # sediment; a thin film stays as it was.
    fill_meadow = wd[L["meadow"]][55:65, 55:65][core].mean()
    fill_sediment = wd[L["sediment"]][55:65, 55:65][core].mean()
    green = (wd[L["meadow"]] + wd[L["grass"]])[55:65, 55:65][core]
    meadow_of_green = wd[L["meadow"]][55:65, 55:65][core][green > 0.05] / green[green > 0.05]
    assert meadow_of_green.size > 0.5 * green.size and np.median(meadow_of_green) > 0.7
    assert fill_meadow > 1.5 * fill_sediment and fill_sediment > 0.05
    assert wd[L["sediment"]][150:170, 150:170].max() == 0
    # Where water runs over it, the deposit is bare sediment.
    channel = np.zeros(shape, np.float32)
    channel[50:70, 50:70] = 50.0
    channel[0:4, 0:4] = 1.0  # so the 95th percentile is the channel's
    wc = material_weights(terrain, masks={"deposition": deposit, "flow": channel})
    assert wc[L["sediment"]][55:65, 55:65][core].mean() > 0.5
    assert wc[L["sediment"]][55:65, 55:65][core].mean() > (
        wd[L["sediment"]][55:65, 55:65][core].mean() + 0.3)
    with pytest.raises(InvalidParameterError, match="flow mask contains NaN"):
        material_weights(terrain, masks={"flow": np.full(shape, np.nan, np.float32)})
    with pytest.raises(InvalidParameterError, match="shape"):
        material_weights(terrain, masks={"wear": np.zeros((3, 3), np.float32)})
    with pytest.raises(InvalidParameterError, match="unknown mask"):
        material_weights(terrain, masks={"lava": flow})


def test_material_texture_is_natural_deterministic_and_without_period(terrain):
    a = material_texture(terrain, scale=2, seed=1)
    assert a.shape == (514, 514, 3) and a.dtype == np.uint8
    assert a.tobytes() == material_texture(terrain, scale=2, seed=1).tobytes()
    assert not np.array_equal(a, material_texture(terrain, scale=2, seed=2))
    assert peak_ratio(a, 64) <= 3.0  # tile: 32 samples × scale 2
    # steep texels are greyer (rock) than flat low ones (grass: green dominates)
    w = material_weights(terrain, seed=1)
    dom = np.repeat(np.repeat(np.argmax(w, axis=0), 2, axis=0), 2, axis=1)
    px = a.astype(np.float64)
    g = px[dom == L["grass"]]
    r = px[dom == L["rock"]]
    assert g[:, 1].mean() > g[:, 0].mean() + 10
    assert abs(r[:, 1].mean() - r[:, 0].mean()) < 10


def test_default_region_texture_has_no_tile_peak():
    hm = diamond_square(513, roughness=0.55, seed=7, spacing=2.0).normalised(0, 180)
    tex = region_texture(hm)
    assert peak_ratio(tex, 32) <= 3.0  # tile: 32 samples


def test_material_texture_validates():
    hm = Heightmap(np.zeros((8, 8), np.float32))
    with pytest.raises(InvalidParameterError, match="weights"):
        material_texture(hm, weights=np.zeros((2, 8, 8)))
    with pytest.raises(InvalidParameterError):
        MaterialRules(rock_slope=(50.0, 40.0))
    assert math.isfinite(float(material_texture(hm).mean()))
