"""``terrascape render`` CLI, in-process."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from terrascape.cli.app import run_app
from terrascape.heightmap import Heightmap

pytestmark = pytest.mark.gl


@pytest.fixture
def npy_map(tmp_path):
    from terrascape.io import write_heightmap

    x = np.linspace(0, 3, 17, dtype=np.float32)
    path = tmp_path / "hm.npy"
    write_heightmap(Heightmap(np.add.outer(x, x), (2.0, 2.0)), path)
    return path


def test_render_file_to_png(gl_ctx, npy_map, tmp_path):
    out = tmp_path / "a.png"
    code = run_app(
        [
            "render",
            str(npy_map),
            "-o",
            str(out),
            "--size",
            "48x32",
            "-q",
            "--technique",
            "regions",
            "--sun",
            "90,30",
        ]
    )
    assert code == 0
    img = np.asarray(Image.open(out))
    assert img.shape == (32, 48, 3)
    # the same image through the library
    from terrascape.io import read_heightmap
    from terrascape.render.offscreen import render_to_array

    ref = render_to_array(
        read_heightmap(npy_map), technique="regions", size=(48, 32), sun=(90, 30), ctx=gl_ctx
    )
    np.testing.assert_array_equal(img, ref[..., :3])
    # no --force: refused, file untouched
    before = out.read_bytes()
    assert run_app(["render", str(npy_map), "-o", str(out), "--size", "48x32", "-q"]) == 2
    assert out.read_bytes() == before


def test_render_cameras_and_generate(gl_ctx, npy_map, tmp_path):
    a, b, c = (tmp_path / f"{n}.png" for n in "abc")
    assert (
        run_app(
            [
                "render",
                str(npy_map),
                "-o",
                str(a),
                "--size",
                "32x32",
                "-q",
                "--camera",
                "16,20,60",
                "--target",
                "16,0,16",
            ]
        )
        == 0
    )
    assert (
        run_app(
            [
                "render",
                str(npy_map),
                "-o",
                str(b),
                "--size",
                "32x32",
                "-q",
                "--orbit",
                "180,30,60",
                "--wireframe",
            ]
        )
        == 0
    )
    assert (
        run_app(
            [
                "render",
                "--generate",
                "hills",
                "--gen-size",
                "17",
                "--seed",
                "3",
                "-o",
                str(c),
                "--size",
                "32x32",
                "-q",
                "--exaggeration",
                "4",
            ]
        )
        == 0
    )
    imgs = [np.asarray(Image.open(p)) for p in (a, b, c)]
    assert not np.array_equal(imgs[0], imgs[1])
    assert all(i.std() > 1 for i in imgs)


def test_turntable_cli(gl_ctx, npy_map, tmp_path):
    base = tmp_path / "t.png"
    assert (
        run_app(
            ["render", str(npy_map), "-o", str(base), "--size", "32x24", "-q", "--turntable", "2"]
        )
        == 0
    )
    assert sorted(p.name for p in tmp_path.glob("t_*.png")) == ["t_0000.png", "t_0001.png"]


@pytest.mark.parametrize(
    "args, message",
    [
        (["--size", "0x10"], "positive"),
        (["--size", "100000x10"], "exceeds"),
        (["--technique", "nope"], "unknown technique"),
        (["--camera", "1,2,nan", "--target", "0,0,0"], "finite"),
        (["--camera", "1,2,3"], "together"),
        (["--orbit", "1,2,3", "--camera", "1,2,3", "--target", "0,0,0"], "not both"),
        (["--exaggeration", "0"], "exaggeration"),
        (["--sun", "10"], "--sun"),
        (["--turntable", "2", "--format", "gif"], "format"),
        (["-o", "x.jpg"], ".png"),
    ],
)
def test_bad_arguments(npy_map, tmp_path, capsys, args, message):
    out = tmp_path / "o.png"
    argv = ["render", str(npy_map), "-o", str(out), "-q", *args]
    if "-o" in args:
        argv = ["render", str(npy_map), "-q", *args]
    assert run_app(argv) == 2
    assert message in capsys.readouterr().err.replace("\n", "")
    assert list(tmp_path.glob("o*")) == [] and list(tmp_path.glob(".o*")) == []


def test_needs_exactly_one_source(npy_map, capsys):
    assert run_app(["render", "-q"]) == 2
    assert run_app(["render", str(npy_map), "--generate", "hills", "-q"]) == 2
    assert run_app(["render", "--generate", "nope", "-q"]) == 2
    assert run_app([str(npy_map.with_name("missing.npy")), "-q"]) == 2


def test_render_daylight_options(gl_ctx, npy_map, tmp_path, capsys):
    from terrascape.io import read_heightmap
    from terrascape.render.offscreen import render_to_array

    hm = read_heightmap(npy_map)  # heights 0 … 6
    out = tmp_path / "sea.png"
    args = ["render", str(npy_map), "-o", str(out), "--size", "48x32", "-q", "--sun", "135,20"]
    assert run_app([*args, "--sea-level", "2.5", "--surround", "fade"]) == 0
    ref = render_to_array(hm, size=(48, 32), sun=(135, 20), ctx=gl_ctx,
                          params={"sea_level": 2.5, "surround": "fade"})
    np.testing.assert_array_equal(np.asarray(Image.open(out)), ref[..., :3])
    dry = render_to_array(hm, size=(48, 32), sun=(135, 20), ctx=gl_ctx,
                          params={"surround": "fade"})
    assert np.abs(ref.astype(int) - dry.astype(int)).max() > 30  # the water is there
    # a sea level above everything is a note on stderr, not an error
    flood = tmp_path / "flood.png"
    assert run_app([*args[:3], str(flood), *args[4:], "--sea-level", "100"]) == 0
    assert "above the whole terrain" in capsys.readouterr().err
    # the seed's look stays available
    old = tmp_path / "old.png"
    assert run_app([*args[:3], str(old), *args[4:], "--lighting", "vertex"]) == 0
    hq = tmp_path / "hq.png"
    assert run_app([*args[:3], str(hq), *args[4:], "--quality", "high"]) == 0
    assert np.asarray(Image.open(hq)).shape == (32, 48, 3)
    lake = tmp_path / "depth.npy"
    np.save(lake, np.where(np.asarray(hm.heights) < 1.0, 0.5, 0.0).astype(np.float32))
    assert run_app([*args[:3], str(tmp_path / "lake.png"), *args[4:], "--water-depth",
                    str(lake)]) == 0
    wrong = tmp_path / "wrong.npy"
    np.save(wrong, np.zeros((5, 5), np.float32))
    for extra in (["--surround", "ocean"], ["--quality", "ultra"], ["--lighting", "sun"],
                  ["--water-depth", str(wrong)], ["--sea-level", "nan"]):
        bad = tmp_path / "bad.png"
        assert run_app([*args[:3], str(bad), *args[4:], *extra]) == 2, extra
        assert not bad.exists()
