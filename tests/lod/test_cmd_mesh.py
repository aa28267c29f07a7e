"""``terrascape mesh`` CLI: modes, printed measured error, exit codes."""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy import ndimage

from terrascape.cli.app import run_app


@pytest.fixture(scope="module")
def hm_path(tmp_path_factory):
    rng = np.random.default_rng(4)
    h = (ndimage.gaussian_filter(rng.standard_normal((65, 65)), 3) * 400).astype(np.float32)
    path = tmp_path_factory.mktemp("mesh") / "hm.npy"
    np.save(path, h)
    return path


def _faces_in_obj(path):
    return sum(1 for line in open(path) if line.startswith("f "))


def test_static_max_error(hm_path, tmp_path, capsys):
    out = tmp_path / "m.obj"
    assert run_app(["mesh", str(hm_path), "-o", str(out), "--max-error", "3", "-q"]) == 0
    text = capsys.readouterr().out
    n, err = re.search(r"(\d+) triangles.*max vertical error ([\d.e+-]+)", text, re.S).groups()
    assert int(n) == _faces_in_obj(out)
    assert 0 < float(err) <= 3.0


def test_static_budget_glb(hm_path, tmp_path, capsys):
    out = tmp_path / "m.glb"
    assert run_app(["mesh", str(hm_path), "-o", str(out), "--triangles", "500", "-q"]) == 0
    n = int(re.search(r"(\d+) triangles", capsys.readouterr().out).group(1))
    assert 498 <= n <= 500
    assert out.read_bytes()[:4] == b"glTF"


def test_view_dependent_geomipmap(hm_path, tmp_path, capsys):
    out = tmp_path / "v.ply"
    code = run_app(["mesh", str(hm_path), "-o", str(out), "--camera", "-50,600,-50",
                    "--target", "32,0,32", "--tolerance", "4", "--size", "640x480",
                    "--patch-size", "9", "-q"])
    assert code == 0
    err = float(re.search(r"max screen error ([\d.e+-]+) px", capsys.readouterr().out).group(1))
    assert err <= 4.0
    assert out.read_bytes().startswith(b"ply\n")


def test_exit_codes(hm_path, tmp_path):
    out = str(tmp_path / "x.obj")
    base = ["mesh", str(hm_path), "-o", out]
    assert run_app(base) == 2  # no mode
    assert run_app([*base, "--max-error", "1", "--camera", "0,1,0", "--target", "1,0,1"]) == 2
    assert run_app([*base, "--camera", "0,1,0"]) == 2  # no target
    assert run_app([*base, "--max-error", "-1"]) == 2
    assert run_app([*base, "--triangles", "0"]) == 2
    assert run_app([*base, "--camera", "nan,1,0", "--target", "1,0,1"]) == 2
    assert run_app([*base, "--camera", "0,1,0", "--target", "1,0,1", "--tolerance", "0"]) == 2
    assert run_app([*base, "--camera", "0,1,0", "--target", "1,0,1", "--patch-size", "12"]) == 2
    assert run_app(["mesh", str(hm_path), "-o", str(tmp_path / "x.stl"), "--max-error", "1"]) == 2
    assert run_app(["mesh", str(tmp_path / "missing.npy"), "-o", out, "--max-error", "1"]) == 2
    assert run_app([*base, "--lod", "bogus", "--camera", "0,1,0", "--target", "1,0,1"]) == 2
    assert not (tmp_path / "x.obj").exists()
    assert run_app([*base, "--max-error", "5", "-q"]) == 0
    assert run_app([*base, "--max-error", "5", "-q"]) == 2  # exists, no --force
    assert run_app([*base, "--max-error", "5", "-q", "--force"]) == 0


def test_non_pow2_map_static_meshes_any_size_view_needs_fit(tmp_path):
    src = tmp_path / "odd.npy"
    np.save(src, np.random.default_rng(0).random((40, 50)).astype(np.float32))
    out = str(tmp_path / "o.obj")
    view = ["--camera", "0,10,0", "--target", "20,0,20", "-q"]
    assert run_app(["mesh", str(src), "-o", out, *view]) == 2
    assert run_app(["mesh", str(src), "-o", out, *view, "--fit", "pad"]) == 0
    assert run_app(["mesh", str(src), "-o", out, "--max-error", "0.1", "-q", "--force"]) == 0
    with open(out) as fh:
        xs = [float(line.split()[1]) for line in fh if line.startswith("v ")]
    assert max(xs) == 49.0  # the data's own extent, padding dropped


def test_view_dependent_roam(hm_path, tmp_path, capsys):
    pytest.importorskip("terrascape.lod.roam")
    out = tmp_path / "r.obj"
    code = run_app(["mesh", str(hm_path), "-o", str(out), "--camera", "-50,600,-50",
                    "--target", "32,0,32", "--tolerance", "3", "--size", "640x480",
                    "--lod", "roam", "-q"])
    assert code == 0
    text = capsys.readouterr().out
    n = int(re.search(r"(\d+) triangles", text).group(1))
    err = float(re.search(r"max screen error ([\d.e+-]+) px", text).group(1))
    assert err <= 3.0 and n == _faces_in_obj(out)


def test_view_dependent_budget_one_flag_and_old_alias(hm_path, tmp_path, capsys):
    view = ["--camera", "-50,600,-50", "--target", "32,0,32", "--size", "640x480", "-q"]
    counts = {}
    for lod, flag in (("roam", "--triangles"), ("roam", "--roam-max-triangles"),
                      ("turner", "--triangles")):
        out = tmp_path / f"{lod}{flag}.obj"
        assert run_app(["mesh", str(hm_path), "-o", str(out), "--lod", lod, flag, "300",
                        *view]) == 0
        text = capsys.readouterr().out
        assert ("deprecated" in text) == (flag == "--roam-max-triangles")
        counts[lod, flag] = n = int(re.search(r"(\d+) triangles", text).group(1))
        assert n == _faces_in_obj(out) and 0 < n <= 315
    assert counts["roam", "--triangles"] == counts["roam", "--roam-max-triangles"] <= 300
    base = ["mesh", str(hm_path), "-o", str(tmp_path / "x.obj"), *view]
    assert run_app([*base, "--lod", "geomipmap", "--triangles", "300"]) == 2
    assert run_app([*base, "--lod", "turner", "--tolerance", "2"]) == 2
    assert run_app([*base, "--lod", "roam", "--patch-size", "9"]) == 2
    assert not (tmp_path / "x.obj").exists()


def test_greedy_mesher_meets_the_error_with_fewer_triangles(tmp_path):
    import trimesh

    from terrascape.cli.app import run_app as run
    from terrascape.generate import diamond_square
    from terrascape.io import write_heightmap

    src = tmp_path / "hm.npy"
    write_heightmap(diamond_square(65, roughness=20.0, seed=2), src)
    counts = {}
    for mesher in ("rtin", "greedy"):
        out = tmp_path / f"{mesher}.obj"
        assert run(["mesh", str(src), "-o", str(out), "--max-error", "1", "--mesher", mesher,
                    "-q"]) == 0
        counts[mesher] = len(trimesh.load(out, force="mesh").faces)
    assert counts["greedy"] < counts["rtin"]
    assert run(["mesh", str(src), "-o", str(tmp_path / "v.obj"), "--mesher", "greedy",
                "--camera", "0,50,0", "--target", "30,0,30", "-q"]) == 2
    assert run(["mesh", str(src), "-o", str(tmp_path / "b.obj"), "--max-error", "1",
                "--mesher", "bogus", "-q"]) == 2


def test_greedy_one_piece_is_the_single_greedy_order(tmp_path, monkeypatch):
    import trimesh

    from terrascape.cli.app import run_app as run
    from terrascape.generate import diamond_square
    from terrascape.io import read_heightmap, write_heightmap
    from terrascape.lod import greedy_tin as gt

    monkeypatch.setattr(gt, "_PIECE", 40)  # several pieces on a small map
    src = tmp_path / "hm.npy"
    write_heightmap(diamond_square(129, roughness=20.0, seed=5), src)
    hm = read_heightmap(src)
    faces = {}
    for name, flag in (("pieces", []), ("one", ["--one-piece"])):
        out = tmp_path / f"{name}.obj"
        assert run(["mesh", str(src), "-o", str(out), "--max-error", "1.5", "--mesher",
                    "greedy", "-q", *flag]) == 0
        faces[name] = len(trimesh.load(out, force="mesh", process=False).faces)
    assert faces["one"] == len(gt.greedy_tin(hm, max_error=1.5, in_pieces=False))
    assert faces["pieces"] == len(gt.greedy_tin(hm, max_error=1.5))
    assert faces["one"] != faces["pieces"]
    assert run(["mesh", str(src), "-o", str(tmp_path / "r.obj"), "--max-error", "1",
                "--one-piece", "-q"]) == 2
