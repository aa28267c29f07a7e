"""Region weights and region texture (Filipović 2008 §3.1.1): values, jitter, slope rule, errors."""

import math

import numpy as np
import pytest

from terrascape.errors import HeightmapSizeError, InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.texture.regions import (
    Region,
    SlopeRule,
    default_regions,
    region_texture,
    region_weights,
)

ABC = [Region("a", 10.0, 10.0), Region("b", 20.0, 10.0), Region("c", 30.0, 5.0)]


def _heights(values):
    """A 2×N map whose both rows hold ``values`` (region_weights needs a 2-D grid)."""
    v = np.asarray(values, dtype=np.float32)
    return np.stack([v, v])


def test_formula_values_at_chosen_heights():
    w = region_weights(_heights([15.0, 27.0, 20.0, 29.0]), ABC)[:, 0, :]
    # h=15: a=(10-5)/10=0.5, b=0.5, c=0  -> already normalised
    np.testing.assert_allclose(w[:, 0], [0.5, 0.5, 0.0], atol=1e-6)
    # h=27: a=0, b=(10-7)/10=0.3, c=(5-3)/5=0.4 -> 3/7, 4/7
    np.testing.assert_allclose(w[:, 1], [0.0, 3 / 7, 4 / 7], atol=1e-6)
    # h=20: only b's peak (a=0, c=(5-10)/5<0)
    np.testing.assert_allclose(w[:, 2], [0.0, 1.0, 0.0], atol=1e-6)
    # h=29: b=0.1, c=0.8 -> 1/9, 8/9
    np.testing.assert_allclose(w[:, 3], [0.0, 1 / 9, 8 / 9], atol=1e-6)


def test_fallback_to_nearest_band_outside_all_bands():
    w = region_weights(_heights([-50.0, 60.0, -0.5]), ABC)[:, 0, :]
    np.testing.assert_array_equal(w[:, 0], [1, 0, 0])  # far below: lowest band
    np.testing.assert_array_equal(w[:, 1], [0, 0, 1])  # far above: c (gap 25) beats b (gap 30)
    np.testing.assert_array_equal(w[:, 2], [1, 0, 0])


def test_weights_sum_to_one_everywhere(rng):
    h = rng.uniform(-20, 80, size=(37, 41)).astype(np.float32)
    slope = rng.uniform(0, 1.4, size=h.shape).astype(np.float32)
    regions = [*ABC, Region("rock", 45.0, 12.0)]
    w = region_weights(h, regions, jitter=0.6, seed=4, slope=slope, slope_rule=True)
    assert w.shape == (4, 37, 41) and w.dtype == np.float32
    assert w.min() >= 0.0
    np.testing.assert_allclose(w.sum(axis=0), 1.0, atol=1e-5)


def test_default_regions_follow_table_1():
    hm = Heightmap(np.array([[0.0, 255.0], [100.0, 200.0]], np.float32))
    regs = default_regions(hm)
    assert [r.name for r in regs] == ["water", "sand", "grass", "rock", "snow"]
    np.testing.assert_allclose([r.max for r in regs], [51, 102, 153, 204, 255])
    assert all(r.range == pytest.approx(51.0) for r in regs)
    assert not regs[0].jitter and all(r.jitter for r in regs[1:])
    # Complementary hats: halfway between two peaks both bands weigh 0.5, no renormalising.
    w = region_weights(_heights([0.0, 76.5, 229.5, 255.0]), regs)[:, 0, :]
    np.testing.assert_allclose(w[:, 0], [1, 0, 0, 0, 0], atol=1e-6)
    # ... except water, which stops at its line (max = 51): above it sand takes it all.
    np.testing.assert_allclose(w[:, 1], [0, 1, 0, 0, 0], atol=1e-6)
    np.testing.assert_allclose(w[:, 2], [0, 0, 0, 0.5, 0.5], atol=1e-6)
    np.testing.assert_allclose(w[:, 3], [0, 0, 0, 0, 1], atol=1e-6)
    flat = default_regions(Heightmap(np.zeros((3, 3), np.float32)))
    assert all(r.range > 0 for r in flat)


def test_jitter_never_touches_water_and_is_deterministic():
    h = np.tile(np.linspace(0, 100, 64, dtype=np.float32), (64, 1))
    # A band named water ignores jitter=True; jitter off for sand too -> nothing may change.
    regs = [Region("water", 20.0, 20.0, jitter=True), Region("sand", 40.0, 20.0, jitter=False),
            Region("grass", 60.0, 20.0, jitter=False)]
    np.testing.assert_array_equal(region_weights(h, regs, jitter=1.0, seed=3),
                                  region_weights(h, regs, jitter=0.0))
    regs = default_regions(Heightmap(h))
    base = region_weights(h, regs)
    jit = region_weights(h, regs, jitter=0.5, seed=3)
    assert np.abs(jit - base).max() > 0.2  # jitter does move the other bands
    # water never appears above its unjittered band (no water texture on hillsides)
    assert np.all(jit[0][base[0] == 0] == 0)
    # bounded: a band's weight stays 0 farther than range·(1 + jitter) from its peak
    for k, r in enumerate(regs):
        far = np.abs(h - r.max) >= r.range * 1.5
        assert np.all(jit[k][far] == 0), r.name
    again = region_weights(h, regs, jitter=0.5, seed=3)
    other = region_weights(h, regs, jitter=0.5, seed=4)
    assert again.tobytes() == jit.tobytes()
    assert not np.array_equal(other, jit)


def _ramp_heightmap():
    """Flat grass plateau on the left, a 60° ramp on the right (spacing 1)."""
    cols = 80
    x = np.arange(cols, dtype=np.float64)
    h = np.where(x < 40, 50.0, 50.0 + (x - 40) * math.tan(math.radians(60)))
    return Heightmap(np.tile(h, (40, 1)).astype(np.float32))


def test_slope_rule_puts_rock_on_steep_ramp():
    hm = _ramp_heightmap()
    regs = [Region("water", 10.0, 40.0), Region("grass", 50.0, 40.0),
            Region("rock", 500.0, 10.0), Region("snow", 1000.0, 10.0)]
    w_off = region_weights(hm.heights, regs, slope=hm.slope(), slope_rule=False)
    w_on = region_weights(hm.heights, regs, slope=hm.slope(), slope_rule=True)
    rock = 2
    assert w_off[rock, :, 45:70].max() < 0.01  # heights alone never reach the rock band
    np.testing.assert_allclose(w_on[rock, :, 42:78], 1.0, atol=1e-6)  # steep: all rock
    np.testing.assert_array_equal(w_on[:, :, :38], w_off[:, :, :38])  # flat: unchanged
    # halfway through the ramp of angles -> t = 0.5
    h = _heights([50.0, 50.0])
    s = _heights([math.radians(37.5), math.radians(37.5)])
    w = region_weights(h, regs, slope=s, slope_rule=SlopeRule("rock", 30, 45))[:, 0, 0]
    np.testing.assert_allclose(w, [0.0, 0.5, 0.5, 0.0], atol=1e-6)
    # water keeps its weight on a steep slope below the water line (no rock under the water
    # plane); above it there is no water at all, so the steep slope is all rock
    h = _heights([10.0, 30.0])
    s = _heights([1.3, 1.3])
    w = region_weights(h, regs, slope=s, slope_rule=True)[:, 0, :]
    np.testing.assert_allclose(w[:, 0], [1, 0, 0, 0], atol=1e-6)
    np.testing.assert_allclose(w[:, 1], [0, 0, 1, 0], atol=1e-6)


def _solid(colour, size=8):
    return np.full((size, size, 3), colour, dtype=np.uint8)


def test_region_texture_blends_colours_by_weight():
    hm = _ramp_heightmap()
    colours = [(0, 0, 255), (0, 200, 0), (120, 120, 120), (255, 255, 255)]
    regs = [Region(n, m, r, texture=_solid(c)) for (n, m, r), c in zip(
        [("water", 10.0, 40.0), ("grass", 50.0, 40.0), ("rock", 500.0, 10.0),
         ("snow", 1000.0, 10.0)], colours, strict=True)]
    tex = region_texture(hm, regs, texture_size=8)
    assert tex.shape == (40, 80, 3) and tex.dtype == np.uint8
    w = region_weights(hm.heights, regs, slope=hm.slope(), slope_rule=True)
    expected = np.einsum("rij,rc->ijc", w, np.asarray(colours, np.float64))
    assert np.abs(tex.astype(np.float64) - expected).max() <= 0.51
    assert tex[20, 10].tolist() == [0, 200, 0] and tex[20, 60].tolist() == [120, 120, 120]
    # lightmap multiplies; any size is resampled
    half = region_texture(hm, regs, texture_size=8, lightmap=np.full((5, 7), 0.5))
    assert np.abs(half.astype(float) - expected * 0.5).max() <= 0.51
    grad = np.tile(np.linspace(0, 1, 80, dtype=np.float32), (40, 1))
    lit = region_texture(hm, regs, texture_size=8, lightmap=grad)
    assert lit[20, 0].tolist() == [0, 0, 0] and lit[20, 10].tolist() == [0, round(200 * 10 / 79), 0]


def test_region_texture_scale_interpolates_heights():
    h = np.array([[0.0, 100.0], [0.0, 100.0]], np.float32)
    regs = [Region("lo", 0.0, 100.0, texture=_solid((0, 0, 0))),
            Region("hi", 100.0, 100.0, texture=_solid((200, 200, 200)))]
    tex = region_texture(Heightmap(h), regs, scale=3, slope_rule=False, texture_size=8)
    assert tex.shape == (6, 6, 3)
    # corner aligned: texel j sits at x = j/5, height 100·j/5, colour 200·j/5
    np.testing.assert_array_equal(tex[0, :, 0], [0, 40, 80, 120, 160, 200])
    np.testing.assert_array_equal(tex[:, 2, 1], [80] * 6)


def test_region_texture_is_hex_tiled_without_a_period():
    pattern = (np.arange(64).reshape(8, 8) * 4).astype(np.uint8)
    tex_img = np.repeat(pattern[..., None], 3, axis=2)
    hm = Heightmap(np.zeros((40, 60), np.float32))
    regs = [Region("ground", 0.0, 1.0, texture=tex_img)]
    out = region_texture(hm, regs, texture_size=8, tile_size=8.0, slope_rule=False)[..., 0]
    # wrap sampling would repeat exactly every 8 samples; hex-tiling never does
    for period in (8, 16, 24):
        assert np.abs(out[:, period:].astype(int) - out[:, :-period]).mean() > 10
        assert np.abs(out[period:, :].astype(int) - out[:-period, :]).mean() > 10
    # every texel is a blend of texture values: inside the texture's range, all of it used
    assert out.min() >= pattern.min() and out.max() <= pattern.max()
    assert np.ptp(out) > 0.6 * np.ptp(pattern)
    a = region_texture(hm, regs, texture_size=8, tile_size=8.0, slope_rule=False, seed=1)
    assert not np.array_equal(a[..., 0], out)  # the seed picks the hexagons' offsets


def test_no_water_colour_above_the_water_line():
    # a steep ramp from 0 to 100: default bands put water up to 20
    x = np.linspace(0.0, 100.0, 64, dtype=np.float32)
    hm = Heightmap(np.tile(x, (16, 1)), spacing=(0.5, 0.5))
    blue, sand = (0, 0, 255), (200, 180, 120)
    regs = [Region("water", 20.0, 20.0, texture=_solid(blue)),
            Region("sand", 40.0, 20.0, texture=_solid(sand)),
            Region("rock", 100.0, 60.0, texture=_solid((100, 100, 100)))]
    tex = region_texture(hm, regs, texture_size=8)
    above = hm.heights > 20.0
    assert np.all(tex[..., 2][above] < 200)  # no blue anywhere above the line
    assert np.all(tex[~above] == blue)
    w = region_weights(hm.heights, regs, slope=hm.slope(), slope_rule=True)
    assert np.all(w[0][above] == 0) and np.all(w[0][~above] == 1)
    # an explicit water level moves the line
    low = region_weights(hm.heights, regs, water_level=10.0)
    assert np.all(low[0][hm.heights > 10.0] == 0) and np.all(low[0][hm.heights <= 10.0] == 1)


def test_region_texture_with_builtins_is_deterministic():
    y, x = np.mgrid[0:33, 0:33] / 32.0
    hm = Heightmap((np.sin(3 * x) * np.cos(2 * y) * 20 + 20).astype(np.float32))
    a = region_texture(hm, jitter=0.3, seed=5, texture_size=32)
    b = region_texture(hm, jitter=0.3, seed=5, texture_size=32)
    c = region_texture(hm, jitter=0.3, seed=6, texture_size=32)
    assert a.tobytes() == b.tobytes() and not np.array_equal(a, c)
    assert region_texture(hm, scale=2, texture_size=32).shape == (66, 66, 3)


def test_bad_input_raises_typed_errors():
    good = _heights([1.0, 2.0])
    with pytest.raises(InvalidParameterError, match="NaN"):
        region_weights(_heights([1.0, np.nan]), ABC)
    with pytest.raises(InvalidParameterError, match="empty"):
        region_weights(good, [])
    with pytest.raises(InvalidParameterError, match="identical"):
        region_weights(good, [Region("a", 1, 2), Region("b", 1, 2)])
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(InvalidParameterError, match="range"):
            Region("a", 1.0, bad)
    with pytest.raises(InvalidParameterError, match="max"):
        Region("a", float("inf"), 1.0)
    with pytest.raises(InvalidParameterError, match="jitter"):
        region_weights(good, ABC, jitter=1.5)
    with pytest.raises(InvalidParameterError, match="needs slope"):
        region_weights(good, [*ABC, Region("rock", 40, 5)], slope_rule=True)
    with pytest.raises(InvalidParameterError, match="shape"):
        region_weights(good, [*ABC, Region("rock", 40, 5)], slope=np.zeros((3, 3)),
                       slope_rule=True)
    with pytest.raises(InvalidParameterError, match="cliff"):
        region_weights(good, ABC, slope=good, slope_rule=SlopeRule("cliff"))
    with pytest.raises(InvalidParameterError, match="start_deg <= end_deg"):
        SlopeRule("rock", 50, 40)
    with pytest.raises(HeightmapSizeError):
        region_weights(np.zeros((1, 5)), ABC)
    hm = Heightmap(good)
    with pytest.raises(InvalidParameterError, match="lightmap"):
        region_texture(hm, lightmap=np.full((4, 4), 1.5))
    with pytest.raises(InvalidParameterError, match="lightmap"):
        region_texture(hm, lightmap=np.zeros(4))
    with pytest.raises(InvalidParameterError, match="scale"):
        region_texture(hm, scale=0)
    with pytest.raises(InvalidParameterError, match="channels"):
        region_texture(hm, [Region("a", 1, 1, texture=np.zeros((4, 4, 2), np.uint8))])
    with pytest.raises(InvalidParameterError, match="not a built-in"):
        region_texture(hm, [Region("lava", 1, 1)])


def test_region_weights_rows_do_not_begin_once_told_to_stop():
    """The weights' kernel leaves rows not yet begun unwritten once the stop flag is set
    (Ctrl-C during a large map's weights, measured in docs/reliability.md §3), and
    otherwise gives region_weights' values."""
    from terrascape.texture import regions as module

    h = np.linspace(0.0, 100.0, 40 * 30, dtype=np.float32).reshape(40, 30)
    regions = default_regions(h)
    rule, s0, s1 = module._resolve_slope_rule(None, regions)
    args = (h, np.zeros((1, 1), np.float32), False, *module._region_arrays(regions, 0.0, 0),
            rule, module._water_index(regions), s0, s1, module._water_level(regions, None))
    for flag in (1, 0):
        out = np.full((len(regions), 40, 30), np.nan, np.float32)
        module._weights_kernel(*args, out, np.array([flag], np.uint8))
        if flag:
            assert np.isnan(out).all()
        else:
            assert np.array_equal(out, region_weights(h, regions))
