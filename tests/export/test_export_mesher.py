"""``terrascape export blender --format glb`` and ``export web`` with ``--mesher``: the glb's
terrain is the chosen static mesher's mesh, valid for the glTF validator, read back by
trimesh on the map's samples within the error the note reports as measured."""

from __future__ import annotations

import re

import numpy as np
import pygltflib
import pytest
import trimesh
from scipy import ndimage

from terrascape import Heightmap
from terrascape.cli import run_app
from terrascape.export.glb import write_terrain_glb
from terrascape.lod.mesh_checks import max_vertical_error
from terrascape.lod.static_meshers import STATIC_MESHERS

SPACING = 10.0


@pytest.fixture(scope="module")
def source(tmp_path_factory):
    rng = np.random.default_rng(5)
    h = ndimage.gaussian_filter(rng.standard_normal((90, 121)), 4) * 600 + 200
    hm = Heightmap(h.astype(np.float32), (SPACING, SPACING))
    path = tmp_path_factory.mktemp("mesher") / "m.npy"
    np.save(path, hm.heights)
    return path, hm


def _grid_triangles_of(glb, hm: Heightmap) -> np.ndarray:
    """The glb's terrain as grid indices: every vertex must sit on a sample, at its height."""
    mesh = trimesh.load(glb, force="mesh", process=False)
    cols = np.rint(mesh.vertices[:, 0] / SPACING).astype(np.int64)
    rows = np.rint(mesh.vertices[:, 2] / SPACING).astype(np.int64)
    np.testing.assert_allclose(mesh.vertices[:, 0], cols * SPACING, atol=1e-3)
    np.testing.assert_allclose(mesh.vertices[:, 2], rows * SPACING, atol=1e-3)
    np.testing.assert_allclose(mesh.vertices[:, 1], hm.heights[rows, cols], atol=1e-3)
    return (rows * hm.cols + cols)[mesh.faces].astype(np.uint32)


@pytest.mark.parametrize("mesher", list(STATIC_MESHERS))
def test_blender_glb_is_the_meshers_mesh(source, tmp_path, mesher, gltf_validator):
    path, hm = source
    out = tmp_path / mesher
    assert run_app(["export", "blender", str(path), "-o", str(out), "--format", "glb",
                    "--spacing", str(SPACING), "--max-error", "2", "--mesher", mesher,
                    "-q"]) == 0
    glb = out / "m.glb"
    issues = gltf_validator(glb)
    assert issues["numErrors"] == 0, issues["messages"]
    tri = _grid_triangles_of(glb, hm)
    expected = STATIC_MESHERS[mesher].mesh(hm, max_error=2.0)
    assert sorted(map(tuple, np.sort(tri, axis=1))) == sorted(
        map(tuple, np.sort(expected, axis=1)))
    measured = max_vertical_error(hm, tri)
    assert measured <= 2.0 * (1 + 1e-6)
    note = (out / "m_import.txt").read_text()
    n, mesher_named, err = re.search(
        r"(\d+) triangles \((\w+) mesher\), maximum vertical error ([\d.e+-]+) world units "
        r"\(measured", note).groups()
    assert int(n) == len(tri) and mesher_named == mesher
    assert float(err) == pytest.approx(measured, rel=1e-3)


def test_greedy_gives_the_web_page_fewer_triangles(source, tmp_path, gltf_validator):
    path, hm = source
    faces, titles = {}, {}
    for mesher in ("rtin", "greedy"):
        site = tmp_path / mesher
        assert run_app(["export", "web", str(path), "-o", str(site), "--spacing",
                        str(SPACING), "--max-error", "1.5", "--mesher", mesher, "-q"]) == 0
        issues = gltf_validator(site / "m.glb")
        assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, issues["messages"]
        doc = pygltflib.GLTF2.load(site / "m.glb")
        terrain = doc.meshes[0].primitives[0]
        faces[mesher] = doc.accessors[terrain.indices].count // 3
        titles[mesher] = re.search(r"(\d[\d,]*) triangles \(max error ([\d.e+-]+), measured\)",
                                   (site / "index.html").read_text()).groups()
    for mesher in faces:
        tri = STATIC_MESHERS[mesher].mesh(hm, max_error=1.5)
        assert faces[mesher] == len(tri)
        assert int(titles[mesher][0].replace(",", "")) == len(tri)
        assert float(titles[mesher][1]) == pytest.approx(max_vertical_error(hm, tri),
                                                         rel=2e-3)
        assert float(titles[mesher][1]) <= 1.5
    assert faces["greedy"] < 0.9 * faces["rtin"]


def test_write_terrain_glb_takes_the_mesher(source, tmp_path):
    _, hm = source
    counts = {}
    for mesher in STATIC_MESHERS:
        glb, mesh = write_terrain_glb(hm, tmp_path / f"{mesher}.glb", max_error=2.0,
                                      mesher=mesher)
        tri = _grid_triangles_of(glb, hm)
        np.testing.assert_array_equal(np.sort(np.sort(tri, axis=1), axis=0),
                                      np.sort(np.sort(mesh.grid_triangles(), axis=1), axis=0))
        counts[mesher] = len(tri)
    assert counts["greedy"] < counts["rtin"]


def test_a_mesher_where_none_meshes_is_refused(source, tmp_path):
    path, _ = source
    for args in (["unity"], ["cesium"], ["blender"]):  # blender's default is the TIFF
        out = tmp_path / args[0]
        assert run_app(["export", *args, str(path), "-o", str(out), "--mesher", "greedy",
                        "-q"]) == 2
        assert not out.exists()
    assert run_app(["export", "web", str(path), "-o", str(tmp_path / "w"), "--mesher",
                    "bogus", "-q"]) == 2
    assert not (tmp_path / "w").exists()
