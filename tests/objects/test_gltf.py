"""A user's glTF read back: glbs written by trimesh and by pygltflib, node transforms applied,
colours from vertex colours / base-colour factor / texture, flat normals when missing, and
clear errors for files without triangles."""

import numpy as np
import pygltflib
import pytest
import trimesh
from PIL import Image

from terrascape.errors import FileFormatError
from terrascape.objects.gltf import load_gltf_mesh


def _box_scene(tmp_path, visual):
    box = trimesh.creation.box(extents=(2.0, 4.0, 1.0))
    box.visual = visual(box)
    scene = trimesh.Scene()
    # a quarter turn about +Y, then up by 2 and along x by 10
    transform = trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0])
    transform[:3, 3] = [10.0, 2.0, 0.0]
    scene.add_geometry(box, node_name="box", transform=transform)
    path = tmp_path / "box.glb"
    path.write_bytes(scene.export(file_type="glb"))
    return path, box, transform


def test_trimesh_glb_with_vertex_colours_and_a_node_transform(tmp_path):
    def coloured(box):
        c = np.zeros((len(box.vertices), 4), np.uint8)
        c[:] = (51, 102, 204, 255)  # 0.2, 0.4, 0.8 as stored (COLOR_0 is linear)
        return trimesh.visual.ColorVisuals(box, vertex_colors=c)

    path, box, transform = _box_scene(tmp_path, coloured)
    m = load_gltf_mesh(path)
    assert m.name == "box" and m.triangles == 12
    want = trimesh.transform_points(box.vertices, transform)
    lo, hi = m.bounds
    np.testing.assert_allclose(lo, want.min(axis=0), atol=1e-5)
    np.testing.assert_allclose(hi, want.max(axis=0), atol=1e-5)
    # the rotation turned the 2 m (x) side along z: extents (1, 4, 2)
    np.testing.assert_allclose(hi - lo, [1.0, 4.0, 2.0], atol=1e-5)
    np.testing.assert_allclose(m.colors, np.tile([0.2, 0.4, 0.8], (len(m.colors), 1)), atol=2e-3)
    # normals: unit, and outward (each face's normal points away from the box centre)
    tri = m.positions[m.indices].astype(np.float64)
    centre = (lo + hi) / 2
    face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    assert np.all(np.einsum("ij,ij->i", face_n, tri.mean(axis=1) - centre) > 0)
    np.testing.assert_allclose(np.linalg.norm(m.normals, axis=1), 1.0, atol=1e-5)


def test_base_colour_factor_and_texture(tmp_path):
    img = Image.new("RGB", (8, 8), (188, 188, 188))  # sRGB 188 → linear ≈ 0.5

    def textured(box):
        mat = trimesh.visual.material.PBRMaterial(baseColorFactor=[0.5, 1.0, 1.0, 1.0],
                                                  baseColorTexture=img)
        uv = np.full((len(box.vertices), 2), 0.5)
        return trimesh.visual.TextureVisuals(uv=uv, material=mat)

    path, _, _ = _box_scene(tmp_path, textured)
    m = load_gltf_mesh(path)
    lin = ((188 / 255 + 0.055) / 1.055) ** 2.4
    np.testing.assert_allclose(m.colors[0], [0.5 * lin, lin, lin], atol=0.01)


def _triangle_doc(*, mode=pygltflib.TRIANGLES, with_normals=False, scale=None):
    pos = np.array([[0, 0, 0], [1, 0, 0], [0, 0, -1]], np.float32)  # counter-clockwise from +Y
    blob = pos.tobytes()
    doc = pygltflib.GLTF2(asset=pygltflib.Asset(version="2.0"))
    doc.bufferViews = [pygltflib.BufferView(buffer=0, byteOffset=0, byteLength=len(blob))]
    doc.accessors = [pygltflib.Accessor(bufferView=0, componentType=pygltflib.FLOAT, count=3,
                                        type="VEC3", min=[0, 0, -1], max=[1, 0, 0])]
    attrs = pygltflib.Attributes(POSITION=0)
    if with_normals:
        n = np.tile(np.float32([0, 1, 0]), (3, 1)).tobytes()
        doc.bufferViews.append(pygltflib.BufferView(buffer=0, byteOffset=len(blob),
                                                    byteLength=len(n)))
        doc.accessors.append(pygltflib.Accessor(bufferView=1, componentType=pygltflib.FLOAT,
                                                count=3, type="VEC3"))
        attrs.NORMAL = 1
        blob += n
    doc.meshes = [pygltflib.Mesh(primitives=[pygltflib.Primitive(attributes=attrs, mode=mode)])]
    doc.materials = []
    doc.nodes = [pygltflib.Node(mesh=0, scale=scale)]
    doc.scenes = [pygltflib.Scene(nodes=[0])]
    doc.scene = 0
    doc.buffers = [pygltflib.Buffer(byteLength=len(blob))]
    doc.set_binary_blob(blob)
    return doc


def test_missing_normals_are_flat_and_mirrors_keep_winding(tmp_path):
    path = tmp_path / "tri.glb"
    _triangle_doc().save_binary(str(path))
    m = load_gltf_mesh(path)
    np.testing.assert_allclose(m.normals, np.tile([0, 1, 0], (3, 1)), atol=1e-6)
    np.testing.assert_allclose(m.colors, 1.0)  # no material: white
    # mirrored along x: positions mirrored, winding flipped so the face still looks up
    _triangle_doc(scale=[-1, 1, 1], with_normals=True).save_binary(str(path))
    m = load_gltf_mesh(path)
    tri = m.positions[m.indices[0]].astype(np.float64)
    assert tri[:, 0].min() == -1.0
    assert np.cross(tri[1] - tri[0], tri[2] - tri[0])[1] > 0
    np.testing.assert_allclose(m.normals, np.tile([0, 1, 0], (3, 1)), atol=1e-6)
    # a .gltf with its buffer as a data URI
    doc = _triangle_doc()
    doc.convert_buffers(pygltflib.BufferFormat.DATAURI)
    doc.save_json(str(tmp_path / "tri.gltf"))
    assert load_gltf_mesh(tmp_path / "tri.gltf").triangles == 1


def test_not_a_mesh_is_a_clear_error(tmp_path):
    path = tmp_path / "points.glb"
    _triangle_doc(mode=pygltflib.POINTS).save_binary(str(path))
    with pytest.raises(FileFormatError, match="holds no triangle mesh"):
        load_gltf_mesh(path)
    (tmp_path / "junk.glb").write_bytes(b"glTF\x02\x00\x00\x00garbage")
    with pytest.raises(FileFormatError, match="not a readable glTF"):
        load_gltf_mesh(tmp_path / "junk.glb")
    (tmp_path / "text.gltf").write_text("{not json")
    with pytest.raises(FileFormatError, match="not a readable glTF"):
        load_gltf_mesh(tmp_path / "text.gltf")
    with pytest.raises(FileFormatError, match="no such glTF file"):
        load_gltf_mesh(tmp_path / "missing.glb")
    doc = _triangle_doc()
    doc.extensionsRequired = ["KHR_draco_mesh_compression"]
    doc.save_binary(str(path))
    with pytest.raises(FileFormatError, match="KHR_draco_mesh_compression"):
        load_gltf_mesh(path)
