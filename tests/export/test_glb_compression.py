"""Meshopt-compressed and uint16-split glb: validator clean, decoded by glTF-Transform with
meshoptimizer's JavaScript decoder and by trimesh, positions checked against the terrain."""

from __future__ import annotations

import meshoptimizer
import numpy as np
import pygltflib
import pytest

from terrascape import Heightmap
from terrascape.cli import run_app
from terrascape.export.glb import build_glb
from terrascape.export.meshing import rtin_rectangle, terrain_mesh, uint16_parts
from terrascape.generate import diamond_square

trimesh = pytest.importorskip("trimesh")


_COMPONENT_SCALE = {5120: 127.0, 5121: 255.0, 5122: 32767.0, 5123: 65535.0}


@pytest.fixture(scope="module")
def terrain() -> Heightmap:
    hm = diamond_square(129, roughness=0.55, seed=3, spacing=10.0).normalised(100.0, 900.0)
    return Heightmap(hm.heights[:, :121].copy(), hm.spacing)  # not square, not 2**n + 1


def _world_positions(node: dict, attribute: dict) -> np.ndarray:
    raw = np.asarray(attribute["array"], np.float64).reshape(-1, attribute["size"])
    if attribute["normalized"]:
        raw = np.maximum(raw / _COMPONENT_SCALE[attribute["componentType"]], -1.0)
    matrix = np.asarray(node["world"], np.float64).reshape(4, 4).T  # column-major
    return raw @ matrix[:3, :3].T + matrix[:3, 3]


def _assert_same_triangles_rotated(got: np.ndarray, want: np.ndarray) -> None:
    """Triangle ``i`` decoded is triangle ``i`` written, up to a cyclic rotation of its corners
    (meshopt's index codec may rotate a triangle; the winding is kept)."""
    assert got.shape == want.shape
    same = np.zeros(len(want), bool)
    for shift in range(3):
        same |= (np.roll(want, -shift, axis=1) == got).all(axis=1)
    assert same.all()


def _check_against_terrain(world: np.ndarray, hm: Heightmap, step: np.ndarray) -> None:
    """Every decoded vertex lies on a grid sample and has that sample's height, within half
    a quantization step per axis."""
    dx, dz = hm.spacing
    col, row = np.rint(world[:, 0] / dx).astype(int), np.rint(world[:, 2] / dz).astype(int)
    assert np.all(np.abs(world[:, 0] - col * dx) <= step[0] / 2 + 1e-6)
    assert np.all(np.abs(world[:, 2] - row * dz) <= step[2] / 2 + 1e-6)
    assert col.min() >= 0 and col.max() < hm.cols and row.min() >= 0 and row.max() < hm.rows
    assert np.all(np.abs(world[:, 1] - hm.heights[row, col]) <= step[1] / 2 + 1e-4)


def test_compressed_glb_is_small_valid_and_decodes_to_the_terrain(
        terrain, tmp_path, gltf_validator, gltf_transform_reader):
    tri = rtin_rectangle(terrain, max_error=0.5)
    plain, _ = build_glb(terrain, tri, texture=False)
    data, mesh = build_glb(terrain, tri, texture=False, compress=True)
    assert len(data) <= 0.45 * len(plain)
    path = tmp_path / "c.glb"
    path.write_bytes(data)
    issues = gltf_validator(path)
    assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, issues["messages"]
    doc = pygltflib.GLTF2.load_from_bytes(data)
    assert set(doc.extensionsRequired) == {"EXT_meshopt_compression", "KHR_mesh_quantization"}
    assert doc.buffers[1].extensions["EXT_meshopt_compression"] == {"fallback": True}

    read = gltf_transform_reader(path)
    (node,) = [n for n in read["nodes"] if n["primitives"]]
    (prim,) = node["primitives"]
    world = _world_positions(node, prim["attributes"]["POSITION"])
    step = 2.0 * np.asarray(doc.nodes[1].scale) / 65534.0
    assert np.all(np.abs(world - mesh.positions) <= step / 2 + 1e-6)
    _check_against_terrain(world, terrain, step)
    _assert_same_triangles_rotated(np.asarray(prim["indices"]).reshape(-1, 3), mesh.faces)
    # the same triangles (as sample triples) as the RTIN mesh, whatever the order
    decoded = np.sort(mesh.grid_index[np.asarray(prim["indices"]).reshape(-1, 3)], axis=1)
    expected = np.sort(tri.astype(np.int64), axis=1)
    assert {tuple(t) for t in decoded} == {tuple(t) for t in expected}
    normals = np.asarray(prim["attributes"]["NORMAL"]["array"]).reshape(-1, 3) / 127.0
    np.testing.assert_allclose(normals, mesh.normals, atol=0.5 / 127 + 1e-6)


def test_meshoptimizer_decodes_each_view_to_the_uncompressed_bytes(terrain):
    """Lossless: every compressed vertex view decodes (meshoptimizer's C decoder) to exactly
    the bytes the uncompressed quantized glb of the same mesh holds, every index view to the
    same triangles."""
    from terrascape.export.glb import compression_ordered, glb_document

    mesh = compression_ordered(terrain_mesh(terrain, rtin_rectangle(terrain, max_error=1.0)))
    packed = glb_document(mesh, quantize=True, compress=True)
    loose = glb_document(mesh, quantize=True)
    packed_blob, loose_blob = packed.binary_blob(), loose.binary_blob()
    assert len(packed.bufferViews) == len(loose.bufferViews) == 4
    for view, reference in zip(packed.bufferViews, loose.bufferViews, strict=True):
        ext = view.extensions["EXT_meshopt_compression"]
        encoded = packed_blob[ext["byteOffset"]:ext["byteOffset"] + ext["byteLength"]]
        want = loose_blob[reference.byteOffset:reference.byteOffset + reference.byteLength]
        if ext["mode"] == "TRIANGLES":
            got = meshoptimizer.decode_index_buffer(ext["count"], ext["byteStride"], encoded)
            # the binding decodes into a uint32 array whatever the index size
            got = got.view(f"<u{ext['byteStride']}")[:ext["count"]]
            _assert_same_triangles_rotated(
                np.asarray(got).astype(np.int64).reshape(-1, 3),
                np.frombuffer(want, f"<u{ext['byteStride']}").astype(np.int64).reshape(-1, 3))
        else:
            got = meshoptimizer.decode_vertex_buffer(
                ext["count"], ext["byteStride"], encoded,
                dtype=np.dtype((np.uint8, ext["byteStride"]))).tobytes()
            assert got == want
        assert view.byteLength == reference.byteLength


def _canonical(triangles: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Triangles ``(M, 3, 3)`` (corner coordinates) as sorted rows of corner ids (rows of
    ``corners``), each rotated to start at its smallest id: winding kept, starting corner and
    triangle order ignored."""
    flat = triangles.reshape(-1, 3)
    order = np.lexsort(corners.T[::-1])
    sorted_corners = corners[order]
    pos = np.searchsorted(sorted_corners.view([("", corners.dtype)] * 3).ravel(),
                          np.ascontiguousarray(flat).view([("", flat.dtype)] * 3).ravel())
    ids = order[pos].reshape(-1, 3)
    assert np.array_equal(corners[ids.reshape(-1)], flat)  # every corner is a vertex
    first = ids.argmin(axis=1)
    rotated = ids[np.arange(len(ids))[:, None], (first[:, None] + np.arange(3)) % 3]
    return rotated[np.lexsort(rotated.T[::-1])]


def test_uint16_parts_fit_and_give_back_the_mesh():
    rng = np.random.default_rng(5)
    faces = rng.integers(0, 400, size=(3000, 3))
    parts = uint16_parts(faces, max_vertices=60)
    assert len(parts) > 10
    for ids, local in parts:
        assert len(ids) < 60 and local.max() < len(ids)
    np.testing.assert_array_equal(np.concatenate([ids[local] for ids, local in parts]), faces)
    # greedy: no part could have taken the next triangle as well
    start = 0
    for _, local in parts[:-1]:
        stop = start + len(local)
        assert np.unique(faces[start:stop + 1]).size >= 60
        start = stop


def test_split_glb_has_uint16_primitives_whose_union_is_the_mesh(tmp_path, gltf_validator,
                                                                 gltf_transform_reader):
    rng = np.random.default_rng(2)
    hm = Heightmap(rng.random((257, 256)).astype(np.float32) * 50)
    tri = rtin_rectangle(hm, max_error=0.0)
    whole = terrain_mesh(hm, tri)
    assert len(whole.positions) == 257 * 256 > 65535
    data, mesh = build_glb(hm, tri, texture=False, split_uint16=True)
    path = tmp_path / "s.glb"
    path.write_bytes(data)
    issues = gltf_validator(path)
    assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, issues["messages"]
    doc = pygltflib.GLTF2.load(path)
    prims = doc.meshes[0].primitives
    assert len(prims) >= 2
    for p in prims:
        acc = doc.accessors[p.indices]
        assert acc.componentType == pygltflib.UNSIGNED_SHORT and acc.max[0] < 65535
    scene = trimesh.load(path, process=False)
    geoms = list(scene.geometry.values())
    assert len(geoms) == len(prims)
    vertices = np.concatenate([g.vertices for g in geoms])
    triangles = np.concatenate([g.vertices[g.faces] for g in geoms])  # (M, 3 corners, xyz)
    for g in geoms:
        assert len(g.vertices) < 65536 and g.faces.max() < 65536
    # same vertex set, and the same triangles (corner coordinates, winding kept)
    whole_vertices = mesh.positions.astype(np.float32)
    assert np.array_equal(np.unique(vertices, axis=0), np.unique(whole_vertices, axis=0))
    want = whole_vertices[mesh.faces.astype(np.int64)]
    assert len(triangles) == len(want)
    assert np.array_equal(_canonical(triangles, whole_vertices),
                          _canonical(want, whole_vertices))
    # compressed and split: glTF-Transform decodes every primitive with 16-bit indices
    data, mesh = build_glb(hm, tri, texture=False, split_uint16=True, compress=True)
    path.write_bytes(data)
    read = gltf_transform_reader(path)
    (node,) = [n for n in read["nodes"] if n["primitives"]]
    assert len(node["primitives"]) >= 2
    step = 2.0 * np.asarray(pygltflib.GLTF2.load(path).nodes[1].scale) / 65534.0
    count = 0
    for prim in node["primitives"]:
        assert prim["indexType"] == pygltflib.UNSIGNED_SHORT
        assert max(prim["indices"]) < 65535
        world = _world_positions(node, prim["attributes"]["POSITION"])
        _check_against_terrain(world, hm, step)
        count += len(prim["indices"]) // 3
    assert count == len(tri)


def test_cli_mesh_compress_and_uint16(tmp_path, gltf_validator):
    hm = diamond_square(257, roughness=0.5, seed=1, spacing=5.0).normalised(0.0, 300.0)
    np.save(tmp_path / "t.npy", hm.heights)
    out = tmp_path / "t.glb"
    assert run_app(["mesh", str(tmp_path / "t.npy"), "-o", str(out), "--max-error", "0",
                    "--spacing", "5", "--compress", "--uint16", "-q"]) == 0
    assert gltf_validator(out)["numErrors"] == 0
    doc = pygltflib.GLTF2.load(out)
    assert "EXT_meshopt_compression" in doc.extensionsRequired
    assert len(doc.meshes[0].primitives) >= 2
    assert all(doc.accessors[p.indices].componentType == pygltflib.UNSIGNED_SHORT
               for p in doc.meshes[0].primitives)
    # the glb options on another format: one clear error, nothing written
    assert run_app(["mesh", str(tmp_path / "t.npy"), "-o", str(tmp_path / "t.obj"),
                    "--max-error", "1", "--compress", "-q"]) == 2
    assert not (tmp_path / "t.obj").exists()


def test_compressed_glb_with_texture_normal_map_and_skirt(terrain, tmp_path, gltf_validator,
                                                          gltf_transform_reader):
    tri = rtin_rectangle(terrain, max_error=2.0)
    data, mesh = build_glb(terrain, tri, compress=True, normal_map=True, skirt=30.0)
    path = tmp_path / "t.glb"
    path.write_bytes(data)
    issues = gltf_validator(path)
    assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, issues["messages"]
    read = gltf_transform_reader(path)
    (node,) = [n for n in read["nodes"] if n["primitives"]]
    (prim,) = node["primitives"]
    assert set(prim["attributes"]) == {"POSITION", "NORMAL", "TEXCOORD_0", "TANGENT"}
    world = _world_positions(node, prim["attributes"]["POSITION"])
    step = 2.0 * np.asarray(pygltflib.GLTF2.load(path).nodes[1].scale) / 65534.0
    assert np.all(np.abs(world - mesh.positions) <= step / 2 + 1e-6)
    # the skirt vertices stay last and hang 30 below their border samples
    k = mesh.skirt_vertices
    assert k > 0
    below = terrain.heights.reshape(-1)[mesh.grid_index[-k:]] - 30.0
    np.testing.assert_allclose(world[-k:, 1], below, atol=step[1])
    _check_against_terrain(world[:-k], terrain, step)
    uv = np.asarray(prim["attributes"]["TEXCOORD_0"]["array"]).reshape(-1, 2) / 65535.0
    np.testing.assert_allclose(uv, mesh.uvs, atol=0.5 / 65535 + 1e-7)
