"""One vocabulary across the CLI: help texts from the registries in users' words, --version,
--sun AZ,EL everywhere, technique aliases, cameras above ground, output for logs."""

from __future__ import annotations

import contextlib
import io
import itertools
import re

import numpy as np
import pytest
import typer.main

from terrascape import Heightmap, __version__
from terrascape.cli import app, load_command_modules, run_app

#: Words that belong to the project's notes, not to a user's screen.
NOT_USERS_WORDS = re.compile(r"seed \d{3}|§|MISSION|\(R\d+\)|\b[HRTP]\d+\b|<bool>")


def _command_paths(cmd, path=()):
    yield list(path)
    for name, sub in getattr(cmd, "commands", {}).items():
        yield from _command_paths(sub, (*path, name))


def _help(path: list[str], monkeypatch) -> str:
    monkeypatch.setenv("COLUMNS", "250")  # one option per line: easier to read failures
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert run_app([*path, "--help"]) == 0
    return buf.getvalue()


load_command_modules()  # commands are imported when run; the scan needs every one built
ALL_COMMANDS = list(_command_paths(typer.main.get_command(app)))


def test_every_command_is_scanned():
    names = {" ".join(p) for p in ALL_COMMANDS}
    assert {"", "render", "view", "shade", "relief", "texture splat", "bench", "convert"} <= names


@pytest.mark.parametrize("path", ALL_COMMANDS, ids=lambda p: " ".join(p) or "terrascape")
def test_help_speaks_the_users_words(path, monkeypatch):
    text = _help(path, monkeypatch)
    found = sorted({m.group(0) for m in NOT_USERS_WORDS.finditer(text)})
    assert not found, f"`terrascape {' '.join(path)} --help` shows {found}"


@pytest.mark.parametrize("path", ALL_COMMANDS, ids=lambda p: " ".join(p) or "terrascape")
def test_help_paragraphs_are_not_broken_mid_sentence(path, monkeypatch):
    # Typer keeps the line breaks of a docstring's later paragraphs: lines written wider than
    # the terminal come out as a long line and a stub ("... spends most of its time\ncompiling").
    monkeypatch.setenv("COLUMNS", "80")
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert run_app([*path, "--help"]) == 0
    lines = [line.rstrip() for line in buf.getvalue().splitlines()]
    start = next(i for i, line in enumerate(lines) if "Usage:" in line) + 1
    end = next((i for i, line in enumerate(lines) if line.startswith("╭")), len(lines))
    text = lines[start:end]
    for line, after in itertools.pairwise(text):
        assert not (line.strip() and after.strip() and len(line) < 50), (
            f"`terrascape {' '.join(path)} --help` breaks a sentence after {line.strip()!r}")


def test_technique_help_lists_the_registry(monkeypatch):
    from terrascape.render.relief_techniques import QUAD_TECHNIQUE
    from terrascape.render.techniques import technique_names

    for command in ("render", "view"):
        flat = " ".join(_help([command], monkeypatch).split())
        for name in technique_names():
            assert re.search(rf"\b{name}\b", flat), f"{command} --help lacks {name}"
    relief = " ".join(_help(["relief"], monkeypatch).split())
    for name in (*QUAD_TECHNIQUE, "prewarp"):
        assert re.search(rf"\b{name}\b", relief), f"relief --help lacks {name}"


def test_version(capsys):
    assert run_app(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"terrascape {__version__}"


def test_technique_aliases_resolve_with_one_note():
    from terrascape.render.relief_techniques import quad_technique
    from terrascape.render.techniques import (
        TECHNIQUE_ALIASES,
        get_technique,
        technique_names,
    )

    names = technique_names()
    assert not set(TECHNIQUE_ALIASES) & set(names)  # an alias never shadows a name
    for alias, canonical in TECHNIQUE_ALIASES.items():
        assert canonical in names
        with pytest.warns(FutureWarning, match=f"now called '{canonical}'"):
            assert get_technique(alias).name == canonical
    # The relief quad takes the registry's names and its own old ones.
    assert quad_technique("steep_parallax") == "steep"
    assert quad_technique("relief_by_distance") == "by_distance"
    with pytest.warns(FutureWarning):
        assert quad_technique("offset_limiting") == "offset_limiting"
    from terrascape.errors import InvalidParameterError

    with pytest.raises(InvalidParameterError, match="available: plain, parallax"):
        quad_technique("splat")


def test_warnings_are_one_line(tmp_path, capsys):
    from terrascape.io import write_heightmap

    src = tmp_path / "h.png"
    write_heightmap(Heightmap(np.arange(64, dtype=np.float32).reshape(8, 8)), src)
    assert run_app(["convert", str(src), str(tmp_path / "h.bmp")]) == 0
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if "warning" in ln]
    assert len(lines) == 1 and "normalised to 0…1" in lines[0] and ".png (16-bit)" in lines[0]
    assert "warnings.warn" not in err and "Warning:" not in err


def test_shade_sun_matches_the_old_options(tmp_path, capsys):
    from PIL import Image

    from terrascape.io import write_heightmap

    z, x = np.mgrid[0:33, 0:33]
    src = tmp_path / "h.png"
    write_heightmap(Heightmap((20 * np.sin(x / 5) * np.cos(z / 7)).astype(np.float32)), src)
    new, old = tmp_path / "new.png", tmp_path / "old.png"
    assert run_app(["shade", str(src), "-o", str(new), "--sun", "90,30", "-q"]) == 0
    capsys.readouterr()
    assert run_app(["shade", str(src), "-o", str(old), "--sun-azimuth", "90",
                    "--sun-elevation", "30", "-q"]) == 0
    assert "deprecated; use --sun AZ,EL" in capsys.readouterr().err
    a, b = np.asarray(Image.open(new)), np.asarray(Image.open(old))
    np.testing.assert_array_equal(a, b)
    other = tmp_path / "other.png"
    assert run_app(["shade", str(src), "-o", str(other), "--sun", "270,30", "-q"]) == 0
    assert (np.asarray(Image.open(other)) != a).any()  # the option is really used
    assert run_app(["shade", str(src), "-o", str(tmp_path / "x.png"), "--sun", "90"]) == 2


def test_missing_optional_module_is_one_line(monkeypatch, capsys):
    import terrascape.cli.cmd_files as cmd_files

    def boom(*args, **kwargs):
        raise ModuleNotFoundError("No module named 'moderngl_window'", name="moderngl_window")

    monkeypatch.setattr(cmd_files, "_read", boom)
    assert run_app(["info", "x.png"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0
    assert "pip install 'terrascape[viewer]'" in err and "moderngl_window" in err


def test_camera_height_and_under_ground_warning():
    from terrascape.cli.cmd_render import build_camera, ground_height

    z, x = np.mgrid[0:17, 0:17]
    hm = Heightmap((100 + 5 * x + 2 * z).astype(np.float32), (4.0, 4.0))
    assert ground_height(hm, 8.0, 12.0) == pytest.approx(100 + 5 * 2 + 2 * 3)
    cam = build_camera(hm, (160, 90), 1.0, "8,12", "30,0,30", None, camera_height=10.0)
    assert cam.eye[1] == pytest.approx(126.0)
    cam = build_camera(hm, (160, 90), 2.0, "8,0,12", "30,0,30", None, camera_height=10.0)
    assert cam.eye[1] == pytest.approx(2 * 116 + 10)  # on the exaggerated ground
    with pytest.warns(UserWarning, match=r"36 under the ground, whose height at x = 8, "
                                         r"z = 12 is 116"):
        build_camera(hm, (160, 90), 1.0, "8,80,12", "30,0,30", None)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        build_camera(hm, (160, 90), 1.0, "8,200,12", "30,0,30", None)
    from terrascape.errors import InvalidParameterError

    with pytest.raises(InvalidParameterError, match="--camera-height needs --camera"):
        build_camera(hm, (160, 90), 1.0, None, None, None, camera_height=5.0)
