"""Splat alpha maps (Filipović 2008 §3.1.3): naive per-block reference, packing, rules, errors."""

import math

import numpy as np
import pytest

from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.texture.regions import Region, default_regions
from terrascape.texture.splat import (
    block_layers,
    material_ids_from_rules,
    pack_splat_maps,
    splat_weights,
    unpack_splat_maps,
)


def naive_blockwise_splat(ids, n_layers, block):
    """The thesis's scheme written out literally: per 32×32-cell block (33×33 vertices), per
    vertex, average the alpha of the cells sharing it, each cell's alpha being its 3×3
    neighbourhood weighted ``1 - d²/1.75²`` and normalised. Returns the map and asserts that
    vertices shared by two blocks get the same value from both."""
    nr, nc = ids.shape
    out = np.full((n_layers, nr + 1, nc + 1), np.nan)

    def cell_alpha(ci, cj):
        acc = np.zeros(n_layers)
        total = 0.0
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                ni, nj = ci + di, cj + dj
                if 0 <= ni < nr and 0 <= nj < nc:
                    wt = 1.0 - (di * di + dj * dj) / 1.75**2
                    acc[ids[ni, nj]] += wt
                    total += wt
        return acc / total

    for b0 in range(0, nr, block):
        for b1 in range(0, nc, block):
            for vi in range(b0, min(b0 + block, nr) + 1):
                for vj in range(b1, min(b1 + block, nc) + 1):
                    cells = [(ci, cj) for ci in (vi - 1, vi) for cj in (vj - 1, vj)
                             if 0 <= ci < nr and 0 <= cj < nc]
                    value = np.mean([cell_alpha(ci, cj) for ci, cj in cells], axis=0)
                    if not np.isnan(out[0, vi, vj]):
                        np.testing.assert_allclose(out[:, vi, vj], value)
                    out[:, vi, vj] = value
    assert not np.isnan(out).any()
    return out


@pytest.mark.parametrize(("shape", "block"), [((40, 37), 32), ((23, 30), 7), ((5, 4), 32)])
def test_splat_matches_naive_per_block_reference(rng, shape, block):
    ids = rng.integers(0, 5, size=shape)
    fast = splat_weights(ids, 6, block=block)
    ref = naive_blockwise_splat(ids, 6, block)
    assert fast.shape == (6, shape[0] + 1, shape[1] + 1) and fast.dtype == np.float32
    np.testing.assert_allclose(fast, ref, atol=1e-6)
    np.testing.assert_allclose(fast.sum(axis=0), 1.0, atol=1e-6)
    assert fast[5].max() == 0.0  # an unused layer stays empty
    # the block size changes the work split, never the values
    np.testing.assert_array_equal(fast, splat_weights(ids, 6, block=3))


def test_splat_hand_computed_values():
    ids = np.zeros((3, 3), np.int64)
    ids[1, 1] = 1  # a single material-1 cell in the middle
    w = splat_weights(ids, block=32)
    e, d = 1 - 1 / 1.75**2, 1 - 2 / 1.75**2
    centre = 1.0 / (1 + 4 * e + 4 * d)  # the middle cell sees itself with weight 1
    edge_cell = e / (1 + 3 * e + 2 * d)  # cell (0,1): 6 neighbours inside the map
    corner_cell = d / (1 + 2 * e + d)  # cell (0,0): 4 neighbours inside
    # vertex (1,1) touches cells (0,0), (0,1), (1,0), (1,1)
    expected = (centre + 2 * edge_cell + corner_cell) / 4
    assert w[1, 1, 1] == pytest.approx(expected, abs=1e-6)
    assert w[1, 0, 0] == pytest.approx(corner_cell, abs=1e-6)  # map corner: one cell
    assert w[1, 0, 1] == pytest.approx((corner_cell + edge_cell) / 2, abs=1e-6)
    assert w[0, 1, 1] == pytest.approx(1 - expected, abs=1e-6)
    uniform = splat_weights(np.full((4, 4), 2), 3)
    np.testing.assert_array_equal(uniform[2], 1.0)


def test_pack_round_trip_and_exact_sums(rng):
    ids = rng.integers(0, 7, size=(20, 25))
    w = splat_weights(ids, 7)
    images = pack_splat_maps(w)
    assert len(images) == 2
    assert all(im.shape == (21, 26, 4) and im.dtype == np.uint8 for im in images)
    assert images[1][..., 3].max() == 0  # 8th channel unused
    total = sum(im.astype(np.int64).sum(axis=-1) for im in images)
    assert np.all(total == 255)  # largest-remainder rounding
    back = unpack_splat_maps(images, 7)
    assert back.shape == w.shape
    assert np.abs(back - w).max() <= 1.0 / 255 + 1e-7
    # channel layout: layer k -> image k//4, channel k%4
    one_hot = np.zeros((6, 3, 3), np.float32)
    one_hot[5] = 1.0
    packed = pack_splat_maps(one_hot)
    assert packed[1][..., 1].min() == 255 and packed[0].max() == 0
    assert len(pack_splat_maps(one_hot[:4] + 0.25)) == 1


def test_pack_rejects_bad_weights():
    with pytest.raises(InvalidParameterError, match="sum to 1"):
        pack_splat_maps(np.full((2, 3, 3), 0.7, np.float32))
    with pytest.raises(InvalidParameterError, match=r"\(L, rows, cols\)"):
        pack_splat_maps(np.zeros((3, 3)))
    with pytest.raises(InvalidParameterError, match=r"\[0, 1\]"):
        pack_splat_maps(np.stack([np.full((2, 2), -0.5), np.full((2, 2), 1.5)]))
    with pytest.raises(InvalidParameterError, match="RGBA"):
        unpack_splat_maps([np.zeros((3, 3, 3), np.uint8)])


def test_material_ids_from_rules_height_and_slope():
    x = np.arange(60, dtype=np.float64)
    # gentle rise through water..rock bands for x < 40, then a 70° cliff
    h = np.where(x < 40, x * 0.5, 20 + (x - 40) * math.tan(math.radians(70)))
    hm = Heightmap(np.tile(h, (10, 1)).astype(np.float32))
    regions = [Region("water", 2.0, 5.0), Region("sand", 7.0, 5.0), Region("grass", 12.0, 5.0),
               Region("rock", 200.0, 5.0), Region("snow", 400.0, 5.0)]
    ids = material_ids_from_rules(hm, regions)
    assert ids.shape == (9, 59) and ids.dtype == np.uint8
    row = ids[4]
    assert row[0] == 0 and row[12] == 1 and row[24] == 2  # cell centre h = 0.25, 6.25, 12.25
    assert np.all(row[42:58] == 3)  # cliff cells: rock by slope
    no_slope = material_ids_from_rules(hm, regions, slope_rule=False)
    # heights alone (~35 at cell 45) are above every band: nearest band is grass (gap 18)
    assert no_slope[4, 45] == 2
    assert np.array_equal(ids[:, :38], no_slope[:, :38])
    default = material_ids_from_rules(hm)
    assert default.max() < len(default_regions(hm))


def test_block_layers():
    ids = np.zeros((64, 64), np.int64)
    ids[10, 10] = 1
    ids[40:, 40:] = 2
    w = splat_weights(ids, 3)
    used = block_layers(w, block=32)
    assert used.shape == (2, 2, 3)
    assert used[:, :, 0].all()
    assert used[0, 0, 1] and not used[1, 1, 1] and not used[0, 1, 1]
    assert used[1, 1, 2] and not used[0, 0, 2]


def test_splat_bad_input():
    with pytest.raises(InvalidParameterError, match="out of range"):
        splat_weights(np.array([[0, 5]]), 3)
    with pytest.raises(InvalidParameterError, match=">= 0"):
        splat_weights(np.array([[0, -1]]))
    with pytest.raises(InvalidParameterError, match="integers"):
        splat_weights(np.array([[0.5, 1.0]]))
    with pytest.raises(InvalidParameterError, match="2-D"):
        splat_weights(np.zeros(5, np.int64))
    with pytest.raises(InvalidParameterError, match="block"):
        splat_weights(np.zeros((3, 3), np.int64), block=0)


def test_material_map_must_match_heightmap():
    from terrascape.errors import HeightmapSizeError

    hm = Heightmap(np.zeros((9, 11), np.float32))
    ok = splat_weights(np.zeros((8, 10), np.int64), 2, grid=hm)
    assert ok.shape == (2, 9, 11)
    with pytest.raises(HeightmapSizeError, match=r"10×8 \(cols×rows\) for a 11×9"):
        splat_weights(np.zeros((9, 11), np.int64), 2, grid=hm)
    with pytest.raises(HeightmapSizeError):
        splat_weights(np.zeros((8, 10), np.int64), 2, grid=(10, 10))
