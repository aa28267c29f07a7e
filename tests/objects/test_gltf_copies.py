"""A user's glb that places copies — EXT_mesh_gpu_instancing and two nodes sharing a mesh —
read back as every copy (count, positions, turns, scales, a tilted copy drawn tilted),
standing on the terrain, drawn by the renderer and listed by the CLI."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pygltflib
import pytest

from terrascape.camera import Camera
from terrascape.errors import FileFormatError
from terrascape.generate import fbm
from terrascape.objects import load_objects, surface_height
from terrascape.objects.gltf import load_gltf_copies, load_gltf_mesh, places_copies
from terrascape.objects.placement import OutsideTerrainWarning

INSTANCING = "EXT_mesh_gpu_instancing"
ROOT_SHIFT = 10.0  # the instanced node's parent moves it along x
# TRANSLATION of the instanced copies (y is the file's; the feet go on the terrain)
TOWERS = np.array([[5.0, 3.0, 10.0], [20.0, 0.0, 20.0], [30.0, -2.0, 40.0],
                   [42.0, 7.0, 50.0], [90.0, 0.0, 10.0]])
TOWER_YAW = np.array([0.0, 0.5, 1.0, 2.0, 0.0])
TOWER_SCALE = np.array([1.0, 1.5, 0.8, 1.0, 1.0])
TILTED = 3  # this copy is also turned 30° about +X
HUTS = np.array([[12.0, 0.0, 52.0], [45.0, 0.0, 14.0]])  # two nodes drawing one mesh
HUT_SCALE = np.array([1.0, 2.0])


def _quat(axis, angle):
    a = np.asarray(axis, np.float64) * math.sin(angle / 2)
    return np.r_[a, math.cos(angle / 2)]


def _quat_mul(p, q):
    x1, y1, z1, w1 = p
    x2, y2, z2, w2 = q
    return np.array([w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2, w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2])


def write_copies_glb(path, box_mesh):
    doc = pygltflib.GLTF2(asset=pygltflib.Asset(version="2.0"))
    blob = bytearray()

    def accessor(array, kind, target=None):
        array = np.ascontiguousarray(array)
        while len(blob) % 4:
            blob.append(0)
        doc.bufferViews.append(pygltflib.BufferView(buffer=0, byteOffset=len(blob),
                                                    byteLength=array.nbytes, target=target))
        blob.extend(array.tobytes())
        comp = pygltflib.UNSIGNED_SHORT if array.dtype == np.uint16 else pygltflib.FLOAT
        extra = {}
        if kind == "VEC3" and target == pygltflib.ARRAY_BUFFER:
            extra = {"min": array.min(axis=0).tolist(), "max": array.max(axis=0).tolist()}
        doc.accessors.append(pygltflib.Accessor(
            bufferView=len(doc.bufferViews) - 1, componentType=comp,
            count=len(array) if array.ndim > 1 else array.size, type=kind, **extra))
        return len(doc.accessors) - 1

    for name, size, colour in (("tower", (2.0, 6.0, 2.0), (0.8, 0.05, 0.05)),
                               ("hut", (4.0, 3.0, 4.0), (0.05, 0.1, 0.8))):
        box = box_mesh(size, colour, name)
        p, n, c, t = box.positions, box.normals, box.colors, box.indices.astype(np.uint16)
        attrs = pygltflib.Attributes(POSITION=accessor(p, "VEC3", pygltflib.ARRAY_BUFFER),
                                     NORMAL=accessor(n, "VEC3", pygltflib.ARRAY_BUFFER),
                                     COLOR_0=accessor(c, "VEC3", pygltflib.ARRAY_BUFFER))
        idx = accessor(t.reshape(-1), "SCALAR", pygltflib.ELEMENT_ARRAY_BUFFER)
        doc.meshes.append(pygltflib.Mesh(name=name, primitives=[
            pygltflib.Primitive(attributes=attrs, indices=idx)]))
    rot = np.array([_quat([0, 1, 0], a) for a in TOWER_YAW])
    rot[TILTED] = _quat_mul(rot[TILTED], _quat([1, 0, 0], math.radians(30)))
    inst = {"TRANSLATION": accessor(TOWERS.astype(np.float32), "VEC3"),
            "ROTATION": accessor(rot.astype(np.float32), "VEC4"),
            "SCALE": accessor(np.repeat(TOWER_SCALE[:, None], 3, 1).astype(np.float32),
                              "VEC3")}
    doc.nodes = [
        pygltflib.Node(name="forest", translation=[ROOT_SHIFT, 0.0, 0.0], children=[1]),
        pygltflib.Node(name="towers", mesh=0, extensions={INSTANCING: {"attributes": inst}}),
        pygltflib.Node(name="hut a", mesh=1, translation=HUTS[0].tolist()),
        pygltflib.Node(name="hut b", mesh=1, translation=HUTS[1].tolist(),
                       scale=[HUT_SCALE[1]] * 3),
    ]
    doc.scenes = [pygltflib.Scene(nodes=[0, 2, 3])]
    doc.scene = 0
    doc.extensionsUsed = [INSTANCING]
    doc.extensionsRequired = [INSTANCING]  # as the extension's specification recommends
    doc.buffers = [pygltflib.Buffer(byteLength=len(blob))]
    doc.set_binary_blob(bytes(blob))
    doc.save_binary(str(path))
    return path


@pytest.fixture
def terrain():
    return fbm(65, scale=40.0, octaves=4, amplitude=6.0, seed=2, spacing=1.0)


def expected_feet():
    x = np.r_[TOWERS[:4, 0] + ROOT_SHIFT, HUTS[:, 0]]
    z = np.r_[TOWERS[:4, 2], HUTS[:, 2]]
    return x, z


def test_instancing_and_shared_meshes_are_read_as_every_copy(tmp_path, box_mesh):
    path = write_copies_glb(tmp_path / "copies.glb", box_mesh)
    assert places_copies(path)
    copies = load_gltf_copies(path)
    assert len(copies) == 7 and [m.name for m in copies.meshes] == ["tower", "hut"]
    np.testing.assert_array_equal(copies.kind, [0, 0, 0, 0, 0, 1, 1])
    # the parent's shift applies after each instance's own transform
    np.testing.assert_allclose(copies.matrices[:5, :3, 3], TOWERS + np.array([ROOT_SHIFT, 0, 0]),
                               atol=1e-5)
    np.testing.assert_allclose(copies.matrices[5:, :3, 3], HUTS, atol=1e-6)
    np.testing.assert_allclose(np.cbrt(np.linalg.det(copies.matrices[:, :3, :3])),
                               np.r_[TOWER_SCALE, HUT_SCALE], atol=1e-5)
    # the single-model reader still sees one model per node (one tower, two huts)
    assert load_gltf_mesh(path).triangles == 3 * 12


def test_copies_stand_on_the_terrain_where_the_file_puts_them(tmp_path, terrain, box_mesh):
    path = write_copies_glb(tmp_path / "copies.glb", box_mesh)
    with pytest.warns(OutsideTerrainWarning, match="1 of its 7 copies"):
        inst = load_objects(str(path), terrain, exaggeration=2.0)
    x, z = expected_feet()
    assert len(inst) == 6
    np.testing.assert_allclose(inst.positions[:, 0], x, atol=1e-4)
    np.testing.assert_allclose(inst.positions[:, 2], z, atol=1e-4)
    np.testing.assert_allclose(inst.positions[:, 1], surface_height(terrain, x, z, 2.0),
                               atol=1e-4)
    np.testing.assert_allclose(inst.scale, np.r_[TOWER_SCALE[:4], HUT_SCALE], atol=1e-5)
    upright = [0, 1, 2, 4, 5]
    np.testing.assert_allclose(inst.yaw[upright], np.r_[TOWER_YAW[:3], 0.0, 0.0], atol=1e-5)
    names = [inst.meshes[k].name for k in inst.kind]
    assert names == ["tower"] * 3 + ["tower~1"] + ["hut"] * 2
    # the tilted copy draws a tilted tower: its world triangles are the file's own transform
    tilted = inst.world_triangles(3).reshape(-1, 3).astype(np.float64)
    tower = load_gltf_copies(path).meshes[0]
    m = load_gltf_copies(path).matrices[TILTED]
    want = tower.positions.astype(np.float64) @ m[:3, :3].T
    want = want[tower.indices].reshape(-1, 3) + inst.positions[3]
    np.testing.assert_allclose(tilted, want, atol=1e-4)
    # its axis (foot to the top face's centre) leans 30° off the vertical
    top = inst.meshes[inst.kind[3]].positions[tower.positions[:, 1] > 5.9].mean(axis=0)
    lean = math.degrees(math.acos(top[1] / np.linalg.norm(top)))
    assert abs(lean - 30.0) < 1e-3, lean


def test_copies_are_drawn(gl_ctx, tmp_path, terrain, box_mesh):
    from terrascape.render.offscreen import OffscreenRenderer

    path = write_copies_glb(tmp_path / "copies.glb", box_mesh)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideTerrainWarning)
        inst = load_objects(str(path), terrain)
    size = (192, 192)
    ex, ez = terrain.extent
    cam = Camera.look_at((ex / 2, 120.0, ez / 2 + 1e-3), (ex / 2, 0.0, ez / 2), fov_y=32.0,
                         near=10.0, far=400.0, aspect=1.0)
    params = {"object_shadows": "none", "impostor_pixels": 0, "haze": 0.0}
    r = OffscreenRenderer(gl_ctx, terrain, size=size)
    try:
        bare = r.render(cam, "material", params).astype(float)
        r.terrain.set_objects(inst)
        drawn = r.render(cam, "material", params).astype(float)
        stats = r.terrain.objects.last_stats
    finally:
        r.release()
    assert stats["objects_meshes"] == 6
    tops = inst.positions + np.c_[np.zeros(6), [6.0 * s for s in inst.scale[:4]]
                                  + [3.0 * s for s in inst.scale[4:]], np.zeros(6)]
    tops[3, 1] = inst.positions[3, 1] + 6.0 * math.cos(math.radians(30))
    for k, (px, py, _) in enumerate(cam.project(tops, size)):
        patch = (slice(int(py) - 1, int(py) + 2), slice(int(px) - 1, int(px) + 2))
        rgb = drawn[patch][..., :3].reshape(-1, 3).mean(axis=0)
        assert np.abs(drawn[patch] - bare[patch]).max() > 40, k
        if k < 4:
            assert rgb[0] > rgb[1] + 40 and rgb[0] > rgb[2] + 40, (k, rgb)  # a red tower
        else:
            assert rgb[2] > rgb[0] + 40 and rgb[2] > rgb[1] + 20, (k, rgb)  # a blue hut


def test_cli_lists_every_copy(tmp_path, terrain, box_mesh):
    from terrascape.cli.app import run_app
    from terrascape.export.instances import read_instances_json

    path = write_copies_glb(tmp_path / "copies.glb", box_mesh)
    np.save(tmp_path / "hm.npy", terrain.heights)
    out = tmp_path / "objects.json"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideTerrainWarning)
        assert run_app(["objects", "scatter", str(tmp_path / "hm.npy"), str(out), "--objects",
                        str(path), "-q"]) == 0
    back = read_instances_json(out)
    x, z = expected_feet()
    assert back["count"] == 6 and back["counts"] == {"tower": 3, "tower~1": 1, "hut": 2}
    np.testing.assert_allclose(back["positions"][:, [0, 2]], np.c_[x, z], atol=1e-4)


def test_copies_nowhere_on_the_terrain_or_too_many_are_clear_errors(tmp_path, terrain, box_mesh):
    path = write_copies_glb(tmp_path / "copies.glb", box_mesh)
    small = fbm(9, scale=4.0, octaves=2, amplitude=1.0, seed=1, spacing=0.5)  # 4 m × 4 m
    with pytest.raises(FileFormatError, match="none of its 7 copies stands on the terrain"):
        load_objects(str(path), small)
    from terrascape.errors import InvalidParameterError

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideTerrainWarning)
        with pytest.raises(InvalidParameterError, match="places 6 objects"):
            load_objects(str(path), terrain, max_objects=5)


def test_damaged_copies_files_give_one_clear_error(tmp_path, terrain, box_mesh):
    """Bytes of the copies glb changed at random: instances or one TerrascapeError line,
    never another exception (hypothesis, capped examples)."""
    from hypothesis import given, settings
    from hypothesis import strategies as st

    from terrascape.errors import TerrascapeError

    good = write_copies_glb(tmp_path / "copies.glb", box_mesh).read_bytes()

    @settings(max_examples=120, deadline=None, derandomize=True)
    @given(edits=st.lists(st.tuples(st.integers(0, len(good) - 1), st.integers(0, 255)),
                          min_size=1, max_size=6),
           cut=st.one_of(st.none(), st.integers(0, len(good))))
    def check(edits, cut):
        data = bytearray(good)
        for where, value in edits:
            data[where] = value
        if cut is not None:
            data = data[:cut]
        bad = tmp_path / "bad.glb"
        bad.write_bytes(bytes(data))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                inst = load_objects(str(bad), terrain)
            except TerrascapeError as exc:
                assert "\n" not in str(exc)
                return
        assert len(inst) > 0 and np.isfinite(inst.positions).all()

    check()
