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


def _cells_and_apexes(h):
    """Each bilinear cell's lowest depth, and each texel's apex: the least of the four
    cells overlapping its footprint (footprint_cone_map's definitions)."""
    from terrascape.relief.minmax_mip import corner_depths
    from terrascape.relief.reference import heights_to_depth

    cell_min = corner_depths(heights_to_depth(h)).min(axis=-1)
    apex = np.minimum(np.minimum(cell_min, np.roll(cell_min, 1, axis=1)),
                      np.minimum(np.roll(cell_min, 1, axis=0),
                                 np.roll(np.roll(cell_min, 1, axis=0), 1, 1)))
    return cell_min, apex


def _footprint_cones_by_brute_force(h, c_max=1.0):
    """footprint_cone_map's definition over every cell at every offset its ring walk can
    reach ([-n/2 - 1, n/2] on each axis, wrapped), with numpy: the lowest box-to-box
    distance ÷ depth difference, capped at c_max."""
    cell_min, apex = _cells_and_apexes(h)
    rows, cols = cell_min.shape
    reach = max(rows, cols) // 2
    offsets = np.arange(-reach - 1, reach + 1)
    oy, ox = np.meshgrid(offsets, offsets, indexing="ij")
    dist = np.hypot(np.maximum(0.0, np.abs(ox + 0.5) - 1.0) / cols,
                    np.maximum(0.0, np.abs(oy + 0.5) - 1.0) / rows)
    ratio = np.full(cell_min.shape, c_max)
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


@pytest.mark.parametrize(("rows", "cols", "seed"), [(40, 56, 1), (64, 64, 2), (33, 47, 3)])
def test_cones_searched_by_blocks_equal_their_definition(rows, cols, seed):
    """Textures of several blocks a side, not multiples of the block, heights in a few
    steps (many cells tie at a texel's cone): every cone is the definition's, bit for bit.
    A ring of blocks stopped on its positive side's distance (the negative side is half a
    texel nearer in box distance) narrowed 1–3 cones of each map too little."""
    h = np.round(natural_field(64, seed=seed)[:rows, :cols] * 4) / 4
    fc = footprint_cone_map(h)
    apex, ratio = _footprint_cones_by_brute_force(h)
    np.testing.assert_array_equal(fc[..., 0], apex.astype(np.float32))
    np.testing.assert_array_equal(fc[..., 1], ratio.astype(np.float32))
    np.testing.assert_allclose(cone_map(h), cone_map_bruteforce(h), rtol=1e-6)
    assert (ratio < 1.0).mean() > 0.3


def _cones_from_few_cells(values, apex, footprint, c_max=1.0):
    """The cone definition where few cells lie above any texel's apex: every texel against
    each of those cells only, at the nearer of its two wrapped offsets on each axis (box to
    box with ``footprint``, else centre to centre)."""
    rows, cols = values.shape
    ky, kx = np.nonzero(values < apex.max())

    def gap(k, i, n):
        o = (k[None, None, :] - i) % n
        near = np.minimum(np.abs(o + 0.5), np.abs(o - n + 0.5))
        if footprint:
            return np.maximum(0.0, near - 1.0) / n
        return np.minimum(o, n - o) / n

    gy = gap(ky, np.arange(rows)[:, None, None], rows)
    gx = gap(kx, np.arange(cols)[None, :, None], cols)
    diff = (apex[:, :, None] - values[ky, kx][None, None, :]).astype(np.float64)
    ratio = np.where(diff > 0.0, np.sqrt(gx * gx + gy * gy) / np.where(diff > 0, diff, 1.0),
                     np.inf)
    return np.minimum(c_max, ratio.min(axis=-1))


@pytest.mark.parametrize("seed", [7, 8, 9])
@pytest.mark.parametrize("footprint", [False, True])
def test_wide_cones_searched_by_groups_of_blocks(footprint, seed):
    """A deep flat texture with a few high points: most cones reach tens of texels, past the
    rings searched block by block, into the groups of blocks. Each cone is the definition's.
    (It failed when the groups' search skipped one ring of blocks more than the first
    search had made, and when a ring of groups stopped on its positive side's distance.)"""
    from terrascape.relief.reference import heights_to_depth

    rng = np.random.default_rng(seed)
    h = np.zeros((192, 176))
    h[rng.integers(0, 192, 5), rng.integers(0, 176, 5)] = rng.uniform(0.2, 1.0, 5)
    if footprint:
        got = footprint_cone_map(h)[..., 1]
        values, apex = _cells_and_apexes(h)
    else:
        got = cone_map(h)
        values = apex = heights_to_depth(h)
    want = _cones_from_few_cells(values, apex, footprint)
    np.testing.assert_allclose(got, want, rtol=1e-6)
    # a search ends where a ring's distance ÷ the deepest possible difference reaches the
    # cone: most reach past the four rings of 8-texel blocks
    reach = want * (apex - values.min()) * 192
    assert np.median(reach) > 40


def test_cones_of_a_smooth_field_through_groups_of_blocks():
    """A smooth field of 150×130 texels: many cones are found in the groups of blocks, past
    cones found in nearer ones, so a group's bound decides. Every cone is the definition's
    (a group bound 8 texels too eager on one axis got 32 wrong)."""
    h = natural_field(256, seed=2)[:150, :130]
    _, ratio = _footprint_cones_by_brute_force(h)
    np.testing.assert_array_equal(footprint_cone_map(h)[..., 1], ratio.astype(np.float32))


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
        cm._cone_kernel(depth, depth, footprint, 1.0, out, flag)
        assert (out == -1.0).all() == bool(stop)
        assert (out == -1.0).any() == bool(stop)
