"""Daylight model: tone-mapped lightmap without clipping, blue sky light in shadows, the sun
colour follows its elevation, the Preetham sky is smooth at the horizon."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from PIL import Image

from terrascape.cli.app import run_app
from terrascape.errors import InvalidParameterError
from terrascape.generate import diamond_square
from terrascape.heightmap import Heightmap
from terrascape.io import write_heightmap
from terrascape.lighting import daylight, lightmap, shadow_mask
from terrascape.lighting.daylight import aces_filmic, linear_to_srgb


@pytest.fixture(scope="module")
def terrain():
    return diamond_square(129, seed=3).scaled(25.0)


@pytest.fixture(scope="module")
def rgb(terrain):
    return lightmap(terrain, 135.0, 20.0, color=True)


def test_lightmap_does_not_clip(terrain, rgb):
    grey = lightmap(terrain, 135.0, 20.0)
    assert grey.shape == terrain.shape and grey.dtype == np.float32
    codes = np.rint(grey * 255)
    # the classic formula clips half of a sunlit map to white; the filmic curve rolls off
    assert (codes >= codes.max()).mean() <= 0.05
    assert (codes >= 250).mean() <= 0.05
    classic = lightmap(terrain, 135.0, 20.0, model="classic")
    assert (classic >= 1.0).mean() > 0.2  # what the old default did
    assert grey.std() > 0.03  # slopes still read


def test_shadows_are_blue_not_black(terrain, rgb):
    mask = shadow_mask(terrain, 135.0, 20.0)
    assert 0.02 < mask.mean() < 0.9
    assert rgb.min() > 0.1  # no pure-black shadow sample
    shadow = rgb[mask]
    lit = rgb[~mask]
    assert (shadow[:, 2] > shadow[:, 0] + 0.03).mean() > 0.95  # bluish: blue above red
    assert shadow.mean() < lit.mean()


def test_sun_colour_follows_elevation():
    low, high = daylight(135.0, 8.0), daylight(135.0, 60.0)
    r_low = low.sun_irradiance / low.sun_irradiance.max()
    r_high = high.sun_irradiance / high.sun_irradiance.max()
    assert r_low[2] < 0.5 * r_low[0]  # low sun: red
    assert r_high[2] > 0.9 * r_high[0]  # high sun: near white (white-balanced)
    assert low.sun_irradiance.sum() < high.sun_irradiance.sum()
    # the sky is blue overhead at midday, and lights the ground less than the sun
    zen = high.sky_radiance([0.0, 1.0, 0.0])
    assert zen[2] > zen[0]
    assert high.sky_irradiance.sum() < high.sun_irradiance.sum() * np.sin(np.radians(60))


def test_sky_smooth_through_horizon():
    day = daylight(135.0, 30.0)
    el = np.radians(np.linspace(-5.0, 30.0, 351))
    az = np.radians(315.0)  # away from the sun
    dirs = np.stack([np.sin(az) * np.cos(el), np.sin(el), -np.cos(az) * np.cos(el)], axis=1)
    lum = day.sky_radiance(dirs) @ [0.2126, 0.7152, 0.0722]
    assert np.all(np.diff(lum) <= 1e-9)  # brighter toward the horizon, no dip
    step = np.abs(np.diff(lum)).max()
    assert np.abs(np.diff(lum, 2)).max() < 0.2 * step + 1e-6  # no kink


def test_tone_curve():
    x = np.linspace(0, 20, 1000)
    y = aces_filmic(x)
    assert np.all(np.diff(y) >= 0) and y[0] == 0 and y.max() <= 1.0
    assert abs(float(linear_to_srgb(0.5)) - 0.7354) < 1e-3


def test_validation():
    flat = np.zeros((8, 8), np.float32)
    with pytest.raises(InvalidParameterError, match="model"):
        lightmap(flat, 0.0, 45.0, model="phong")
    with pytest.raises(InvalidParameterError, match="turbidity"):
        lightmap(flat, 0.0, 45.0, turbidity=50.0)
    with pytest.raises(InvalidParameterError, match="color"):
        lightmap(flat, 0.0, 45.0, model="classic", color=True)
    with pytest.raises(InvalidParameterError):
        lightmap(flat, 0.0, -5.0)


def test_shade_cli_daylight_and_seed(tmp_path, terrain):
    src = tmp_path / "hm.npy"
    write_heightmap(Heightmap(terrain.heights), src)
    out = tmp_path / "day.png"
    assert run_app(["shade", str(src), "-o", str(out), "--sun-azimuth", "135",
                    "--sun-elevation", "20", "--color", "-q"]) == 0
    img = np.array(Image.open(out))
    assert img.shape == (*terrain.shape, 3)
    np.testing.assert_array_equal(
        img, np.rint(lightmap(terrain.heights, 135.0, 20.0, color=True) * 255).astype(np.uint8))
    bad = tmp_path / "bad.png"
    assert run_app(["shade", str(src), "-o", str(bad), "--sun-azimuth", "135",
                    "--sun-elevation", "20", "--lighting", "phong"]) == 2
    assert run_app(["shade", str(src), "-o", str(bad), "--sun-azimuth", "135",
                    "--sun-elevation", "20", "--lighting", "classic", "--color"]) == 2
    assert not bad.exists()


def _whole_map_light(hm, az, el, *, color, sky_visibility=None):
    """The daylight lightmap as one set of whole-map float64 arrays (before the bands)."""
    from terrascape.lighting.daylight import _LUMA, local_sky_visibility
    from terrascape.lighting.normals import normal_map
    from terrascape.lighting.shadows import soft_shadow

    day = daylight(az, el, exposure=-1.0)
    normals = normal_map(hm).astype(np.float64)
    vis = soft_shadow(hm, az, el, sun_radius_deg=0.5, samples=8)
    svf = local_sky_visibility(hm) if sky_visibility is None else sky_visibility
    rgb = day.display(day.surface_irradiance(normals, vis, svf) / np.pi).astype(np.float32)
    if color:
        return rgb
    luma = _LUMA.astype(np.float32)
    return rgb[..., 0] * luma[0] + rgb[..., 1] * luma[1] + rgb[..., 2] * luma[2]


@pytest.mark.parametrize("parallel", [False, True])
def test_lightmap_in_bands_equals_the_whole_map_formula(monkeypatch, parallel):
    """Bands of a few rows (the last one short), serial and shared among threads, give the
    whole-map computation's values bit for bit, grey and RGB, with the local sky visibility
    enlarged band by band or a given one sliced."""
    daylight_module = sys.modules["terrascape.lighting.daylight"]
    hm = diamond_square(513, seed=5).scaled(60.0)
    # 300 rows, 290 columns: the sky visibility is computed on every second sample
    hm = Heightmap(hm.heights[:300, :290], spacing=(2.0, 2.0))
    monkeypatch.setattr(daylight_module, "_BAND_SAMPLES", 7 * 290)  # 43 bands, last 6 rows
    monkeypatch.setattr(daylight_module, "_LONG_SAMPLES", 0 if parallel else 1 << 40)
    for color in (False, True):
        expected = _whole_map_light(hm, 200.0, 12.0, color=color)
        got = daylight_module.daylight_lightmap(hm, 200.0, 12.0, color=color)
        assert got.dtype == np.float32 and got.tobytes() == expected.tobytes()
    svf = np.linspace(0.5, 1.0, hm.heights.size).reshape(hm.shape)
    expected = _whole_map_light(hm, 80.0, 35.0, color=False, sky_visibility=svf)
    got = daylight_module.daylight_lightmap(hm, 80.0, 35.0, sky_visibility=svf)
    assert got.tobytes() == expected.tobytes()


def test_lightmap_bands_do_not_begin_once_told_to_stop():
    """No band begins once told to stop; otherwise every band is lit, and a flat map evenly
    (grey made from a BLAS product rounded the last columns differently on AVX-512)."""
    from terrascape.lighting.daylight import _light_in_bands

    day = daylight(135.0, 30.0)
    normals = np.zeros((40, 30, 3), np.float32)
    normals[..., 1] = 1.0
    vis = np.ones((40, 30), np.float32)
    for flag, untouched in ((1, True), (0, False)):
        out = np.full((40, 30), np.nan, np.float32)
        _light_in_bands(day, normals, vis, lambda rows: 1.0, out, False,
                        np.array([flag], np.uint8))
        assert np.isnan(out).all() == untouched
        assert untouched or (np.isfinite(out).all() and np.ptp(out) == 0.0)


def test_lightmap_peak_memory_stays_near_its_inputs_and_output(monkeypatch):
    """numpy reports its arrays to tracemalloc. The lightmap of a 1025² map allocates its
    normals (float32, after a float64 copy of the heights: 20 B a sample), the shadows
    (11 B while made, 4 B kept), the output (4 B grey, 12 B RGB) and a few bands' float64
    temporaries; before the bands it held whole-map float64 RGB arrays, 165 B a sample.
    Bands of 2¹² samples keep the bands' share small (measured 23.0 B grey, 29.9 B RGB)."""
    import tracemalloc

    monkeypatch.setattr(sys.modules["terrascape.lighting.daylight"], "_BAND_SAMPLES", 1 << 12)
    hm = diamond_square(1025, seed=2).scaled(200.0)
    lightmap(hm, 135.0, 30.0)  # compiled and cached before measuring
    for color, limit in ((False, 25.0), (True, 32.0)):
        tracemalloc.start()
        try:
            light = lightmap(hm, 135.0, 30.0, color=color)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert light.shape[:2] == (1025, 1025)
        per_sample = peak / hm.heights.size
        assert per_sample < limit, f"{per_sample:.1f} B a sample"
