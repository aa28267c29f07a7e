"""Objects exported with the terrain: EXT_mesh_gpu_instancing in the glb (Khronos validator,
read back by pygltflib), engine instance lists read back and checked against the engine's
own height files (their axes) and rotation conventions."""

from __future__ import annotations

import json
import os

import numpy as np
import pygltflib
import pytest
import tifffile
from PIL import Image
from scipy import ndimage

from terrascape import Heightmap
from terrascape.cli import run_app
from terrascape.export import ExportOptions, get_destination
from terrascape.export.glb import build_glb
from terrascape.export.instances import (
    INSTANCING,
    engine_to_world,
    read_engine_instances,
    read_instances_json,
    world_to_engine,
)
from terrascape.export.meshing import rtin_rectangle
from terrascape.io import read_heightmap
from terrascape.objects import scatter


@pytest.fixture(scope="module")
def terrain() -> Heightmap:
    rng = np.random.default_rng(8)
    h = ndimage.gaussian_filter(rng.standard_normal((129, 129)), 6) * 1500 + 300
    return Heightmap(h.astype(np.float32), (4.0, 4.0))


def _accessor(doc, index):
    acc = doc.accessors[index]
    view = doc.bufferViews[acc.bufferView]
    width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[acc.type]
    dtype = {5126: np.float32, 5125: np.uint32, 5123: np.uint16}[acc.componentType]
    data = doc.binary_blob()[view.byteOffset + (acc.byteOffset or 0):]
    return np.frombuffer(data, dtype, acc.count * width).reshape(acc.count, width)


def _check_instanced_glb(path, inst, validate):
    issues = validate(path)
    assert issues["numErrors"] == 0, issues["messages"][:5]
    # the validator checks the core document (buffers, accessors, meshes) but does not know
    # this extension: its only note about it is that one; the extension's own rules below
    other = [m for m in issues["messages"] if m["severity"] <= 1]
    assert not other, other
    doc = pygltflib.GLTF2.load_binary(path)
    # the specification asks for it in extensionsRequired (there is no fallback)
    assert INSTANCING in doc.extensionsUsed and INSTANCING in doc.extensionsRequired
    found = 0
    for node in doc.nodes:
        ext = (node.extensions or {}).get(INSTANCING)
        if ext is None:
            continue
        name = doc.meshes[node.mesh].name
        k = [m.name for m in inst.meshes].index(name)
        sel = inst.of_kind(k)
        a = ext["attributes"]
        # the extension's rules: accessor types, one count for all three
        kinds = {k: (doc.accessors[i].type, doc.accessors[i].componentType)
                 for k, i in a.items()}
        assert kinds == {"TRANSLATION": ("VEC3", 5126), "ROTATION": ("VEC4", 5126),
                         "SCALE": ("VEC3", 5126)}
        assert {doc.accessors[i].count for i in a.values()} == {len(sel)}
        np.testing.assert_array_equal(_accessor(doc, a["TRANSLATION"]), inst.positions[sel])
        q = _accessor(doc, a["ROTATION"]).astype(np.float64)
        np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-6)
        assert np.all(q[:, [0, 2]] == 0)
        yaw = np.mod(2 * np.arctan2(q[:, 1], q[:, 3]), 2 * np.pi)
        diff = np.angle(np.exp(1j * (yaw - inst.yaw[sel])))
        assert np.abs(diff).max() < 1e-5
        np.testing.assert_allclose(_accessor(doc, a["SCALE"]),
                                   np.repeat(inst.scale[sel][:, None], 3, 1), rtol=1e-7)
        prim = doc.meshes[node.mesh].primitives[0]
        np.testing.assert_array_equal(_accessor(doc, prim.attributes.POSITION),
                                      inst.meshes[k].positions)
        np.testing.assert_array_equal(_accessor(doc, prim.attributes.COLOR_0),
                                      inst.meshes[k].colors)
        found += len(sel)
    assert found == len(inst) > 0
    return doc


def test_glb_carries_gpu_instanced_objects(terrain, tmp_path, gltf_validator):
    inst = scatter(terrain, seed=2)
    tri = rtin_rectangle(terrain, max_error=1.0)
    for quantize in (False, True):
        data, _ = build_glb(terrain, tri, texture=False, quantize=quantize, objects=inst)
        path = tmp_path / f"t{int(quantize)}.glb"
        path.write_bytes(data)
        doc = _check_instanced_glb(path, inst, gltf_validator)
        # the terrain is still the first mesh, its node untouched
        assert doc.nodes[1].mesh == 0 and doc.meshes[0].name == "terrain"


def test_cli_web_and_blender_glb_with_objects(terrain, tmp_path, gltf_validator):
    from terrascape.io import write_heightmap

    src = tmp_path / "t.tif"
    write_heightmap(terrain, src)
    assert run_app(["export", "web", str(src), "-o", str(tmp_path / "web"), "--objects",
                    "default", "--seed", "3", "-q"]) == 0
    inst = scatter(read_heightmap(src), seed=3)
    _check_instanced_glb(tmp_path / "web" / "t.glb", inst, gltf_validator)
    assert run_app(["export", "blender", str(src), "-o", str(tmp_path / "b"), "--format", "glb",
                    "--objects", "default", "--seed", "3", "-q"]) == 0
    _check_instanced_glb(tmp_path / "b" / "t.glb", inst, gltf_validator)
    # tile pyramids carry no objects: said, not silently dropped
    assert run_app(["export", "cesium", str(src), "-o", str(tmp_path / "c"), "--objects",
                    "default"]) == 2


def _bilinear(grid, rows, cols):
    return ndimage.map_coordinates(grid.astype(np.float64), [rows, cols], order=1,
                                   mode="nearest")


def _engine_heights(engine, out, terrain):
    """Height under each listed object read from the ENGINE's own terrain file, in its own
    axes: wrong axes put the objects tens of metres off the ground."""
    lst = read_engine_instances(engine, next(out.glob("T_objects.*[nv]")))
    p = lst["position"]
    dx, dz = terrain.spacing
    ex, ez = terrain.extent
    lo, hi = terrain.min, terrain.max
    if engine == "unity":  # RAW rows from the south edge (z = 0), heights over Y = lo
        raw = np.fromfile(out / "T.raw", "<u2").reshape(terrain.shape)
        h = lo + raw * (hi - lo) / 65535
        return _bilinear(h, p[:, 2] / dz, p[:, 0] / dx), p[:, 1], lst
    if engine == "unreal":  # PNG rows along +Y, columns along +X, centimetres
        png = np.asarray(Image.open(out / "T.png"), np.float64)
        h = lo + png * (hi - lo) / 65535
        return _bilinear(h, p[:, 1] / 100 / dz, p[:, 0] / 100 / dx), p[:, 2] / 100, lst
    if engine == "godot":
        h = read_heightmap(out / "T.exr").heights
        return _bilinear(h, p[:, 2] / dz, p[:, 0] / dx), p[:, 1], lst
    h = tifffile.imread(out / "T.tif")  # first row = the plane's +Y edge, plane centred
    return _bilinear(h, (ez / 2 - p[:, 1]) / dz, (p[:, 0] + ex / 2) / dx), p[:, 2], lst


def _plus_x(engine, rotation):
    """Where each engine's own rotation sends the mesh's +X axis (its documented API)."""
    t = np.radians(rotation) if engine in ("unity", "unreal") else rotation
    if engine in ("unity", "godot"):  # Quaternion.Euler(0, t, 0) / Basis(UP, t), Y up
        return np.stack([np.cos(t), np.zeros_like(t), -np.sin(t)], 1)
    return np.stack([np.cos(t), np.sin(t), np.zeros_like(t)], 1)  # FRotator yaw / Euler z


def _to_engine_vector(engine, v):
    x, y, z = v[:, 0], v[:, 1], v[:, 2]
    return {"unity": np.stack([x, y, -z], 1), "unreal": np.stack([x, z, y], 1),
            "godot": v, "blender": np.stack([x, -z, y], 1)}[engine]


@pytest.mark.parametrize("engine", ["unity", "unreal", "godot", "blender"])
def test_engine_instance_lists(engine, terrain, tmp_path):
    hm = terrain
    if engine == "unreal":  # Unreal's sizes: crop to 127
        hm = Heightmap(terrain.heights[:127, :127], terrain.spacing)
    inst = scatter(hm, seed=4)
    options = ExportOptions(name="T", layers=False, objects=lambda fitted: scatter(fitted, seed=4))
    files = get_destination(engine).export(hm, tmp_path, options)
    names = {f.name for f in files}
    ext = "csv" if engine == "unreal" else "json"
    assert {"T_objects.glb", f"T_objects.{ext}", "T_objects_import.txt"} <= names
    ground, listed, lst = _engine_heights(engine, tmp_path, hm)
    assert len(listed) == len(inst) > 100
    err = np.abs(ground - listed)
    assert np.median(err) < 0.1 and err.max() < 1.5, (np.median(err), err.max())
    # back into terrascape's frame: the very instances
    world, yaw = engine_to_world(engine, hm, lst["position"], lst["rotation"])
    np.testing.assert_allclose(world, inst.positions, atol=2e-3)
    assert np.abs(np.angle(np.exp(1j * (yaw - inst.yaw)))).max() < 1e-5
    np.testing.assert_allclose(lst["scale"], inst.scale, rtol=1e-6)
    assert list(lst["mesh"]) == [inst.meshes[k].name for k in inst.kind]
    # the engine's own rotation sends the mesh's +X where terrascape's yaw does
    plus_x = inst.matrices()[:, :3, 0] / inst.scale[:, None]
    np.testing.assert_allclose(_plus_x(engine, lst["rotation"]),
                               _to_engine_vector(engine, plus_x.astype(np.float64)), atol=1e-5)
    # the meshes glb holds each used mesh once, named
    doc = pygltflib.GLTF2.load_binary(tmp_path / "T_objects.glb")
    assert {n.name for n in doc.nodes} == {inst.meshes[k].name for k in set(inst.kind)}


def test_world_engine_round_trip(terrain):
    rng = np.random.default_rng(1)
    p = rng.uniform(0, 500, (20, 3))
    yaw = rng.uniform(0, 2 * np.pi, 20)
    for engine in ("unity", "unreal", "godot", "blender"):
        q, r = world_to_engine(engine, terrain, p, yaw)
        back, y = engine_to_world(engine, terrain, q, r)
        np.testing.assert_allclose(back, p, atol=1e-9)
        np.testing.assert_allclose(y, yaw, atol=1e-9)


def test_cli_objects_scatter_writes_a_list(terrain, tmp_path):
    from terrascape.io import write_heightmap

    src = tmp_path / "t.tif"
    write_heightmap(terrain, src)
    out = tmp_path / "o.json"
    assert run_app(["objects", "scatter", str(src), str(out), "--seed", "1", "-q"]) == 0
    first = out.read_bytes()
    lst = read_instances_json(out)
    inst = scatter(read_heightmap(src), seed=1)
    # the decimals read back to the very float32 values
    np.testing.assert_array_equal(lst["positions"].astype(np.float32), inst.positions)
    np.testing.assert_array_equal(lst["yaw"].astype(np.float32), inst.yaw)
    assert lst["count"] == len(inst) and sum(lst["counts"].values()) == len(inst)
    # same seed, same bytes; existing output needs --force; a bad rules key is one line
    assert run_app(["objects", "scatter", str(src), str(out), "--seed", "1", "-q"]) == 2
    assert run_app(["objects", "scatter", str(src), str(out), "--seed", "1", "-q",
                    "--force"]) == 0
    assert out.read_bytes() == first
    rules = tmp_path / "r.toml"
    rules.write_text('[[rules]]\nname = "x"\nmeshes = ["rock"]\ndensity = 5\nspacing = 2\n'
                     'slop = [0, 10]\n')
    assert run_app(["objects", "scatter", str(src), str(tmp_path / "x.json"), "--objects",
                    str(rules)]) == 2
    assert not (tmp_path / "x.json").exists()
    rules.write_text('[[rules]]\nname = "x"\nmeshes = ["rock"]\ndensity = 5000\nspacing = 2\n')
    assert run_app(["objects", "scatter", str(src), str(tmp_path / "x.json"), "--objects",
                    str(rules)]) == 2
    doc = json.loads(first)
    assert doc["terrain"]["spacing"] == [4.0, 4.0]


def test_web_page_draws_the_instanced_trees(terrain, tmp_path):
    """three.js (headless Chromium) draws the EXT_mesh_gpu_instancing nodes: the top view
    with objects has foliage-dark pixels the same page without them lacks."""
    import shutil
    import subprocess

    from terrascape.io import write_heightmap

    chromium = next((shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome")
                     if shutil.which(n)), None)
    if chromium is None:
        if os.environ.get("CI", "").lower() in {"1", "true", "yes"}:
            pytest.fail("CI must run the browser test: apt-get install -y chromium")
        pytest.skip("chromium is not installed")
    hm = Heightmap(terrain.heights[:65, :65] * 0.05, (3.0, 3.0))  # 192 m: trees show
    src = tmp_path / "t.tif"
    write_heightmap(hm, src)
    shots = {}
    for label, extra in (("bare", []), ("trees", ["--objects", "default", "--seed", "1"])):
        assert run_app(["export", "web", str(src), "-o", str(tmp_path / label), "-q",
                        *extra]) == 0
        out = tmp_path / f"{label}.png"
        subprocess.run([chromium, "--headless", "--no-sandbox", "--use-angle=swiftshader",
                        "--enable-unsafe-swiftshader", "--disable-gpu-sandbox", "--no-first-run",
                        f"--user-data-dir={tmp_path / ('p-' + label)}", "--window-size=480,400",
                        "--virtual-time-budget=20000", f"--screenshot={out}",
                        (tmp_path / label / "index.html").as_uri() + "#top"],
                       capture_output=True, timeout=180)
        img = np.asarray(Image.open(out).convert("RGB")).astype(np.float64)[:-30]
        r, g, b = img[..., 0], img[..., 1], img[..., 2]
        shots[label] = np.mean((g > r + 4) & (g > b) & (img.mean(axis=2) < 70))
    assert shots["trees"] > shots["bare"] + 0.03, shots
