"""Terrain mesh geometry: positions, planar uvs, winding, chunks."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.mesh import banded_grid_triangles, grid_triangles, terrain_mesh


def test_positions_and_uvs(rng):
    h = rng.random((5, 7)).astype(np.float32)
    mesh = terrain_mesh(Heightmap(h, (2.0, 3.0)), uv_scale=4.0, exaggeration=1.5)
    assert mesh.positions.dtype == np.float32 and mesh.positions.shape == (35, 3)
    k = 3 * 7 + 5  # row 3, col 5
    np.testing.assert_allclose(mesh.positions[k], [5 * 2.0, h[3, 5] * 1.5, 3 * 3.0], rtol=1e-6)
    assert mesh.extent == (12.0, 12.0)
    np.testing.assert_allclose(mesh.uvs[k], [10.0 / 12 * 4, 9.0 / 12 * 4], rtol=1e-6)
    np.testing.assert_allclose(mesh.uvs[0], [0, 0])
    np.testing.assert_allclose(mesh.uvs[-1], [4, 4], rtol=1e-6)


def test_triangles_are_ccw_from_above_and_cover_grid():
    mesh = terrain_mesh(Heightmap(np.zeros((4, 6), np.float32)))
    tri = mesh.triangles
    assert tri.dtype == np.uint32 and tri.shape == (2 * 3 * 5, 3)
    p = mesh.positions.astype(np.float64)
    face_n = np.cross(p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]])
    assert (face_n[:, 1] > 0).all()  # CCW seen from +Y ⇒ front faces point up
    np.testing.assert_allclose(np.abs(face_n[:, 1]).sum() / 2, 3 * 5)  # total area
    # each cell appears once: the set of (min index) of triangles covers every cell corner
    assert len({tuple(sorted(t)) for t in tri.tolist()}) == len(tri)


def test_exaggeration_scales_normals():
    x = np.arange(9, dtype=np.float32)
    hm = Heightmap(np.tile(0.5 * x, (9, 1)))
    flat = terrain_mesh(hm).normals[40]
    steep = terrain_mesh(hm, exaggeration=4.0).normals[40]
    np.testing.assert_allclose(flat, np.array([-0.5, 1, 0]) / np.hypot(0.5, 1), atol=1e-6)
    np.testing.assert_allclose(steep, np.array([-2.0, 1, 0]) / np.hypot(2.0, 1), atol=1e-6)


def test_block_wise_frames_equal_whole_map_gradient(rng, monkeypatch):
    import importlib

    module = importlib.import_module("terrascape.mesh.terrain_mesh")
    h = rng.normal(size=(40, 11)).astype(np.float32)
    hm = Heightmap(h, (1.5, 0.5))
    monkeypatch.setattr(module, "_FRAME_BLOCK_ROWS", 7)
    mesh = terrain_mesh(hm)
    np.testing.assert_allclose(mesh.normals.reshape(40, 11, 3), hm.normals(), atol=1e-6)


def test_chunks_share_borders_and_cover_all_triangles():
    hm = Heightmap(np.arange(21 * 13, dtype=np.float32).reshape(21, 13))
    mesh = terrain_mesh(hm)
    chunks = mesh.chunks(9)
    assert [(c.row0, c.col0) for c in chunks][:3] == [(0, 0), (0, 8), (8, 0)]
    assert {(c.rows, c.cols) for c in chunks} == {(9, 9), (9, 5), (5, 9), (5, 5)}
    all_idx = np.concatenate([c.indices() for c in chunks]).reshape(-1, 3)
    assert sorted(map(tuple, all_idx.tolist())) == sorted(map(tuple, mesh.triangles.tolist()))
    assert sum(c.n_triangles for c in chunks) == mesh.n_triangles
    c = chunks[1]  # rows 0..8, cols 8..12
    ys = mesh.positions[:, 1].reshape(21, 13)[0:9, 8:13]
    assert c.bbox_min == (8.0, float(ys.min()), 0.0)
    assert c.bbox_max == (12.0, float(ys.max()), 8.0)


def test_grid_triangles_subgrid_uses_global_indices():
    t = grid_triangles(5, 5, row0=1, col0=2, n_rows=2, n_cols=2)
    assert t.tolist() == [[7, 12, 8], [8, 12, 13]]


def test_bad_arguments():
    hm = Heightmap(np.zeros((3, 3), np.float32))
    with pytest.raises(InvalidParameterError, match="uv_scale"):
        terrain_mesh(hm, uv_scale=0)
    with pytest.raises(InvalidParameterError, match="exaggeration"):
        terrain_mesh(hm, exaggeration=float("nan"))
    with pytest.raises(InvalidParameterError, match="Heightmap"):
        terrain_mesh(np.zeros((3, 3)))
    with pytest.raises(InvalidParameterError, match="2\\*\\*k"):
        terrain_mesh(hm).chunks(10)


def _vsplit_shaded(indices, segment=1024, slots=256):
    """Vertices a 1024-index-segment, 256-slot direct-mapped vertex cache shades (the model
    of Mesa's draw module vertex splitter, draw_pt_vsplit.c: hash = index % 256, cache
    cleared per segment)."""
    shaded = 0
    for s in range(0, len(indices), segment):
        cache = np.full(slots, -1, dtype=np.int64)
        for v in indices[s : s + segment]:
            if cache[v % slots] != v:
                cache[v % slots] = v
                shaded += 1
    return shaded


@pytest.mark.parametrize(
    ("rows", "cols", "band"), [(2, 2, 8), (9, 17, 8), (33, 20, 5), (65, 65, 8)]
)
def test_banded_triangles_are_the_grid_triangles_reordered(rows, cols, band):
    banded = banded_grid_triangles(rows, cols, band)
    plain = grid_triangles(rows, cols)
    assert banded.dtype == np.uint32 and banded.shape == plain.shape
    # same triangles with the same vertex order (winding and diagonal), only the order differs
    as_set = lambda t: {tuple(x) for x in t.tolist()}  # noqa: E731
    assert as_set(banded) == as_set(plain)
    assert len(as_set(banded)) == len(banded)


def test_banded_order_shades_each_vertex_about_once():
    # The renderer's 129² chunks: ~0.59 shaded vertices per triangle (0.5 is the floor for
    # a grid); the grid order of a 1025-wide map re-shades 2 per triangle in the same cache.
    banded = banded_grid_triangles(129, 129).reshape(-1)
    assert _vsplit_shaded(banded) / (len(banded) // 3) < 0.62
    wide = grid_triangles(1025, 1025, n_rows=9, n_cols=129).reshape(-1)
    assert _vsplit_shaded(wide) / (len(wide) // 3) > 1.9


def test_chunk_local_indices_address_the_chunk_vertices(rng):
    hm = Heightmap(rng.random((40, 37)).astype(np.float32))
    mesh = terrain_mesh(hm)
    pos = mesh.positions.reshape(mesh.rows, mesh.cols, 3)
    for c in mesh.chunks(17):
        local = pos[c.rows_slice, c.cols_slice].reshape(-1, 3)
        tri_local = local[c.local_indices().reshape(-1, 3)]
        tri_grid = mesh.positions[c.indices().reshape(-1, 3)]
        key = lambda t: sorted(map(tuple, t.reshape(-1, 9).tolist()))  # noqa: E731
        assert key(tri_local) == key(tri_grid)
