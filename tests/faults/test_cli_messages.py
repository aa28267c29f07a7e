"""Each message the reliability review found unclear now says what is wrong and how to fix
it, in one line with the right exit code, and writes nothing."""

from __future__ import annotations

import re

import numpy as np
import pytest

from terrascape import Heightmap
from terrascape.cli.app import run_app
from terrascape.io import write_heightmap

# stage timings ("read… 0.00 s") and the note a stage still running after 5 s prints (a
# first run compiling, or a loaded machine): not error lines
_NOT_ERRORS = r"… \d+\.\d+ s$|: still working after \d"


def _error_line(err: str) -> str:
    assert "Traceback" not in err and "╭" not in err, err  # no traceback, no boxed panel
    lines = [line for line in err.splitlines()
             if line.strip() and not re.search(_NOT_ERRORS, line)]
    assert len(lines) == 1, err
    return lines[0]


@pytest.fixture
def hm_file(tmp_path):
    path = tmp_path / "hm.npy"
    rng = np.random.default_rng(4)
    write_heightmap(Heightmap(rng.random((33, 33)).astype(np.float32) * 50), path)
    return path


def _run(capsys, argv) -> tuple[int, str]:
    code = run_app([str(a) for a in argv])
    return code, _error_line(capsys.readouterr().err)


def test_typer_range_error_is_one_line(tmp_path, hm_file, capsys):
    code, line = _run(capsys, ["texture", "regions", hm_file, "-o", tmp_path / "t.png",
                               "--scale", "0"])
    assert code == 2
    assert line.startswith("error: Invalid value for '--scale'")
    assert "terrascape texture regions --help" in line


def test_unknown_option_is_one_line(capsys):
    code, line = _run(capsys, ["generate", "fault", "--bogus"])
    assert code == 2 and "No such option: --bogus" in line


def test_sun_elevation_range_is_stated_as_checked(tmp_path, hm_file, capsys):
    for value in ("1000", "-10"):
        code, line = _run(capsys, ["shade", hm_file, "-o", tmp_path / "s.png",
                                   "--sun", f"10,{value}"])
        assert code == 2 and "must be in (0, 90] degrees" in line, line
    assert not (tmp_path / "s.png").exists()


def test_normalmap_refuses_height_scale_that_flattens_normals(tmp_path, hm_file, capsys):
    code, line = _run(capsys, ["normalmap", hm_file, "-o", tmp_path / "n.png",
                               "--height-scale", "1e300"])
    assert code == 2 and "|F| <= 1e6" in line
    assert not (tmp_path / "n.png").exists()


def test_relief_refuses_a_non_png_name(tmp_path, capsys):
    code, line = _run(capsys, ["relief", tmp_path / "x.jpg"])
    assert code == 2 and "must end in .png" in line
    assert not (tmp_path / "x.jpg").exists()


def test_roam_max_triangles_without_roam_is_refused(tmp_path, hm_file, capsys):
    code, line = _run(capsys, ["mesh", hm_file, "-o", tmp_path / "m.obj", "--max-error", "1",
                               "--roam-max-triangles", "100"])
    assert code == 2 and "--lod roam" in line
    assert not (tmp_path / "m.obj").exists()


def test_mesh_size_error_names_the_real_option(tmp_path, capsys):
    path = tmp_path / "odd.npy"
    write_heightmap(Heightmap(np.zeros((30, 40), np.float32)), path)
    # static meshes take any rectangle; the view-dependent schemes need a 2**n + 1 square
    code, line = _run(capsys, ["mesh", path, "-o", tmp_path / "m.obj", "--camera", "0,50,0",
                               "--target", "20,0,15", "--lod", "roam"])
    assert code == 2 and "--fit pad" in line and "--pad/--resample" not in line


def test_turntable_is_bounded(tmp_path, hm_file, capsys):
    code, line = _run(capsys, ["render", hm_file, "-o", tmp_path / "t.png",
                               "--turntable", "10001"])
    assert code == 2 and "--turntable must be in [0, 10000]" in line


def test_convert_into_a_folder_says_it_is_a_folder(tmp_path, hm_file, capsys):
    (tmp_path / "adir").mkdir()
    code, line = _run(capsys, ["convert", hm_file, tmp_path / "adir"])
    assert code == 2 and "is a folder" in line and "--force" not in line


def test_demo_into_an_existing_file(tmp_path, capsys):
    target = tmp_path / "demo-output"
    target.write_text("mine")
    code, line = _run(capsys, ["demo", "-o", target])
    assert code == 2 and "must be a folder" in line
    assert target.read_text() == "mine"


def test_existing_output_and_dangling_symlink_need_force(tmp_path, hm_file, capsys):
    link = tmp_path / "o.png"
    link.symlink_to(tmp_path / "nowhere.png")
    code, line = _run(capsys, ["convert", hm_file, link])
    assert code == 2 and "symlink" in line and "--force" in line
    assert link.is_symlink() and not (tmp_path / "nowhere.png").exists()
