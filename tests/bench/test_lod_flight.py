"""The LOD flight benchmark on tiny maps: the figures it prints must be consistent."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from terrascape.bench import lod_flight as lf
from terrascape.errors import InvalidParameterError

VIEWPORT = (160, 90)


def _gm_and_camera(target_side=65):
    from terrascape.lod import Geomipmap

    hm = lf._terrain(target_side)
    cam = lf._flight(hm, 1, VIEWPORT)[0]
    return Geomipmap(hm, 17), cam


def test_bisect_tolerance_is_the_smallest_tau_within_target():
    gm, cam = _gm_and_camera()
    gm.update(cam, VIEWPORT, 1e-3, cull=True)
    full = gm.triangle_count()
    target = full // 3
    tau, n = lf.bisect_tolerance(gm, cam, VIEWPORT, target, rel=1e-3)
    assert 0 < n <= target
    gm.update(cam, VIEWPORT, tau, cull=True)
    assert gm.triangle_count() == n  # gm is left at the returned τ
    # tight: a τ just below the result (beyond the bisection precision) exceeds the target
    gm.update(cam, VIEWPORT, tau / 1.002, cull=True)
    assert gm.triangle_count() > target
    # the count is non-increasing in τ (what the bisection relies on)
    counts = []
    for t in np.geomspace(1e-3, 1e3, 25):
        gm.update(cam, VIEWPORT, float(t), cull=True)
        counts.append(gm.triangle_count())
    assert all(a >= b for a, b in itertools.pairwise(counts))
    assert counts[0] == full > counts[-1]


def test_bisect_tolerance_edges_and_bad_input():
    gm, cam = _gm_and_camera()
    gm.update(cam, VIEWPORT, 1e-3, cull=True)
    full = gm.triangle_count()
    assert lf.bisect_tolerance(gm, cam, VIEWPORT, full) == (1e-3, full)  # already fits
    tau, n = lf.bisect_tolerance(gm, cam, VIEWPORT, 1)  # below the coarsest mesh
    assert tau == 1e6 and n > 1
    with pytest.raises(InvalidParameterError, match="target"):
        lf.bisect_tolerance(gm, cam, VIEWPORT, 0)
    with pytest.raises(InvalidParameterError, match="lo < hi"):
        lf.bisect_tolerance(gm, cam, VIEWPORT, 10, lo=2.0, hi=1.0)
    with pytest.raises(InvalidParameterError, match="unknown algorithm"):
        lf._lod_driver("bogus", gm.heightmap, 10, cam, VIEWPORT)


@pytest.mark.gl
def test_flight_table_is_consistent(gl_ctx):
    target = 2000
    table, results = lf._size_table(gl_ctx, (65,), 3, VIEWPORT, target=target)
    assert [r.algorithm for r in results] == [*lf.ALGORITHMS, lf.FULL_RES]
    assert len(table.rows) == 4 and len(table.rows[0]) == len(table.columns)
    full = results[-1]
    for r, row in zip(results, table.rows, strict=True):
        assert len(r.frame_ms) == 3 and (r.triangles > 0).all()
        # the frame contains the LOD update, the upload and the draw
        assert (r.frame_ms >= r.lod_ms).all() and (r.frame_ms >= r.draw_ms).all()
        np.testing.assert_allclose(r.frame_ms, r.lod_ms + r.upload_ms + r.draw_ms, rtol=1e-9)
        assert r.fps == pytest.approx(1000.0 / float(np.median(r.frame_ms)))
        fps_col = row[table.columns.index("frames/s")]
        frame_col = row[table.columns.index("frame ms (median)")]
        assert fps_col == pytest.approx(1000.0 / frame_col)
        # every algorithm drew terrain over the same part of the last frame
        assert r.coverage > 0.05
        assert abs(r.coverage - full.coverage) < 0.02
    roam, turner, gm, _ = results
    assert (roam.triangles <= target).all()
    assert (turner.triangles <= 2 * 64 * 64).all()
    assert gm.tau_px > 0 and 0 < gm.first_triangles <= target
    assert table.rows[2][table.columns.index("τ px")] == pytest.approx(gm.tau_px)
    assert table.rows[0][table.columns.index("τ px")] == ""
    # full resolution: the renderer's culled chunks of the 64×64-cell grid
    assert 0 < full.triangles.max() <= 2 * 64 * 64
    assert (full.lod_ms < 1.0).all()
    assert any("llvmpipe" in n or "GL:" in n for n in table.notes)


@pytest.mark.gl
def test_target_table_follows_the_target(gl_ctx):
    targets = (600, 2400)
    table, res = lf._target_table(gl_ctx, 65, targets, 2, VIEWPORT)
    assert [row[0] for row in table.rows] == list(targets)
    # one column group per SCHEMES entry, the layout the report's figures read
    assert table.columns == [
        "target", "ROAM triangles", "ROAM frames/s", "Turner triangles", "Turner frames/s",
        "geomipmap τ px", "geomipmap triangles", "geomipmap frames/s"]
    assert all(len(row) == len(table.columns) for row in table.rows)
    for t in targets:
        roam, turner, gm = res[t]
        assert (roam.triangles <= t).all()
        assert 0 < gm.first_triangles <= t
        for r in (roam, turner, gm):
            assert math.isfinite(r.fps) and r.fps > 0
    lo, hi = res[600], res[2400]
    assert hi[0].triangles.mean() > lo[0].triangles.mean()  # ROAM
    assert hi[1].triangles.mean() > lo[1].triangles.mean()  # Turner
    assert hi[2].tau_px < lo[2].tau_px  # geomipmap: a bigger budget needs a smaller τ
