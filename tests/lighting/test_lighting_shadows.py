from __future__ import annotations

import math

import numpy as np
import pytest

from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.lighting import (
    shadow_mask,
    shadow_mask_reference,
    soft_shadow,
)

# The seed's lightmap formula (terrascape.lighting.lightmap now defaults to the daylight
# model; the thesis's formula stays in lighting.shadows and as model="classic").
from terrascape.lighting.shadows import lightmap

METHODS = [shadow_mask, shadow_mask_reference]


def _anti_sun(az_deg):
    """Horizontal world direction (x, z) in which shadows fall (away from the sun)."""
    a = math.radians(az_deg)
    return np.array([-math.sin(a), math.cos(a)])


def _offsets(mask, centre, spacing):
    r, c = np.nonzero(mask)
    return np.stack([(c - centre[1]) * spacing[0], (r - centre[0]) * spacing[1]], axis=1)


# --- known geometry ----------------------------------------------------------------------------
@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("az", [0, 45, 90, 135, 180, 225, 270, 315])
@pytest.mark.parametrize("el", [20.0, 35.0])
def test_single_column_shadow_length_and_direction(method, az, el):
    n, height = 129, 20.0
    h = np.zeros((n, n), np.float32)
    h[64, 64] = height
    mask = method(h, az, el)
    assert not mask[64, 64]
    length = height / math.tan(math.radians(el))
    step = math.sqrt(2.0) if az % 90 else 1.0
    off = _offsets(mask, (64, 64), (1.0, 1.0))
    d = _anti_sun(az)
    along = off @ d
    across = off @ np.array([-d[1], d[0]])
    assert len(off) > 0
    np.testing.assert_allclose(across, 0.0, atol=1e-9)  # exactly on the line away from the sun
    assert (along > 0).all()
    assert length - step <= along.max() < length + 1e-9
    # contiguous: every sample of the line up to the far end is shadowed
    assert len(off) == round(along.max() / step)


@pytest.mark.parametrize("method", METHODS)
def test_column_shadow_with_anisotropic_spacing(method):
    dx, dz, height, el = 2.0, 0.5, 30.0, 25.0
    h = np.zeros((257, 129), np.float32)
    h[200, 100] = height
    hm = Heightmap(h, spacing=(dx, dz))
    length = height / math.tan(math.radians(el))
    for az, step in [(90, dx), (180, dz)]:
        off = _offsets(method(hm, az, el), (200, 100), (dx, dz))
        along = off @ _anti_sun(az)
        assert length - step <= along.max() < length + 1e-9
        np.testing.assert_allclose(off @ _anti_sun(az + 90), 0.0, atol=1e-9)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("az", [30.0, 110.0, 200.0, 290.0, 333.0])
def test_cylinder_shadow_in_any_direction(method, az):
    n, radius, height, el = 161, 3.0, 25.0, 30.0
    z, x = np.mgrid[0:n, 0:n]
    inside = np.hypot(x - 80, z - 80) <= radius
    h = np.where(inside, height, 0.0).astype(np.float32)
    mask = method(h, az, el) & ~inside
    off = _offsets(mask, (80, 80), (1.0, 1.0))
    d = _anti_sun(az)
    along = off @ d
    length = height / math.tan(math.radians(el))
    assert radius + length - 1.5 <= along.max() <= radius + length + 1.5
    mean = off.mean(axis=0)
    angle = math.degrees(math.atan2(mean[0] * d[1] - mean[1] * d[0], mean @ d))
    assert abs(angle) < 2.0
    # the shadow is about as wide as the column
    across = off @ np.array([-d[1], d[0]])
    assert 2 * radius - 1.5 <= across.max() - across.min() <= 2 * radius + 2.5


@pytest.mark.parametrize("method", METHODS)
def test_flat_plane_never_shadowed(method):
    hm = Heightmap(np.full((40, 50), 7.0), spacing=(1.5, 0.5))
    for az in (0.0, 17.0, 90.0, 201.5, 315.0):
        for el in (0.5, 5.0, 45.0, 90.0):
            assert not method(hm, az, el).any()


@pytest.mark.parametrize("method", [*METHODS, soft_shadow, lightmap])
def test_bad_light_and_heights_raise(method):
    h = np.zeros((8, 8))
    for el in (0.0, -10.0, 91.0, float("nan")):
        with pytest.raises(InvalidParameterError, match="elevation"):
            method(h, 45.0, el)
    with pytest.raises(InvalidParameterError, match="azimuth"):
        method(h, float("inf"), 30.0)
    bad = h.copy()
    bad[3, 3] = np.nan
    with pytest.raises(InvalidParameterError, match="NaN"):
        method(bad, 45.0, 30.0)


def test_overhead_sun_casts_no_shadow(terrain):
    h = terrain(33, 1)
    assert not shadow_mask(h, 10.0, 90.0).any()
    assert not shadow_mask_reference(h, 10.0, 90.0).any()


# --- fast vs reference -------------------------------------------------------------------------
def test_fast_equals_reference_on_axes_and_diagonals(terrain):
    h = terrain(65, 3)
    for az in range(0, 360, 45):
        for el in (8.0, 30.0):
            np.testing.assert_array_equal(
                shadow_mask(h, az, el), shadow_mask_reference(h, az, el), err_msg=f"{az} {el}"
            )


def test_near_walk_run_skip_changes_no_decision(terrain):
    """The near walk skips a step for runs of samples whose crossings cannot rise above their
    rays; with the skip and without it every line's near hits are the same."""
    from terrascape.lighting import shadows as sh

    rng = np.random.default_rng(7)
    # gentle terrain with needles: most runs skip under a high sun, the needles must not
    h = terrain(83, 5, relief=0.05, cols=101)
    needles = rng.integers(0, h.size, 60)
    h.flat[needles] += rng.uniform(5.0, 40.0, 60).astype(np.float32)
    hm = Heightmap(h)
    near = sh._NEAR
    total_skipped = 0
    for az in (0.0, 33.0, 45.0, 160.0, 200.0, 271.0):
        for el in (8.0, 35.0, 60.0):
            transpose, da, db, rise = sh._sweep_geometry(hm, sh.sun_above_horizon(az, el))
            o, _, _ = sh._oriented(hm, transpose)
            o = np.ascontiguousarray(o)
            segments = (o.shape[1] + sh._SEGMENT - 1) // sh._SEGMENT
            smax = np.empty((o.shape[0], segments))
            smin = np.empty((o.shape[0], segments))
            for a in range(o.shape[0]):
                sh._segment_extrema(o[a], smax[a], smin[a])
            skipped = np.zeros(near + 1, np.int64)
            for a in range(o.shape[0]):
                with_runs = np.zeros(o.shape[1], np.uint8)
                without = np.zeros(o.shape[1], np.uint8)
                sh._near_part(o, a, da, db, rise, near, 0, o.shape[1] - 1, with_runs, smax, smin,
                              1e-6, np.ones(near + 1, np.uint8), skipped)
                total_skipped += int(skipped.sum())
                sh._near_part(o, a, da, db, rise, near, 0, o.shape[1] - 1, without, smax, smin,
                              1e-6, np.zeros(near + 1, np.uint8), skipped)
                np.testing.assert_array_equal(with_runs, without, err_msg=f"{az} {el} line {a}")
                assert with_runs.any() or el > 8.0 or a in (0, o.shape[0] - 1)
    assert total_skipped > 1000  # the skip is exercised, not bypassed
    # and the whole sweep still equals the ray walk where it must (axes and diagonals)
    for az in (0.0, 45.0, 90.0, 225.0):
        for el in (10.0, 60.0):
            np.testing.assert_array_equal(shadow_mask(hm, az, el),
                                          shadow_mask_reference(hm, az, el), err_msg=f"{az}")


def test_fast_matches_reference_on_random_terrains_and_lights(terrain):
    """The fast sweep's decisions differ from the ray walk on a sub-sample band only."""
    rng = np.random.default_rng(2024)
    fractions, shadowed = [], []
    for i in range(24):
        rows = 97
        cols = 97 if i % 3 else 130
        spacing = (1.0, 1.0) if i % 4 else (1.5, 0.75)
        hm = Heightmap(terrain(rows, 100 + i, cols=cols), spacing=spacing)
        az = float(rng.uniform(0.0, 360.0))
        el = float(rng.uniform(5.0, 60.0))
        fast = shadow_mask(hm, az, el)
        ref = shadow_mask_reference(hm, az, el)
        fractions.append(float(np.mean(fast != ref)))
        shadowed.append(float(ref.mean()))
    print(
        f"\nfast vs reference disagreement over {len(fractions)} cases: "
        f"mean {np.mean(fractions):.4%}, max {np.max(fractions):.4%}"
    )
    assert max(fractions) <= 0.005, fractions
    assert np.mean(shadowed) > 0.15  # the comparison is not on trivially lit terrain


# --- soft shadows and lightmaps ----------------------------------------------------------------
def test_soft_shadow_penumbra_matches_sun_disc_geometry():
    """Behind a long wall the visible disc fraction follows the horizon angle atan(H/d)."""
    n, wall, height = 40, 300, 50.0
    h = np.zeros((n, 360), np.float32)
    h[:, wall] = height
    el, radius = 10.0, 2.0
    vis = soft_shadow(h, 90.0, el, sun_radius_deg=radius, samples=64)
    row = vis[n // 2]
    assert row[wall:].min() == 1.0  # the sunny side of the wall
    for c in range(wall - 400, wall):
        if c < 0:
            continue
        phi = math.degrees(math.atan(height / (wall - c)))
        u = min(1.0, max(-1.0, (phi - el) / radius))
        below = 0.5 + (u * math.sqrt(1 - u * u) + math.asin(u)) / math.pi
        assert abs(row[c] - (1.0 - below)) <= 1.0 / 64 + 1e-6, c
    # the penumbra really is a gradient: some samples strictly between 0 and 1
    assert ((row > 0.05) & (row < 0.95)).sum() >= 5
    assert np.all(np.diff(row[:wall]) <= 1e-6)  # darker toward the wall


def test_soft_shadow_zero_radius_is_hard_mask(terrain):
    h = terrain(65, 7)
    vis = soft_shadow(h, 123.0, 20.0, sun_radius_deg=0.0)
    np.testing.assert_array_equal(vis, (~shadow_mask(h, 123.0, 20.0)).astype(np.float32))


def test_lightmap_formula_flat_and_shadowed():
    el = 30.0
    flat = lightmap(np.zeros((10, 10)), 77.0, el, ambient=0.1)
    expect = min(1.0, 0.1 + 0.5 * (1.0 + math.sin(math.radians(el))))
    np.testing.assert_allclose(flat, expect, atol=1e-6)
    assert flat.dtype == np.float32

    h = np.zeros((64, 64), np.float32)
    h[32, 40] = 20.0
    mask = shadow_mask(h, 90.0, el)
    lm = lightmap(h, 90.0, el, ambient=0.1)
    np.testing.assert_allclose(lm[mask], 0.1)
    lit = ~mask
    lit[31:34, 39:42] = False  # the column's own slopes
    np.testing.assert_allclose(lm[lit], expect, atol=1e-6)
    no_shadow = lightmap(h, 90.0, el, ambient=0.1, shadows=False)
    far = mask.copy()
    far[31:34, 39:42] = False
    np.testing.assert_allclose(no_shadow[far], expect, atol=1e-6)
    ref = lightmap(h, 90.0, el, ambient=0.1, method="reference")
    np.testing.assert_array_equal(ref, lm)
    soft = lightmap(h, 90.0, el, ambient=0.1, soft=True)
    assert soft.min() >= 0.1 - 1e-6 and soft.max() <= 1.0
    assert (soft[mask] < expect).all()


def test_lightmap_clamps_to_one_and_validates():
    bright = lightmap(np.zeros((5, 5)), 0.0, 90.0, ambient=0.9)
    np.testing.assert_allclose(bright, 1.0)
    with pytest.raises(InvalidParameterError, match="ambient"):
        lightmap(np.zeros((5, 5)), 0.0, 45.0, ambient=1.5)
    with pytest.raises(InvalidParameterError, match="method"):
        lightmap(np.zeros((5, 5)), 0.0, 45.0, method="magic")


# --- the sweep split into blocks of ray lines (parallel) -----------------------------------
@pytest.mark.parametrize("shape", [(97, 97), (65, 130), (130, 65)])
@pytest.mark.parametrize("az", [0.0, 17.0, 45.0, 133.0, 200.0, 271.0, 333.0])
def test_sweep_in_blocks_equals_one_sweep(terrain, shape, az):
    """Any number of blocks (and so of threads) decides every sample as one serial sweep,
    and writes every sample."""
    from terrascape.lighting import shadows as sh

    hm = Heightmap(terrain(shape[0], 3, cols=shape[1]))
    for el in (6.0, 25.0):
        transpose, da, db, rise = sh._sweep_geometry(hm, sh.sun_above_horizon(az, el))
        results = []
        for blocks in (1, 2, 3, 8, 40):
            h, full, out = sh._oriented(hm, transpose)
            sh._line_sweep_kernel(h, da, db, rise, sh._NEAR, out, blocks)
            results.append(full)
            # every sample is written (the public function does not zero its mask first)
            h, full, out = sh._oriented(hm, transpose)
            full[:] = True
            sh._line_sweep_kernel(h, da, db, rise, sh._NEAR, out, blocks)
            results.append(full)
        for other in results[1:]:
            np.testing.assert_array_equal(other, results[0])
        # and the public function (its own block count) gives the same map
        np.testing.assert_array_equal(shadow_mask(hm, az, el), results[0])


@pytest.mark.parametrize("az", [0.0, 75.0, 105.0, 280.0])
def test_sweep_writes_a_transposed_mask_as_the_transposed_sweep(terrain, az):
    """Light near the x axis: the sweep of the transposed heights writes the mask in the
    map's own orientation (sample (a, b) to out[b, a]), the transpose of its own mask."""
    from terrascape.lighting import shadows as sh

    hm = Heightmap(terrain(90, 4, cols=71))
    transpose, da, db, rise = sh._sweep_geometry(hm, sh.sun_above_horizon(az, 9.0))
    h = np.ascontiguousarray(hm.heights.T if transpose else hm.heights)
    own = np.zeros(h.shape, dtype=np.bool_)
    sh._line_sweep_kernel(h, da, db, rise, sh._NEAR, own, 3)
    turned = np.zeros(h.shape[::-1], dtype=np.bool_)
    sh._line_sweep_kernel(h, da, db, rise, sh._NEAR, turned, 3, 0, 0, True)
    np.testing.assert_array_equal(turned, own.T)
    assert 0.02 < own.mean() < 0.9
    expected = own.T if transpose else own
    np.testing.assert_array_equal(shadow_mask(hm, az, 9.0), expected)


@pytest.mark.parametrize("shape", [(150, 211), (211, 150), (64, 97)])
@pytest.mark.parametrize("az", [75.0, 105.0, 260.0, 290.0])
def test_sweep_along_columns_equals_the_sweep_of_a_transposed_copy(terrain, shape, az):
    """Light near the x axis: sweeping the map's columns through bands of lines copied in
    cache (no transposed copy of the map) decides every sample as the sweep of the
    transposed copy does, for any number of blocks, a window's origin, a grid-line count
    that is not a whole number of bands, and either orientation of the output."""
    from terrascape.lighting import shadows as sh

    hm = Heightmap(terrain(shape[0], 6, cols=shape[1]))
    h = np.ascontiguousarray(hm.heights)
    copy = np.ascontiguousarray(h.T)
    for el in (4.0, 20.0):
        transpose, da, db, rise = sh._sweep_geometry(hm, sh.sun_above_horizon(az, el))
        assert transpose
        for blocks in (1, 3, 8):
            for a_org, b_org in ((0, 0), (37, 5)):
                for out_transposed in (False, True):
                    oshape = h.shape if out_transposed else copy.shape
                    want = np.zeros(oshape, dtype=np.bool_)
                    sh._line_sweep_kernel(copy, da, db, rise, sh._NEAR, want, blocks, a_org,
                                          b_org, out_transposed)
                    got = np.ones(oshape, dtype=np.bool_)  # every sample must be written
                    sh._line_sweep_kernel(h, da, db, rise, sh._NEAR, got, blocks, a_org,
                                          b_org, out_transposed, True)
                    np.testing.assert_array_equal(got, want)
        assert 0.01 < want.mean() < 0.95


def test_column_extrema_are_the_extrema_of_the_transposed_rows(terrain):
    """The run extrema of a transposed sweep, found across the map's rows, are the values
    the rows of a transposed copy give, and so is the largest magnitude."""
    from terrascape.lighting import shadows as sh

    h = terrain(83, 2, cols=70) - 5.0  # negative heights too: the magnitude is |h|
    copy = np.ascontiguousarray(h.T)
    segments = (h.shape[0] + sh._SEGMENT - 1) // sh._SEGMENT
    want_max = np.empty((h.shape[1], segments), h.dtype)
    want_min = np.empty_like(want_max)
    top = max(sh._segment_extrema(copy[a], want_max[a], want_min[a]) for a in range(len(copy)))
    got_max = np.empty_like(want_max)
    got_min = np.empty_like(want_max)
    magnitude = sh._column_extrema(h, got_max, got_min)
    np.testing.assert_array_equal(got_max, want_max)
    np.testing.assert_array_equal(got_min, want_min)
    assert magnitude.max() == top


def test_block_bounds_share_the_work():
    """Blocks of the ray lines: in order, covering every line once, of about equal work."""
    from terrascape.lighting import shadows as sh

    n0, n1 = 400, 300
    for e in (0.0, 0.4, -1.0, 1.0):
        first = -(n0 - 1) * max(e, 0.0) - 2.0
        nj = int(n1 + (n0 - 1) * abs(e)) + 5
        bounds = sh._block_bounds(n0, n1, e, first, nj, 4)
        assert bounds[0] == 0 and bounds[-1] == nj
        assert np.all(np.diff(bounds) >= 0)
        # crossings per line, counted sample by sample
        a = np.arange(n0)
        work = np.array([np.count_nonzero((first + i + a * e >= 0) & (first + i + a * e <= n1 - 1))
                         for i in range(nj)]) + 0.125 * n0
        shares = [work[bounds[k]:bounds[k + 1]].sum() / work.sum() for k in range(4)]
        assert max(shares) < 0.25 + 0.02, (e, shares)


def test_sweep_same_map_on_one_thread_and_two(terrain):
    import numba

    hm = Heightmap(terrain(257, 8))
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = shadow_mask(hm, 123.0, 12.0)
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        two = shadow_mask(hm, 123.0, 12.0)
    finally:
        numba.set_num_threads(before)
    np.testing.assert_array_equal(one, two)
    assert 0.02 < one.mean() < 0.9  # a real shadow map, not an empty one


def test_sweep_kernel_sees_one_array_type_for_every_light_direction(terrain, monkeypatch):
    """numba compiles the sweep once per argument type: heights (read-only) and the
    transposed copy made for light near the x axis must reach it as the same type, or a
    new installation compiles the sweep twice (seconds each)."""
    import numba

    from terrascape.lighting import shadows as sh

    seen = set()
    kernel = sh._line_sweep_kernel

    def recording(h, *args):
        seen.add((numba.typeof(h), numba.typeof(args[4])))
        return kernel(h, *args)

    monkeypatch.setattr(sh, "_line_sweep_kernel", recording)
    hm = Heightmap(terrain(65, 3, cols=80))
    transposed = []
    for az in (0.0, 45.0, 90.0, 133.0, 271.0):
        transposed.append(sh._sweep_geometry(hm, sh.sun_above_horizon(az, 20.0))[0])
        shadow_mask(hm, az, 20.0)
        shadow_mask(np.array(hm.heights), az, 20.0)  # a writable array too
    assert set(transposed) == {True, False}
    assert len(seen) == 1, seen
    [(h_type, out_type)] = seen
    assert not h_type.mutable and h_type.layout == "C" and out_type.layout == "C"


@pytest.mark.parametrize("az", [45.0, 135.0, 225.0, 315.0])
def test_diagonal_suns_sweep_the_map_untransposed_with_the_same_mask(az, monkeypatch):
    from terrascape.lighting import shadows
    from terrascape.lighting.sun import sun_direction

    rng = np.random.default_rng(5)
    hm = Heightmap((rng.random((97, 97)) * 30.0).astype(np.float32), 1.0)
    for el in (5.0, 20.0, 40.0):
        light = np.asarray(sun_direction(az, el))
        transpose, da, db, rise = shadows._sweep_geometry(hm, light)
        assert not transpose and abs(db) == 1.0
        mask = shadows._fast_mask_for_light(hm, light)
        assert 0 < mask.sum() < mask.size
        # the same step on the transposed map (where a one-ulp tie used to send it)
        monkeypatch.setattr(shadows, "_sweep_geometry",
                            lambda *_, g=(True, int(db), float(da), rise): g)
        assert np.array_equal(shadows._fast_mask_for_light(hm, light), mask)
        monkeypatch.undo()


def test_the_reference_told_to_stop_begins_no_more_grid_lines(terrain):
    """The flag an interrupted caller sets: with it, the rays cast per sample write nothing;
    without it, the same kernel gives the reference's mask."""
    from terrascape.lighting.shadows import _oriented, _reference_kernel, _sweep_geometry
    from terrascape.lighting.sun import sun_direction

    hm = Heightmap(terrain(65, 5))
    expected = shadow_mask_reference(hm, 200.0, 20.0)
    assert 0.05 < expected.mean() < 0.95
    transpose, da, db, rise = _sweep_geometry(hm, sun_direction(200.0, 20.0))
    for stop in (0, 1):
        h, full, out = _oriented(hm, transpose)
        full[:] = True  # so that an unwritten sample shows
        _reference_kernel(h, da, db, rise, float(hm.heights.max()), out,
                          np.array([stop], np.uint8))
        if stop:
            assert full.all()
        else:
            np.testing.assert_array_equal(full, expected)
