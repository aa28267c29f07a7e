"""Benchmark case terrain_vs_relief (Janković 2010 §2.7 Test 4): tiny sizes, results not speed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from terrascape.bench import terrain_vs_relief as tvr
from terrascape.errors import InvalidParameterError

SIZE = 65
VIEWPORT = (160, 90)


@pytest.fixture(scope="module")
def measured(gl_ctx):
    return {kind: tvr._measure(gl_ctx, size=SIZE, viewport=VIEWPORT, frames=2, kind=kind)
            for kind in ("seed", "mountains")}


def _by_method(results):
    return {r.method: r for r in results}


def test_terrain_quad_relief_surface_is_the_terrain():
    hm = tvr.terrain(17, "mountains")
    quad = tvr.terrain_quad(hm)
    eye = np.array([500.0, 2000.0, 500.0])  # above: the relief hangs below the top face
    basis = quad.uvd_basis(eye)
    rows, cols = hm.shape
    r, c = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    h01 = (hm.heights - hm.min) / (hm.max - hm.min)
    # texel (r, c) centre in UV, at depth d = 1 − normalised height
    uvd = np.stack([(c + 0.5) / cols, (r + 0.5) / rows, 1.0 - h01], -1)
    world = np.asarray(quad.origin) + uvd @ basis.T
    dx, dz = hm.spacing
    np.testing.assert_allclose(world[..., 0], c * dx, atol=1e-6)
    np.testing.assert_allclose(world[..., 2], r * dz, atol=1e-6)
    np.testing.assert_allclose(world[..., 1], hm.heights, atol=1e-3)


def test_terrain_kinds_and_bad_kind():
    for kind, cfg in tvr.TERRAINS.items():
        hm = tvr.terrain(33, kind)
        assert hm.min == pytest.approx(0.0) and hm.max == pytest.approx(cfg["relief"], rel=1e-6)
        assert hm.extent == (tvr.EXTENT, tvr.EXTENT)
    with pytest.raises(InvalidParameterError, match="terrain kind"):
        tvr.terrain(33, "moon")


@pytest.mark.gl
def test_speed_rows(measured):
    for results in measured.values():
        rows = _by_method(results)
        full = rows["polygons, full resolution"].triangles
        t1, t4, t16 = (rows[f"polygons, geomipmap τ={t:g} px"].triangles for t in (1, 4, 16))
        assert full == 2 * (SIZE - 1) ** 2
        assert 0 < t16 <= t4 <= t1 <= full
        for label, _, _ in tvr.QUAD_METHODS:
            assert rows[label].kind == "quad" and rows[label].triangles == 2
        for r in results:
            if r.kind == "floor":
                continue
            assert r.ms > 0 and math.isclose(r.fps, 1000.0 / r.ms)
    *speeds, quality = tvr.tables(measured, size=SIZE, viewport=VIEWPORT, frames=2,
                                  spacing=tvr.EXTENT / (SIZE - 1))
    assert len(speeds) == 2 and "seed scale" in speeds[0].title
    for speed in speeds:
        col = speed.columns.index
        rows = {row[col("method")]: row for row in speed.rows}
        assert len(rows) == len(speed.rows) == 7  # unique method labels (report plots them)
        tex = rows["texture mapping"]
        assert tex[col("× texture mapping")] == 1.0
        assert tex[col("seed FPS (config 2)")] == 824 and tex[col("seed × texture")] == 1.0
        relief = rows["relief 16+8"]
        assert relief[col("seed × texture")] == pytest.approx(55 / 824)
        assert relief[col("× texture mapping")] == pytest.approx(
            relief[col("frames/s")] / tex[col("frames/s")])
        full = rows["polygons, full resolution"]
        assert full[col("seed FPS (config 2)")].startswith("5 (1 LOD")
    assert len(quality.rows) == 2 * 8


@pytest.mark.gl
def test_quality_figures(measured):
    spacing = tvr.EXTENT / (SIZE - 1)
    for kind, results in measured.items():
        rows = _by_method(results)
        ref = rows["polygons, full resolution"]
        same = tvr.quality_figures(ref, ref, spacing)
        assert all(v == 0.0 for v in same.values())
        assert ref.covered.mean() > 0.1  # the terrain is in view (whole-terrain camera)
        tex = tvr.quality_figures(rows["texture mapping"], ref, spacing)
        relief = tvr.quality_figures(rows["relief 16+8"], ref, spacing)
        # Relief mapping shows the terrain sample the polygons show; the flat textured quad
        # shows the sample under the top plane — shifted along the view ray.
        assert relief["median_dxz"] < 0.25
        assert tex["median_dxz"] > 4 * relief["median_dxz"]
        assert relief["mean_dl_both"] < tex["mean_dl_both"]
        if kind == "seed":
            # Same colour texture, sun and Phong constants: where both see the terrain the
            # relief image matches the polygons within a few grey levels.
            assert relief["mean_dl_both"] < 3.0
