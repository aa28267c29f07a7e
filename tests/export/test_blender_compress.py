"""``export blender --format glb --compress quantize``: a KHR_mesh_quantization glb (what
Blender's glTF importer reads since 2.91), valid, smaller, and the same surface within the
16-bit step."""

from __future__ import annotations

import numpy as np
import pygltflib
import pytest

from terrascape.cli import run_app
from terrascape.generate import diamond_square


@pytest.fixture(scope="module")
def terrain():
    hm = diamond_square(129, seed=4, roughness=0.6)
    return type(hm)(hm.heights * 60.0, (10.0, 10.0))


def _export(terrain, tmp_path, *extra: str):
    np.save(tmp_path / "b.npy", terrain.heights)
    folder = tmp_path / ("q" if extra else "p")
    assert run_app(["export", "blender", str(tmp_path / "b.npy"), "-o", str(folder),
                    "--format", "glb", "--spacing", "10", "--max-error", "1", "-q",
                    *extra]) == 0
    return folder / "b.glb", (folder / "b_import.txt").read_text()


def _world_positions(path) -> tuple[np.ndarray, np.ndarray, pygltflib.GLTF2]:
    """Vertex positions in world units (the node transform applied to the decoded accessor),
    and the quantization step per axis (zero for float positions)."""
    doc = pygltflib.GLTF2.load(path)
    prim = doc.meshes[0].primitives[0]
    acc = doc.accessors[prim.attributes.POSITION]
    view = doc.bufferViews[acc.bufferView]
    blob = doc.binary_blob()
    dtype = {pygltflib.FLOAT: "<f4", pygltflib.SHORT: "<i2"}[acc.componentType]
    stride = view.byteStride or 3 * np.dtype(dtype).itemsize
    raw = np.ndarray((acc.count, 3), dtype=dtype, buffer=blob,
                     offset=view.byteOffset + (acc.byteOffset or 0),
                     strides=(stride, np.dtype(dtype).itemsize)).astype(np.float64)
    node = next(n for n in doc.nodes if n.mesh == 0)
    scale = np.asarray(node.scale if node.scale is not None else [1, 1, 1], np.float64)
    move = np.asarray(node.translation if node.translation is not None else [0, 0, 0],
                      np.float64)
    if acc.componentType == pygltflib.SHORT:
        assert acc.normalized
        return move + scale * np.maximum(raw / 32767.0, -1.0), scale / 32767.0, doc
    return move + scale * raw, np.zeros(3), doc


def test_blender_quantized_glb_is_valid_smaller_and_the_same_surface(terrain, tmp_path,
                                                                      gltf_validator):
    plain, _ = _export(terrain, tmp_path)
    quant, note = _export(terrain, tmp_path, "--compress", "quantize")
    issues = gltf_validator(quant)
    assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, issues["messages"]
    p, _, _ = _world_positions(plain)
    q, step, doc = _world_positions(quant)
    assert doc.extensionsRequired == ["KHR_mesh_quantization"]
    prim = doc.meshes[0].primitives[0]
    assert doc.accessors[prim.attributes.NORMAL].componentType == pygltflib.BYTE
    assert np.all(step > 0) and len(q) == len(p)  # the same mesh, vertex for vertex
    assert np.all(np.abs(q - p) <= 0.5 * step + 1e-4 * np.abs(p).max())
    assert quant.stat().st_size < plain.stat().st_size
    assert "KHR_mesh_quantization" in note and "Blender 2.91" in note
    trimesh = pytest.importorskip("trimesh")
    scene = trimesh.load(quant, process=False)
    assert len(scene.geometry) == 1


def test_blender_compress_is_checked(terrain, tmp_path):
    np.save(tmp_path / "b.npy", terrain.heights)
    assert run_app(["export", "blender", str(tmp_path / "b.npy"), "-o", str(tmp_path / "m"),
                    "--format", "glb", "--compress", "meshopt", "-q"]) == 2
    assert run_app(["export", "blender", str(tmp_path / "b.npy"), "-o", str(tmp_path / "t"),
                    "--compress", "quantize", "-q"]) == 2  # the TIFF has no mesh
    assert not (tmp_path / "m").exists() or not any((tmp_path / "m").iterdir())
