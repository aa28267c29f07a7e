"""Textured GLB: Khronos validator clean, read back by trimesh and pygltflib, rectangular DEMs,
quantisation bounds, skirts and georeference."""

from __future__ import annotations

import io

import numpy as np
import pygltflib
import pytest
from PIL import Image
from scipy import ndimage

from terrascape import Heightmap
from terrascape.cli import run_app
from terrascape.export.glb import bake_texture, build_glb, write_terrain_glb
from terrascape.export.meshing import rtin_rectangle, terrain_mesh
from terrascape.lod.mesh_checks import max_vertical_error

trimesh = pytest.importorskip("trimesh")


@pytest.fixture(scope="module")
def dem() -> Heightmap:
    """A rectangular (not 2**n + 1) UTM DEM."""
    rng = np.random.default_rng(11)
    h = ndimage.gaussian_filter(rng.standard_normal((70, 93)), 4) * 900 + 600
    return Heightmap(h.astype(np.float32), (30.0, 30.0), origin=(500000.0, 5000000.0),
                     crs="EPSG:32633", nodata=-9999.0)


def _image(doc: pygltflib.GLTF2, blob: bytes, index: int) -> np.ndarray:
    view = doc.bufferViews[doc.images[index].bufferView]
    data = blob[view.byteOffset:view.byteOffset + view.byteLength]
    return np.asarray(Image.open(io.BytesIO(data)))


def test_rectangular_dem_mesh_covers_the_data_within_the_error(dem):
    for err in (0.0, 2.0, 10.0):
        tri = rtin_rectangle(dem, max_error=err)
        assert max_vertical_error(dem, tri) <= err  # raises if any sample is uncovered
    tri = rtin_rectangle(dem, max_triangles=3000)
    assert len(tri) <= 3000
    max_vertical_error(dem, tri)


def test_plain_glb_validates_and_trimesh_reads_vertices_bounds_uvs(dem, tmp_path,
                                                                   gltf_validator):
    path, mesh = write_terrain_glb(dem, tmp_path / "t.glb", max_error=3.0)
    issues = gltf_validator(path)
    assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, issues["messages"]
    scene = trimesh.load(path, process=False)
    (geom,) = scene.geometry.values()
    assert len(geom.vertices) == len(mesh.positions)
    np.testing.assert_allclose(scene.bounds, [[0, dem.min, 0], [92 * 30.0, dem.max, 69 * 30.0]],
                               rtol=1e-6)
    uv = geom.visual.uv  # trimesh flips v to OpenGL's convention
    np.testing.assert_allclose(uv[:, 0], mesh.uvs[:, 0], atol=1e-7)
    np.testing.assert_allclose(1.0 - uv[:, 1], mesh.uvs[:, 1], atol=1e-6)
    assert uv[:, 0].min() == pytest.approx(0.5 / 93) and uv[:, 0].max() == pytest.approx(
        92.5 / 93)

    doc = pygltflib.GLTF2.load(path)
    blob = doc.binary_blob()
    prim = doc.meshes[0].primitives[0]
    assert doc.accessors[prim.indices].componentType == pygltflib.UNSIGNED_SHORT
    assert {"POSITION", "NORMAL", "TEXCOORD_0"} <= {
        k for k, v in vars(prim.attributes).items() if v is not None}
    material = doc.materials[prim.material]
    assert material.pbrMetallicRoughness.metallicFactor == 0.0
    colour = _image(doc, blob, doc.textures[
        material.pbrMetallicRoughness.baseColorTexture.index].source)
    np.testing.assert_array_equal(colour, bake_texture(dem))
    extras = doc.nodes[doc.scenes[0].nodes[0]].extras
    assert extras["crs"] == "EPSG:32633"
    assert extras["first_sample_centre"] == [500015.0, 4999985.0]


def test_quantized_glb_with_normal_map_and_skirt(dem, tmp_path, gltf_validator):
    tri = rtin_rectangle(dem, max_error=3.0)
    plain, _ = build_glb(dem, tri, texture=False)
    data, mesh = build_glb(dem, tri, texture=False, quantize=True)
    assert len(data) < 0.75 * len(plain)
    data, mesh = build_glb(dem, tri, quantize=True, normal_map=True, skirt=40.0,
                           georeference_node=True)
    path = tmp_path / "q.glb"
    path.write_bytes(data)
    issues = gltf_validator(path)
    assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, issues["messages"]
    doc = pygltflib.GLTF2.load(path)
    assert doc.extensionsRequired == ["KHR_mesh_quantization"]
    prim = doc.meshes[0].primitives[0]
    acc = doc.accessors[prim.attributes.POSITION]
    assert acc.componentType == pygltflib.SHORT and acc.normalized
    assert doc.accessors[prim.attributes.NORMAL].componentType == pygltflib.BYTE
    assert doc.accessors[prim.attributes.TEXCOORD_0].componentType == pygltflib.UNSIGNED_SHORT
    assert prim.attributes.TANGENT is not None and doc.materials[0].normalTexture is not None
    # dequantise what trimesh reads (it keeps the raw integers) with the node transform
    scene = trimesh.load(path, process=False)
    (geom,) = scene.geometry.values()
    node = doc.nodes[1]
    world = np.asarray(node.translation) + np.asarray(node.scale) * (geom.vertices / 32767.0)
    step = np.asarray(node.scale) / 32767.0
    assert np.all(np.abs(world - mesh.positions) <= step * 0.5 + 1e-6)
    # skirt: one vertex 40 below each border vertex (every sample on the map's edge)
    k = mesh.skirt_vertices
    below = dem.heights.reshape(-1)[mesh.grid_index[-k:]] - 40.0
    np.testing.assert_allclose(world[-k:, 1], below, atol=step[1])
    r, c = np.divmod(mesh.grid_index[-k:], dem.cols)
    assert np.all((r == 0) | (r == dem.rows - 1) | (c == 0) | (c == dem.cols - 1))
    root = doc.nodes[0]
    assert root.translation == [500015.0, 0.0, -4999985.0]


def test_big_meshes_use_uint32_indices(tmp_path):
    rng = np.random.default_rng(2)
    hm = Heightmap(rng.random((300, 260)).astype(np.float32) * 50)
    tri = rtin_rectangle(hm, max_error=0.0)
    mesh = terrain_mesh(hm, tri)
    assert len(mesh.positions) == 300 * 260 > 65535
    data, _ = build_glb(hm, tri, texture=False)
    doc = pygltflib.GLTF2.load_from_bytes(data)
    assert doc.accessors[doc.meshes[0].primitives[0].indices].componentType == \
        pygltflib.UNSIGNED_INT


def test_cli_meshes_the_real_403x344_dem(tmp_path, gltf_validator):
    from matplotlib.cbook import get_sample_data

    z = get_sample_data("jacksboro_fault_dem.npz")["elevation"].astype(np.float32)
    np.save(tmp_path / "j.npy", z)
    out = tmp_path / "j.glb"
    assert run_app(["mesh", str(tmp_path / "j.npy"), "-o", str(out), "--max-error", "4",
                    "--spacing", "74.5,92.6", "--quantize", "-q"]) == 0
    assert gltf_validator(out)["numErrors"] == 0
    scene = trimesh.load(out, process=False)
    (geom,) = scene.geometry.values()
    assert len(geom.vertices) > 1000
    doc = pygltflib.GLTF2.load(out)
    node = doc.nodes[1]
    extent = np.asarray(node.scale) * 2
    np.testing.assert_allclose(extent, [402 * 74.5, 1076 - 236, 343 * 92.6], rtol=1e-6)
