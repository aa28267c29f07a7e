"""The static meshers' table: every entry meshes any map size within its bound or budget,
refuses what it does not take, and ``terrascape mesh`` offers exactly the table."""

from __future__ import annotations

import re
import subprocess
import sys

import numpy as np
import pytest
import trimesh

from terrascape.cli.app import run_app
from terrascape.errors import InvalidParameterError
from terrascape.generate import diamond_square
from terrascape.heightmap import Heightmap
from terrascape.io import write_heightmap
from terrascape.lod.mesh_checks import conformity_report, max_vertical_error
from terrascape.lod.static_meshers import DEFAULT_STATIC_MESHER, STATIC_MESHERS, static_mesher

NAMES = list(STATIC_MESHERS)


def _map(rows: int, cols: int) -> Heightmap:
    """A rough map of any size: a crop of diamond-square heights."""
    side = 3
    while side < max(rows, cols):
        side = 2 * side - 1
    full = diamond_square(side, roughness=30.0, seed=11).heights
    return Heightmap(np.ascontiguousarray(full[:rows, :cols]), (2.0, 2.0))


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("shape", [(65, 65), (40, 57)])
def test_each_mesher_covers_the_map_within_its_error(name: str, shape) -> None:
    hm = _map(*shape)
    for error in (0.5, 3.0):
        tri = STATIC_MESHERS[name].mesh(hm, max_error=error)
        assert tri.dtype == np.uint32 and tri.ndim == 2 and tri.shape[1] == 3
        assert conformity_report(tri, hm.shape).ok, (name, shape, error)
        assert max_vertical_error(hm, tri) <= error * (1 + 1e-6), (name, shape, error)
        assert len(tri) < 2 * (shape[0] - 1) * (shape[1] - 1)  # it did simplify


@pytest.mark.parametrize("name", NAMES)
def test_each_mesher_keeps_its_triangle_budget(name: str) -> None:
    hm = _map(65, 65)
    coarse = STATIC_MESHERS[name].mesh(hm, max_triangles=200)
    fine = STATIC_MESHERS[name].mesh(hm, max_triangles=2000)
    assert 0 < len(coarse) <= 200 and len(coarse) < len(fine) <= 2000
    assert conformity_report(coarse, hm.shape).ok
    assert max_vertical_error(hm, fine) < max_vertical_error(hm, coarse)


def test_options_a_mesher_does_not_take_are_refused() -> None:
    hm = _map(17, 17)
    taking = [m for m in STATIC_MESHERS.values() if "in_pieces" in m.options]
    refusing = [m for m in STATIC_MESHERS.values() if "in_pieces" not in m.options]
    assert taking and refusing  # both branches are exercised
    for m in taking:
        assert conformity_report(m.mesh(hm, max_error=1.0, in_pieces=False), hm.shape).ok
    for m in refusing:
        with pytest.raises(InvalidParameterError, match="does not take in_pieces"):
            m.mesh(hm, max_error=1.0, in_pieces=False)
    with pytest.raises(InvalidParameterError, match=r"unknown static mesher 'bogus'.*rtin"):
        static_mesher("bogus")
    assert static_mesher("greedy") is STATIC_MESHERS["greedy"]
    assert static_mesher(None) is STATIC_MESHERS[DEFAULT_STATIC_MESHER] is STATIC_MESHERS["rtin"]


def test_each_mesher_names_the_warm_up_that_compiles_it() -> None:
    from terrascape.warmup import WARM_UP_TASKS

    for m in STATIC_MESHERS.values():
        assert m.warm_up in WARM_UP_TASKS, m.name
        assert "terrascape mesh" in WARM_UP_TASKS[m.warm_up].summary


def test_a_slow_first_mesh_says_it_compiles(monkeypatch, tmp_path, capsys) -> None:
    import importlib
    import time

    cli_app = importlib.import_module("terrascape.cli.app")  # the module, not its app
    from terrascape.lod.static_meshers import StaticMesher

    src = tmp_path / "hm.npy"
    write_heightmap(_map(33, 33), src)
    real = StaticMesher.mesh

    def slow(self, *args, **kwargs):  # as a first run that compiles
        time.sleep(0.5)
        return real(self, *args, **kwargs)

    monkeypatch.setattr(cli_app, "SLOW_NOTE_AFTER", 0.05)
    monkeypatch.setattr(StaticMesher, "mesh", slow)
    assert run_app(["mesh", str(src), "-o", str(tmp_path / "g.obj"), "--max-error", "1",
                    "--mesher", "greedy"]) == 0
    assert ("a big map takes a while, and a first run on a new installation also compiles the "
            "mesher, once (`terrascape warm-up --only greedy`") in " ".join(
        capsys.readouterr().err.split())


def test_the_table_imports_no_mesher() -> None:
    """Reading the table (as ``--help`` does) loads neither numba nor a mesher's module."""
    code = ("import sys; import terrascape.lod.static_meshers as m; "
            "print(sorted(k for k in sys.modules if k == 'numba' or k.startswith("
            "('terrascape.lod.greedy_tin', 'terrascape.lod.rtin', 'terrascape.export'))))")
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=True).stdout.strip()
    assert loaded == "[]"


def test_mesh_command_offers_exactly_the_table(capsys) -> None:
    assert run_app(["mesh", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    text = re.sub(r"[│╭╮╰╯─]", " ", text)
    help_of_mesher = text.split("--mesher", 1)[1].split("--one-piece", 1)[0]
    help_of_mesher, default = help_of_mesher.split("[default:", 1)
    assert default.split("]")[0].strip(" ()") == NAMES[0]
    # the names outside parentheses, each followed by its help in parentheses
    offered, depth, outside = [], 0, ""
    for char in help_of_mesher:
        if char == "(" and depth == 0:
            offered.append(outside.split()[-1])
            outside = ""
        depth += (char == "(") - (char == ")")
        if depth == 0 and char != ")":
            outside += char
    assert offered == NAMES


@pytest.mark.parametrize("name", NAMES)
def test_mesh_command_writes_each_meshers_mesh(name: str, tmp_path) -> None:
    hm = _map(40, 57)
    src = tmp_path / "hm.npy"
    write_heightmap(hm, src)
    out = tmp_path / f"{name}.obj"
    assert run_app(["mesh", str(src), "-o", str(out), "--spacing", "2", "--max-error", "1",
                    "--mesher", name, "-q"]) == 0
    written = trimesh.load(out, force="mesh", process=False)
    expected = STATIC_MESHERS[name].mesh(hm, max_error=1.0)
    assert len(written.faces) == len(expected)
    # the written vertices are the map's samples: x = col·dx, y = height, z = row·dz
    cols = np.rint(written.vertices[:, 0] / 2.0).astype(int)
    rows = np.rint(written.vertices[:, 2] / 2.0).astype(int)
    np.testing.assert_allclose(written.vertices[:, 1], hm.heights[rows, cols], atol=1e-3)
    assert sorted(map(tuple, np.sort((rows * 57 + cols)[written.faces], axis=1))) == sorted(
        map(tuple, np.sort(expected.astype(int), axis=1)))


def test_mesh_command_refuses_a_mesher_for_a_view_mesh(tmp_path) -> None:
    src = tmp_path / "hm.npy"
    write_heightmap(_map(33, 33), src)
    base = ["mesh", str(src), "-o", str(tmp_path / "v.obj"), "--camera", "0,50,0",
            "--target", "30,0,30", "-q"]
    for name in NAMES:
        assert run_app([*base, "--mesher", name]) == 2
    assert run_app(base) == 0  # no mesher: the view-dependent mesh
    assert run_app(["mesh", str(src), "-o", str(tmp_path / "b.obj"), "--max-error", "1",
                    "--mesher", "bogus", "-q"]) == 2
    assert not (tmp_path / "b.obj").exists()


def test_the_package_offers_the_table() -> None:
    import terrascape.lod as lod

    assert lod.STATIC_MESHERS is STATIC_MESHERS and lod.static_mesher is static_mesher
    assert set(lod.__all__) == set(lod._WHERE)  # every lazy name listed, and only those
