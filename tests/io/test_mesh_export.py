"""Mesh export: compact_mesh, OBJ / binary PLY / GLB round trips, GLB structural validity."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pytest

from terrascape import Heightmap
from terrascape.errors import FileFormatError, InvalidParameterError, OutputExistsError
from terrascape.io.mesh import (
    compact_mesh,
    glb_bytes,
    vertex_normals,
    write_glb,
    write_mesh,
    write_obj,
    write_ply,
)
from terrascape.lod import full_resolution_triangles, rtin_mesh

_COMPONENT = {5126: ("<f4", 4), 5125: ("<u4", 4), 5123: ("<u2", 2), 5121: ("u1", 1)}
_NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}


def validate_glb(data: bytes) -> tuple[dict, dict[str, np.ndarray]]:
    """Structural glTF 2.0 GLB check; returns the JSON and the decoded primitive arrays."""
    magic, version, length = struct.unpack_from("<III", data, 0)
    assert magic == 0x46546C67 and version == 2 and length == len(data)
    jlen, jtype = struct.unpack_from("<II", data, 12)
    assert jtype == 0x4E4F534A and jlen % 4 == 0
    gltf = json.loads(data[20:20 + jlen].decode("utf-8"))
    boff = 20 + jlen
    blen, btype = struct.unpack_from("<II", data, boff)
    assert btype == 0x004E4942 and blen % 4 == 0 and boff % 4 == 0
    assert boff + 8 + blen == len(data)
    binary = data[boff + 8:boff + 8 + blen]
    assert gltf["asset"]["version"] == "2.0"
    assert len(gltf["buffers"]) == 1 and gltf["buffers"][0]["byteLength"] <= blen
    assert blen - gltf["buffers"][0]["byteLength"] < 4  # only alignment padding
    prim = gltf["meshes"][0]["primitives"][0]
    assert prim.get("mode", 4) == 4
    arrays = {}
    wanted = {**prim["attributes"], "indices": prim["indices"]}
    for name, ai in wanted.items():
        acc = gltf["accessors"][ai]
        view = gltf["bufferViews"][acc["bufferView"]]
        dtype, size = _COMPONENT[acc["componentType"]]
        ncomp = _NCOMP[acc["type"]]
        start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
        assert start % size == 0  # component alignment
        nbytes = acc["count"] * ncomp * size
        assert acc.get("byteOffset", 0) + nbytes <= view["byteLength"]
        assert view.get("byteOffset", 0) + view["byteLength"] <= gltf["buffers"][0]["byteLength"]
        arr = np.frombuffer(binary, dtype, acc["count"] * ncomp, start).reshape(acc["count"], -1)
        if "min" in acc:
            np.testing.assert_array_equal(arr.min(axis=0), np.asarray(acc["min"], arr.dtype))
            np.testing.assert_array_equal(arr.max(axis=0), np.asarray(acc["max"], arr.dtype))
        arrays[name] = arr
    pos = gltf["accessors"][prim["attributes"]["POSITION"]]
    assert "min" in pos and "max" in pos and pos["type"] == "VEC3"  # required by the spec
    assert gltf["accessors"][prim["indices"]]["componentType"] == 5125
    assert gltf["bufferViews"][gltf["accessors"][prim["indices"]]["bufferView"]]["target"] == 34963
    assert arrays["indices"].max() < len(arrays["POSITION"])
    return gltf, arrays


def read_obj(path):
    v, f = [], []
    with open(path, encoding="ascii") as fh:
        lines = fh.read().splitlines()
    for line in lines:
        parts = line.split()
        if parts and parts[0] == "v":
            v.append([float(x) for x in parts[1:4]])
        elif parts and parts[0] == "f":
            f.append([int(x.split("/")[0]) - 1 for x in parts[1:4]])
    return np.array(v, np.float32), np.array(f, np.uint32)


def read_ply(path):
    data = Path(path).read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    assert header[1] == "format binary_little_endian 1.0"
    nv = int(next(h for h in header if h.startswith("element vertex")).split()[-1])
    nf = int(next(h for h in header if h.startswith("element face")).split()[-1])
    v = np.frombuffer(data, "<f4", nv * 3, end).reshape(nv, 3)
    rec = np.dtype([("n", "u1"), ("i", "<u4", (3,))])
    f = np.frombuffer(data, rec, nf, end + nv * 12)
    assert (f["n"] == 3).all() and end + nv * 12 + nf * 13 == len(data)
    return v, f["i"]


@pytest.fixture
def mesh(rng):
    h = (rng.random((33, 33)) * 50).astype(np.float32)
    hm = Heightmap(h, spacing=(2.0, 3.0))
    tri = rtin_mesh(hm, max_error=10.0)
    return hm, tri


def test_compact_mesh_positions_and_faces(mesh):
    hm, tri = mesh
    v, f = compact_mesh(hm, tri)
    assert v.dtype == np.float32 and f.dtype == np.uint32 and f.shape == tri.shape
    assert len(v) == len(np.unique(tri)) < hm.rows * hm.cols
    # every face maps back to the same world positions as the grid indices
    r, c = np.divmod(tri.astype(np.int64), hm.cols)
    expect = np.stack([c * 2.0, hm.heights[r, c], r * 3.0], -1)
    np.testing.assert_array_equal(v[f], expect.astype(np.float32))
    # faces point up (CCW from above)
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    assert (n[:, 1] > 0).all()
    vn = vertex_normals(v, f)
    np.testing.assert_allclose(np.linalg.norm(vn, axis=1), 1, rtol=1e-5)
    assert (vn[:, 1] > 0).all()


def test_obj_round_trip(mesh, tmp_path):
    v, f = compact_mesh(*mesh)
    path = write_obj(tmp_path / "t.obj", v, f)
    v2, f2 = read_obj(path)
    np.testing.assert_array_equal(v2, v)  # %.9g round-trips float32 exactly
    np.testing.assert_array_equal(f2, f)
    assert path.read_text().count("\nvn ") == len(v)


def test_ply_round_trip(mesh, tmp_path):
    v, f = compact_mesh(*mesh)
    v2, f2 = read_ply(write_ply(tmp_path / "t.ply", v, f))
    np.testing.assert_array_equal(v2, v)
    np.testing.assert_array_equal(f2, f)


def test_glb_is_valid_and_round_trips(mesh, tmp_path):
    v, f = compact_mesh(*mesh)
    path = write_glb(tmp_path / "t.glb", v, f)
    gltf, arrays = validate_glb(path.read_bytes())
    np.testing.assert_array_equal(arrays["POSITION"], v)
    np.testing.assert_array_equal(arrays["indices"].reshape(-1, 3), f)
    np.testing.assert_allclose(arrays["NORMAL"], vertex_normals(v, f))
    assert gltf["accessors"][0]["count"] == len(v)


@pytest.mark.parametrize("n_vertices", [3, 4, 5, 7])
def test_glb_alignment_with_odd_sizes(n_vertices):
    # vertex counts whose byte sizes are not multiples of 8/16, and a JSON needing padding
    v = np.random.default_rng(n_vertices).random((n_vertices, 3)).astype(np.float32)
    f = np.array([[0, 1, 2]] * (n_vertices - 2), np.uint32) + np.arange(n_vertices - 2)[:, None]
    f = np.minimum(f, n_vertices - 1)
    validate_glb(glb_bytes(v, f))


def test_full_resolution_export(tmp_path):
    hm = Heightmap(np.zeros((3, 4), np.float32), spacing=(1.0, 1.0))
    v, f = compact_mesh(hm, full_resolution_triangles(hm.shape))
    assert len(v) == 12 and len(f) == 12
    gltf, _ = validate_glb(write_mesh(tmp_path / "flat.glb", v, f).read_bytes())
    assert gltf["accessors"][0]["max"] == [3.0, 0.0, 2.0]


def test_atomic_and_bad_inputs(mesh, tmp_path):
    v, f = compact_mesh(*mesh)
    target = tmp_path / "keep.ply"
    target.write_bytes(b"old")
    with pytest.raises(OutputExistsError):
        write_ply(target, v, f)
    assert target.read_bytes() == b"old"
    write_ply(target, v, f, force=True)
    assert target.read_bytes().startswith(b"ply\n")
    with pytest.raises(FileFormatError, match="unknown mesh format"):
        write_mesh(tmp_path / "x.stl", v, f)
    with pytest.raises(InvalidParameterError, match="face indices"):
        write_obj(tmp_path / "bad.obj", v, f + len(v))
    assert not (tmp_path / "bad.obj").exists()
    with pytest.raises(InvalidParameterError, match="triangle indices"):
        compact_mesh(mesh[0], np.array([[0, 1, 10**6]]))
    with pytest.raises(InvalidParameterError, match="Heightmap"):
        compact_mesh(np.zeros((3, 3)), np.array([[0, 3, 1]]))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.ply"]  # no temp files left
