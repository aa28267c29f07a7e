"""The Panda3D GeoMipTerrain head-to-head: mesh extraction, measurement and the skip path."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from terrascape.bench import lod_peers as lp
from terrascape.heightmap import Heightmap


@pytest.fixture(scope="module")
def core():
    pytest.importorskip("panda3d")
    found = lp._import_panda()
    assert found is not None
    return found[0]


def _map(n=65, seed=3):
    # asymmetric (a ramp along rows plus noise) so a flipped orientation cannot match
    rng = np.random.default_rng(seed)
    r, c = np.mgrid[0:n, 0:n]
    h = 3.0 * r + 0.5 * c + rng.uniform(0, 20, (n, n))
    return Heightmap(h.astype(np.float32), spacing=(10.0, 10.0))


def _generated(core, hm, block, *, near_m=None, far_m=None, factor_m=None, cam=None):
    from terrascape.camera import Camera

    t = lp.panda_terrain(core, hm, block, near_m=near_m, far_m=far_m, factor_m=factor_m)
    cam = cam or Camera(position=(0.0, 500.0, 0.0), pitch=-30.0, near=1.0, far=5000.0)
    lp.set_focal_point(t, hm, cam)
    t.generate()
    return t


def test_extracted_mesh_matches_heights_and_covers_the_grid(core):
    from terrascape.lod import conformity_report
    from terrascape.lod.mesh_checks import sample_errors

    hm = _map()
    span = float(hm.max - hm.min)
    # near/far in metres: mixed levels (focal point at the north-west corner)
    t = _generated(core, hm, 16, near_m=150.0, far_m=700.0)
    tris, mismatch = lp.panda_triangles(core, t, hm)
    assert tris.shape[1] == 3 and tris.dtype == np.int64
    # vertex heights read from Panda equal the heightmap at the mapped indices (16-bit
    # quantisation only): this is what proves the row/col orientation
    assert mismatch <= span / 65535.0 + 1e-3
    rep = conformity_report(tris, hm.shape)
    assert rep.area_actual == rep.area_expected == 64 * 64
    assert rep.wrong_orientation == 0 and rep.degenerate == 0
    assert rep.ok, str(rep)
    # every sample is covered (sample_errors raises on holes) and some are approximated
    err = sample_errors(hm, tris)
    assert err.max() > 0
    # several levels: fewer than the full-resolution triangles, more than all-coarsest
    assert 2 * 4 * 4 < len(tris) < 2 * 64 * 64


def test_orientation_check_catches_a_flipped_map(core):
    hm = _map()
    flipped = hm.with_heights(np.ascontiguousarray(hm.heights[::-1]))
    t = _generated(core, flipped, 16, near_m=150.0, far_m=700.0)
    _, mismatch = lp.panda_triangles(core, t, hm)
    assert mismatch > 10.0  # the ramp: rows differ by metres


def test_extremes_full_resolution_and_coarsest(core):
    hm = _map()
    rows, cols = hm.shape
    # near beyond the map: every block at level 0 -> the full grid, each cell 2 triangles
    t = _generated(core, hm, 16, near_m=1e6, far_m=2e6)
    tris, _ = lp.panda_triangles(core, t, hm)
    assert len(tris) == 2 * (rows - 1) * (cols - 1)
    assert np.array_equal(np.unique(tris), np.arange(rows * cols))
    # tiny factor: every block at the coarsest level -> 2 triangles per 16×16 block
    t = _generated(core, hm, 16, factor_m=1e-3)
    tris, _ = lp.panda_triangles(core, t, hm)
    assert len(tris) == 2 * 4 * 4
    corners = {r * cols + c for r in range(0, rows, 16) for c in range(0, cols, 16)}
    assert set(np.unique(tris).tolist()) == corners


def test_vertex_reader_agrees_with_buffer_read(core):
    hm = _map()
    t = _generated(core, hm, 16, near_m=150.0, far_m=700.0)
    path = t.getRoot().findAllMatches("**/+GeomNode")[0]
    geom = path.node().getGeom(0)
    vdata = geom.getVertexData()
    fast = lp._vertex_positions(core, vdata)
    idx = np.unique(lp._primitive_indices(core, geom.getPrimitive(0)))
    reader = core.GeomVertexReader(vdata, "vertex")
    for i in idx[:50]:
        reader.setRow(int(i))
        assert np.allclose(tuple(reader.getData3()), fast[i])


def test_comparison_counts_and_errors_are_measured(core):
    from terrascape.bench.lod_roam import _flight, _terrain
    from terrascape.lod import conformity_report
    from terrascape.lod.mesh_checks import frustum_mask, screen_errors

    hm = _terrain(129)
    cam = _flight(hm, 1)[0]
    r = lp.compare_at_camera(core, hm, cam, ("test", 16, 50.0, 400.0, None))
    meshes = r["meshes"]
    mask = frustum_mask(hm, cam)
    worst = {
        k: float(screen_errors(hm, m, cam, lp.VIEWPORT)[mask].max()) for k, m in meshes.items()
    }
    assert worst["panda"] == pytest.approx(r["panda_error"]) and worst["panda"] > 0
    # ours meet Panda's measured worst error (re-measured here, not taken from the dict)
    assert worst["roam"] <= worst["panda"] and worst["geomipmap"] <= worst["panda"]
    for key, name in (("roam", "roam"), ("geomipmap", "gm")):
        assert len(meshes[key]) == r[f"{name}_triangles"]
        assert r[f"{name}_ratio"] == len(meshes[key]) / len(meshes["panda"])
        assert conformity_report(meshes[key], hm.shape).ok
    assert r["panda_triangles"] == len(meshes["panda"])
    assert r["roam_direct_ratio"] == r["roam_direct_triangles"] / r["panda_triangles"]
    assert r["roam_in_view_ratio"] == lp.in_view_count(meshes["roam"], mask) / r["panda_in_view"]
    # ROAM at τ = ε is measured too, and its bound is conservative
    assert r["roam_direct_error"] <= r["panda_error"]


@pytest.mark.parametrize("cull", [False, True])
def test_like_for_like_comparison_is_measured(core, cull):
    from terrascape.bench.lod_roam import _terrain
    from terrascape.lod import Roam
    from terrascape.lod.mesh_checks import frustum_mask, screen_errors

    hm = _terrain(129)
    setting = lp.settings_for_map(hm)[1]
    r = lp.fair_compare(core, hm, setting, 90.0, cull=cull)
    cam = lp.fair_camera(hm, 90.0)
    # the eye is above the centre, at the stated height over the ground
    assert cam.position[0] == pytest.approx(hm.extent[0] / 2)
    assert cam.position[1] == pytest.approx(float(hm.heights[64, 64]) + lp.FAIR_EYE_HEIGHT_M)
    # rebuild ROAM at the bisected τ and re-measure: everywhere without culling, in view
    # with it; its count is the whole mesh, or the triangles with a corner in view
    roam = Roam(hm)
    roam.update(cam, lp.VIEWPORT, tolerance_px=r["roam_tau"], cull=cull)
    tris = roam.triangles()
    mask = frustum_mask(hm, cam) if cull else np.ones(hm.shape, bool)
    err = screen_errors(hm, tris, cam, lp.VIEWPORT)[mask].max()
    assert err == pytest.approx(r["roam_error"]) and err <= r["panda_error"]
    assert r["roam_triangles"] == (lp.in_view_count(tris, mask) if cull else len(tris))
    assert r["roam_ratio"] == r["roam_triangles"] / r["panda_triangles"]
    assert r["gm_error"] <= r["panda_error"] and r["panda_error"] > 0


def test_bisect_tau_finds_the_largest_tolerance():
    # error(τ) = floor(τ)/2, a monotone step: the largest τ with error ≤ 3 is just below 7
    def mesh_for(tau):
        return np.array([[0, 1, 2]] * (1 + int(100 / (1 + tau))))

    def err(tau):
        return np.floor(tau) / 2.0

    last = {}

    def measure(tris):
        return err(last["tau"])

    def wrapped(tau):
        last["tau"] = tau
        return mesh_for(tau)

    tau, tris, e = lp.bisect_tau(wrapped, measure, 3.0, steps=30)
    assert e <= 3.0 and 6.99 < tau < 7.0
    assert len(tris) == len(mesh_for(tau))
    # a zero target (full-resolution peer) goes down to where the error is 0
    tau0, _, e0 = lp.bisect_tau(wrapped, measure, 0.0)
    assert e0 == 0.0 and tau0 < 1.0


def test_in_view_count():
    mask = np.zeros((3, 3), bool)
    mask[0, 0] = True
    tris = np.array([[0, 3, 1], [4, 7, 5], [1, 4, 2]])
    assert lp.in_view_count(tris, mask) == 1


def test_skip_table_without_panda(monkeypatch):
    monkeypatch.setitem(sys.modules, "panda3d", None)
    monkeypatch.setitem(sys.modules, "panda3d.core", None)
    tables = lp.run(quick=True)
    assert len(tables) == 1
    assert tables[0].rows == [["skipped"]]
    assert "pip install 'terrascape[bench]'" in tables[0].notes[0]


def test_quick_run_tables(core):
    tables = lp.run(quick=True)
    assert len(tables) == 3
    fair, tri, timing = tables
    fcol = fair.columns.index
    assert len(fair.rows) == len(lp.SETTINGS) * (1 + len(lp.FAIR_YAWS))
    for row in fair.rows:
        assert row[fcol("ROAM px")] <= row[fcol("Panda worst px")]
        assert row[fcol("geomipmap px")] <= row[fcol("Panda worst px")]
    assert sorted(t.what.endswith("no culling") for t in fair.targets) == [False, True]
    assert len(tri.rows) == len(lp.SETTINGS) and all(len(r) == len(tri.columns) for r in tri.rows)
    col = tri.columns.index
    for row in tri.rows:
        eps = row[col("Panda worst px ε")]
        assert row[col("ROAM px")] <= eps and row[col("geomipmap px")] <= eps
        assert row[col("ROAM ratio")] == pytest.approx(
            row[col("ROAM triangles")] / row[col("Panda triangles")]
        )
        assert row[col("Panda conforming (T-junctions)")].endswith(")")
    assert len(timing.rows) == 1 and timing.rows[0][1] > 0
