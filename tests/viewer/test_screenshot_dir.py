"""Where the viewer's F12 screenshots go: the user's pictures folder, else next to the file."""

from __future__ import annotations

from pathlib import Path

from terrascape.viewer.app import default_screenshot_dir, pictures_dir


def test_xdg_pictures_dir_from_the_environment(tmp_path):
    pics = tmp_path / "Bilder"
    pics.mkdir()
    env = {"XDG_PICTURES_DIR": str(pics), "XDG_CONFIG_HOME": str(tmp_path / "cfg")}
    assert pictures_dir(tmp_path, env) == pics
    assert default_screenshot_dir("/data/hm.png", home=tmp_path, environ=env) == (
        pics / "terrascape")


def test_xdg_pictures_dir_from_user_dirs_file(tmp_path):
    (tmp_path / "Slike").mkdir()
    cfg = tmp_path / ".config"
    cfg.mkdir()
    (cfg / "user-dirs.dirs").write_text(
        '# written by xdg-user-dirs-update\nXDG_DESKTOP_DIR="$HOME/Desktop"\n'
        'XDG_PICTURES_DIR="$HOME/Slike"\n')
    assert pictures_dir(tmp_path, {}) == tmp_path / "Slike"


def test_plain_pictures_folder(tmp_path):
    (tmp_path / "Pictures").mkdir()
    assert pictures_dir(tmp_path, {}) == tmp_path / "Pictures"


def test_next_to_the_input_without_a_pictures_folder(tmp_path, monkeypatch):
    home = tmp_path / "home"
    home.mkdir()
    data = tmp_path / "data"
    data.mkdir()
    # $HOME itself (what user-dirs.dirs says when there is no pictures folder) does not count.
    (home / ".config").mkdir()
    (home / ".config" / "user-dirs.dirs").write_text('XDG_PICTURES_DIR="$HOME/"\n')
    assert pictures_dir(home, {}) is None
    assert default_screenshot_dir(data / "hm.png", home=home, environ={}) == (
        data / "screenshots")
    monkeypatch.chdir(tmp_path)
    assert default_screenshot_dir(None, home=home, environ={}) == Path(tmp_path) / "screenshots"
    assert not (data / "screenshots").exists()  # created on the first F12 only
