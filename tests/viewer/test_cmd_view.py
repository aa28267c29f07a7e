"""`terrascape view` without a window: help, option errors, the no-display error."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from terrascape.cli.app import run_app
from terrascape.cli.cmd_view import generate_terrain
from terrascape.errors import GLUnavailableError, InvalidParameterError
from terrascape.viewer.app import check_display, key_names

CLI = "import sys; from terrascape.cli import main; main(sys.argv[1:])"


def test_help_works_without_display(monkeypatch, capsys):
    monkeypatch.delenv("DISPLAY", raising=False)
    assert run_app(["view", "--help"]) == 0
    text = capsys.readouterr().out
    for option in ("--generate", "--gen-size", "--texture", "--technique", "--lod", "--size",
                   "--fullscreen", "--screenshot-dir"):
        assert option in text


def test_no_display_is_one_line_exit_2_with_hint():
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    env["COLUMNS"] = "200"
    proc = subprocess.run(
        [sys.executable, "-c", CLI, "view", "--generate", "diamond-square", "--gen-size", "65"],
        env=env, capture_output=True, text=True, timeout=60,
    )
    assert proc.returncode == 2
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, proc.stderr
    assert "DISPLAY" in lines[0] and "terrascape render" in lines[0]
    assert "Traceback" not in proc.stderr


def test_check_display(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    if sys.platform.startswith("linux"):
        with pytest.raises(GLUnavailableError, match="terrascape render"):
            check_display()
    monkeypatch.setenv("DISPLAY", ":12345")
    check_display()  # set: the window library gets to try (and fails with the same hint)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["view"], "either a HEIGHTMAP"),
        (["view", "x.png", "--generate", "hills"], "not both"),
        (["view", "--generate", "volcano"], "--generate must be one of"),
        (["view", "--generate", "hills", "--technique", "nope"], "--technique must be one of"),
        (["view", "--generate", "hills", "--lod", "octree"], "--lod must be one of"),
        (["view", "--generate", "hills", "--size", "12by3"], "--size"),
        (["view", "--generate", "hills", "--exaggeration", "0"], "--exaggeration"),
        (["view", "--generate", "hills", "--sea-level", "nan"], "--sea-level"),
        (["view", "--generate", "hills", "--target-fps", "-1"], "--target-fps"),
        (["view", "--generate", "hills", "--object-shadows", "none"], "needs --objects"),
        (["view", "--generate", "hills", "--objects", "default", "--object-shadows", "soft"],
         "--object-shadows must be one of"),
    ],
)
def test_bad_options_exit_2_before_opening_a_window(argv, message, monkeypatch, capsys):
    monkeypatch.setenv("DISPLAY", ":12345")  # never reached
    monkeypatch.setenv("COLUMNS", "200")
    assert run_app(argv) == 2
    assert message in capsys.readouterr().err


def test_missing_heightmap_file_is_a_clean_error(monkeypatch, tmp_path, capsys):
    monkeypatch.setattr("terrascape.viewer.app.check_display", lambda: None)
    monkeypatch.setenv("COLUMNS", "200")
    assert run_app(["view", str(tmp_path / "missing.png")]) == 2
    assert "missing.png" in capsys.readouterr().err


@pytest.mark.parametrize("kind", ["diamond-square", "fault", "hills"])
def test_generate_terrain_kinds(kind):
    hm = generate_terrain(kind, 33, 5)
    assert hm.shape == (33, 33) and hm.spacing == (2.0, 2.0)
    assert hm.min == pytest.approx(0.0)
    assert hm.max == pytest.approx(0.2 * 32 * 2.0, rel=1e-5)
    again = generate_terrain(kind, 33, 5)
    np.testing.assert_array_equal(hm.heights, again.heights)
    assert not np.array_equal(hm.heights, generate_terrain(kind, 33, 6).heights)


def test_generate_terrain_rejects_unknown_kind():
    with pytest.raises(InvalidParameterError, match="--generate"):
        generate_terrain("volcano", 33, 0)


def test_key_names_translate_window_codes():
    class Keys:
        A = 97
        TAB = 65289
        F1 = 65470
        ACTION_PRESS = 1
        PAGE_UP = 65365

    names = key_names(Keys)
    assert names[97] == "A" and names[65289] == "TAB" and names[65470] == "F1"
    assert names[65365] == "PAGE_UP" and 1 not in names
    assert names[0xFE20] == "TAB"  # X11 Shift+Tab


def test_sea_level_reaches_the_viewer(monkeypatch, capsys):
    import terrascape.viewer.app as viewer_app

    seen = {}

    def fake_run_viewer(hm, **kwargs):
        seen.update(kwargs, shape=hm.shape)
        return 0

    monkeypatch.setattr(viewer_app, "run_viewer", fake_run_viewer)
    monkeypatch.setattr(viewer_app, "check_display", lambda: None)
    assert run_app(["view", "--generate", "hills", "--gen-size", "33", "--sea-level",
                    "5"]) == 0
    assert seen["sea_level"] == 5.0 and seen["shape"] == (33, 33)
    assert seen["target_fps"] == 15.0  # moving frames held at 15 frames/s by default
    assert run_app(["view", "--generate", "hills", "--gen-size", "33", "--target-fps",
                    "0"]) == 0
    assert seen["target_fps"] == 0.0


@pytest.mark.parametrize("args, message", [
    (["--latitude", "45"], "give --time"),
    (["--time", "06:00"], "has no date"),
    (["--time", "2026-06-21T06:00", "--latitude", "100"], "latitude must be in [-90, 90]"),
])
def test_time_options_fail_before_any_window(monkeypatch, capsys, args, message):
    monkeypatch.delenv("DISPLAY", raising=False)
    assert run_app(["view", "--generate", "fbm", "--gen-size", "33", *args]) == 2
    assert message in " ".join(capsys.readouterr().err.split())
