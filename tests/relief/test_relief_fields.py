import numpy as np
import pytest

from terrascape.errors import HeightmapSizeError, InvalidParameterError
from terrascape.relief.fields import city_field, natural_field


def test_city_field_has_streets_roofs_and_thin_walls():
    h = city_field(128, seed=3)
    assert h.dtype == np.float32 and h.shape == (128, 128)
    assert h.min() == 0.0 and h.max() == 1.0
    # Streets: every block pitch (32) ends with 4 rows/cols of height 0.
    assert np.all(h[28:32, :] == 0.0) and np.all(h[:, 60:64] == 0.0)
    # Thin walls: some row has a run of exactly 1 or 2 equal texels above lower neighbours.
    thin = 0
    for row in h:
        d = np.diff(row)
        ups = np.nonzero(d > 0.05)[0]
        downs = np.nonzero(d < -0.05)[0]
        for u in ups:
            nxt = downs[downs > u]
            if nxt.size and nxt[0] - u <= 2:
                thin += 1
    assert thin > 20


def test_fields_are_deterministic_and_seeded():
    assert np.array_equal(city_field(64, seed=1, block=16), city_field(64, seed=1, block=16))
    assert not np.array_equal(natural_field(64, seed=1), natural_field(64, seed=2))


def test_natural_field_is_smooth_and_tileable():
    h = natural_field(128, seed=5)
    assert h.min() == 0.0 and h.max() == pytest.approx(1.0)
    # Tileable: the wrap-around step is no larger than steps inside the field.
    inner = np.abs(np.diff(h, axis=1)).max()
    assert np.abs(h[:, 0] - h[:, -1]).max() <= inner * 1.01
    assert inner < 0.1  # smooth at texel scale


def test_field_sizes_are_validated():
    with pytest.raises(HeightmapSizeError, match="power-of-two"):
        city_field(100)
    with pytest.raises(InvalidParameterError):
        natural_field(64, beta=0.5)


def test_walls_are_told_apart_from_slopes():
    from terrascape.relief.fields import WALL_STEP, has_walls, max_texel_step

    assert has_walls(city_field(64, seed=1, block=16))
    # The bench fields (seed 0): the city's walls are full-height steps, the smooth field
    # stays far below the wall step.
    assert max_texel_step(city_field(256, seed=0)) == 1.0
    assert max_texel_step(natural_field(256, seed=0)) < 0.08
    assert max_texel_step(natural_field(1280, seed=0)) < 0.04
    for size in (64, 256, 1280):
        assert not has_walls(natural_field(size, seed=0))
    ramp = np.tile(np.linspace(0.0, 1.0, 16, dtype=np.float32), (16, 1))
    # The ramp's steps are 1/15, but tiled it jumps from 1 back to 0: a wall.
    assert max_texel_step(ramp) == pytest.approx(1.0)
    assert has_walls(ramp)
    inner = ramp[:, :8] * 0 + np.float32(0.5)
    inner[4, 4] = 0.5 + WALL_STEP  # one raised texel, the wrap pair flat
    assert has_walls(inner) and not has_walls(inner, step=WALL_STEP + 0.01)
    with pytest.raises(HeightmapSizeError):
        max_texel_step(np.zeros(8))
    with pytest.raises(InvalidParameterError):
        has_walls(ramp, step=0.0)


def test_fence_field_has_one_texel_walls_and_tiles():
    from terrascape.relief.fields import fence_field, has_walls

    f = fence_field(64, seed=2, fences=8)
    assert f.dtype == np.float32 and f.shape == (64, 64)
    assert f.max() == 1.0 and f.min() == 0.0
    assert has_walls(f)
    raised = f > 0
    # one texel thick: no 2×2 block of fence texels unless two fences cross
    blocks = raised[:-1, :-1] & raised[1:, :-1] & raised[:-1, 1:] & raised[1:, 1:]
    assert blocks.sum() <= 4
    np.testing.assert_array_equal(f, fence_field(64, seed=2, fences=8))


@pytest.mark.parametrize("bits", [8, 16])
def test_sampled_heights_are_the_packed_codes(bits):
    from terrascape.lighting.normals import pack_normal_height
    from terrascape.relief.fields import natural_field, sampled_heights

    h = 0.2 + 0.6 * natural_field(32, seed=1)  # not spanning [0, 1]: the pack stretches it
    s = sampled_heights(h, bits)
    codes = pack_normal_height(h, bits=bits)[..., 3]
    np.testing.assert_array_equal(s, (codes / float((1 << bits) - 1)).astype(np.float32))
    # idempotent: packing the sampled surface gives the same codes
    np.testing.assert_array_equal(pack_normal_height(s, bits=bits)[..., 3], codes)
    np.testing.assert_array_equal(sampled_heights(h, 32), h.astype(np.float32))
