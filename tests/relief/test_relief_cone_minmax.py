import importlib

import numpy as np
import pytest

from terrascape.errors import HeightmapSizeError
from terrascape.relief.cone_map import cone_map, cone_map_bruteforce, footprint_cone_map
from terrascape.relief.fields import city_field, natural_field
from terrascape.relief.minmax_mip import minmax_mip
from terrascape.relief.prewarp import sample_bilinear


@pytest.mark.parametrize("field", ["city", "natural"])
def test_cone_map_equals_bruteforce_definition(field):
    h = city_field(16, block=8, street=2, seed=1) if field == "city" else natural_field(16)
    np.testing.assert_allclose(cone_map(h), cone_map_bruteforce(h), rtol=1e-6)


def test_cone_of_single_pit():
    h = np.ones((8, 8))
    h[4, 4] = 0.0  # one texel of depth 1; everything else at depth 0
    c = cone_map(h, c_max=5.0)
    assert c[4, 4] == pytest.approx(1.0 / 8)  # nearest higher texel one texel away
    assert np.all(np.delete(c.ravel(), 4 * 8 + 4) == 5.0)


def test_footprint_cones_are_empty_of_the_bilinear_surface():
    # From any point of texel i's footprint above the apex, the cone must not contain
    # any point of the bilinear surface: sample both densely and check.
    h = natural_field(16, seed=3)
    fc = footprint_cone_map(h)
    rng = np.random.default_rng(0)
    q = rng.uniform(0, 1, (4000, 2))
    dq = 1.0 - sample_bilinear(h, q, wrap=True)
    for _ in range(40):
        i, j = rng.integers(0, 16, 2)
        apex, ratio = fc[i, j]
        p = (np.array([j, i]) + 0.5 + rng.uniform(-0.5, 0.5, 2)) / 16
        d = np.abs(q - p)
        dist = np.hypot(*np.minimum(d, 1 - d).T)
        inside = dist < ratio * (apex - dq) - 1e-9
        assert not inside.any()
    assert (fc[..., 1] > 0).all()


def _footprint_cones_by_brute_force(h, c_max=1.0):
    """footprint_cone_map's definition over every cell at every offset its ring walk can
    reach ([-n/2 - 1, n/2] on each axis, wrapped), with numpy: the lowest box-to-box
    distance ÷ depth difference, capped at c_max."""
    from terrascape.relief.minmax_mip import corner_depths
    from terrascape.relief.reference import heights_to_depth

    depth = heights_to_depth(h)
    rows, cols = depth.shape
    cell_min = corner_depths(depth).min(axis=-1)
    apex = np.minimum(np.minimum(cell_min, np.roll(cell_min, 1, axis=1)),
                      np.minimum(np.roll(cell_min, 1, axis=0),
                                 np.roll(np.roll(cell_min, 1, axis=0), 1, 1)))
    reach = max(rows, cols) // 2
    offsets = np.arange(-reach - 1, reach + 1)
    oy, ox = np.meshgrid(offsets, offsets, indexing="ij")
    dist = np.hypot(np.maximum(0.0, np.abs(ox + 0.5) - 1.0) / cols,
                    np.maximum(0.0, np.abs(oy + 0.5) - 1.0) / rows)
    ratio = np.full(depth.shape, c_max)
    for r in range(rows):
        for c in range(cols):
            diff = apex[r, c] - cell_min[(r + oy) % rows, (c + ox) % cols]
            above = diff > 0.0
            if above.any():
                ratio[r, c] = min(c_max, float((dist[above] / diff[above]).min()))
    return apex, ratio


@pytest.mark.parametrize("field", ["city", "natural", "noise"])
def test_footprint_cones_equal_their_definition(field):
    """Every texel's cone against every cell its ring walk reaches: the walk visits each
    ring's cells (and only those) and stops only where no farther cell could narrow the
    cone."""
    h = {"city": lambda: city_field(16, block=8, street=2, seed=1),
         "natural": lambda: natural_field(16, seed=4),
         "noise": lambda: np.random.default_rng(2).random((16, 16))}[field]()
    fc = footprint_cone_map(h)
    apex, ratio = _footprint_cones_by_brute_force(h)
    np.testing.assert_allclose(fc[..., 0], apex, rtol=1e-6)
    np.testing.assert_allclose(fc[..., 1], ratio, rtol=1e-5)
    assert (ratio < 1.0).mean() > 0.3  # many cones are narrowed by some cell


def test_minmax_mip_bounds_every_cell():
    h = city_field(32, block=16, seed=2)
    levels = minmax_mip(h)
    assert [lv.shape[0] for lv in levels] == [32, 16, 8, 4, 2, 1]
    d = 1.0 - h
    rng = np.random.default_rng(1)
    q = rng.uniform(0, 1, (3000, 2))
    dq = 1.0 - sample_bilinear(h, q, wrap=True)
    cell = np.floor(q * 32 - 0.5).astype(int) % 32
    for k, lv in enumerate(levels):
        node = cell >> k
        lo = lv[node[:, 1], node[:, 0], 0]
        hi = lv[node[:, 1], node[:, 0], 1]
        assert (dq >= lo - 1e-6).all() and (dq <= hi + 1e-6).all()
    assert levels[-1][0, 0, 0] == d.min() and levels[-1][0, 0, 1] == d.max()
    with pytest.raises(HeightmapSizeError):
        minmax_mip(np.zeros((24, 24)))


def test_packed_minmax_mip_one_texel_per_node():
    # The quad tracer's single RGBA chain: level 0 = the four corner depths of each cell,
    # higher levels (min, max, min, max); the channel minimum is the node bound everywhere.
    from terrascape.relief.minmax_mip import cell_corners, packed_minmax_mip

    h = natural_field(16, seed=4)
    levels = minmax_mip(h)
    packed = packed_minmax_mip(h)
    assert [p.shape for p in packed] == [(lv.shape[0], lv.shape[1], 4) for lv in levels]
    d = 1.0 - h
    c = cell_corners(h)
    np.testing.assert_allclose(c[3, 5], [d[3, 5], d[3, 6], d[4, 5], d[4, 6]], rtol=1e-6)
    np.testing.assert_allclose(c[15, 15], [d[15, 15], d[15, 0], d[0, 15], d[0, 0]], rtol=1e-6)
    for p, lv in zip(packed, levels, strict=True):
        np.testing.assert_array_equal(p.min(axis=-1), lv[..., 0])
    np.testing.assert_array_equal(packed[2][..., 2:], levels[2])


@pytest.mark.parametrize("footprint", [False, True])
def test_the_cone_kernels_told_to_stop_begin_no_more_rows(footprint):
    """The flag an interrupted caller sets: rows not yet begun are left as they were."""
    cm = importlib.import_module("terrascape.relief.cone_map")  # the package face names
    # the function

    depth = 1.0 - natural_field(16, seed=3)
    for stop in (0, 1):
        out = np.full(depth.shape, -1.0)
        flag = np.array([stop], np.uint8)
        if footprint:
            cm._footprint_cone_kernel(depth, depth, 1.0, out, flag)
        else:
            cm._cone_kernel(depth, 1.0 / 16, 1.0 / 16, 1.0, out, flag)
        assert (out == -1.0).all() == bool(stop)
        assert (out == -1.0).any() == bool(stop)
