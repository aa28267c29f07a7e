"""End-to-end: `terrascape view` in a real window under Xvfb, driven with xdotool, seen
through screenshots of the X root window (ImageMagick `import`)."""

from __future__ import annotations

import io
import subprocess
import sys
import time

import numpy as np
import pytest

W, H = 320, 240
# Rows below the HUD's status panel (7 lines of the 10 px font + padding at 240 px high):
# the scene there is free of text that changes every frame (the frame rate).
SCENE_ROWS = slice(150, H)

pytestmark = pytest.mark.xvfb

CLI = "import sys; from terrascape.cli import main; main(sys.argv[1:])"


def _grab(env) -> np.ndarray:
    from PIL import Image

    png = subprocess.run(["import", "-window", "root", "png:-"], env=env, check=True,
                         capture_output=True, timeout=10).stdout
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)[:H, :W]


def _wait_for(env, predicate, timeout: float, what: str) -> np.ndarray:
    deadline = time.monotonic() + timeout
    while True:
        img = _grab(env)
        if predicate(img):
            return img
        if time.monotonic() > deadline:
            pytest.fail(f"timed out waiting for {what}")
        time.sleep(0.2)


def _key(env, wid: str, key: str) -> None:
    subprocess.run(["xdotool", "windowfocus", "--sync", wid], env=env, check=True, timeout=10)
    subprocess.run(["xdotool", "key", key], env=env, check=True, timeout=10)


def _scene_change(a: np.ndarray, b: np.ndarray) -> float:
    """Fraction of scene pixels whose colour changed by more than 24 levels."""
    d = np.abs(a[SCENE_ROWS] - b[SCENE_ROWS]).max(axis=-1)
    return float((d > 24).mean())


def _is_sky(px: np.ndarray) -> np.ndarray:
    r, g, b = px[..., 0], px[..., 1], px[..., 2]
    # +10: the daylight sky's hazy horizon is paler than the old gradient's horizon colour
    return (b > r + 10) & (b >= g) & (b > 120)


def test_view_window_keys_and_quit(xvfb, tmp_path):
    # A home without a pictures folder: F12 then writes to ./screenshots (a generated map
    # has no file to put them next to).
    env = {k: v for k, v in xvfb.items() if k != "XDG_PICTURES_DIR"}
    env.update(HOME=str(tmp_path), XDG_CONFIG_HOME=str(tmp_path / "config"))
    proc = subprocess.Popen(
        [sys.executable, "-c", CLI, "view", "--generate", "diamond-square", "--gen-size", "65",
         "--size", f"{W}x{H}"],
        env=env, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
    )
    try:
        wid = subprocess.run(
            ["xdotool", "search", "--sync", "--name", "terrascape view"], env=env,
            capture_output=True, text=True, timeout=20, check=True,
        ).stdout.split()[0]
        # First frame: not blank — sky at the top, and a terrain of other colours below it.
        first = _wait_for(env, lambda im: im.std() > 10, 15, "a first frame")
        # (the HUD panel starts 8 px below the top edge)
        assert _is_sky(first[:6]).mean() > 0.95, "the top of the frame should be sky"
        scene = first[SCENE_ROWS]
        terrain = ~_is_sky(scene)
        assert 0.1 < terrain.mean() < 0.9, "terrain and sky should share the lower frame"
        greenish_or_brown = (scene[..., 0] + scene[..., 1] > 1.6 * scene[..., 2]) & terrain
        assert greenish_or_brown.mean() > 0.02, "terrain colours (not sky blue) expected"
        # HUD: white glyph pixels over the dark panel at the top left.
        hud = first[5:60, 5:120]
        assert (hud.min(axis=-1) > 200).sum() > 50, "HUD text should be drawn"

        # The scene itself is static (no keys held): two grabs agree.
        again = _grab(env)
        assert _scene_change(first, again) < 0.01

        _key(env, wid, "Tab")  # plain → regions: tiled materials instead of the region colour
        tabbed = _wait_for(env, lambda im: _scene_change(first, im) > 0.02, 20,
                           "the technique switch to change the image")
        _key(env, wid, "z")  # wireframe overlay: dark edges over the terrain
        wired = _wait_for(env, lambda im: _scene_change(tabbed, im) > 0.02, 10,
                          "wireframe to change the image")
        t_lum = tabbed[SCENE_ROWS].sum(-1)
        w_lum = wired[SCENE_ROWS].sum(-1)
        changed = np.abs(t_lum - w_lum) > 72
        assert (w_lum[changed] < t_lum[changed]).mean() > 0.8, "wire lines should be dark"

        _key(env, wid, "F12")  # screenshot into ./screenshots (created now)
        deadline = time.monotonic() + 10
        while not (shots := list((tmp_path / "screenshots").glob("terrascape-*.png"))):
            assert time.monotonic() < deadline, "F12 wrote no screenshot"
            time.sleep(0.1)
        from PIL import Image

        time.sleep(0.3)  # atomic rename: the file is complete once it exists
        with Image.open(shots[0]) as shot:
            saved = np.asarray(shot.convert("RGB"), dtype=np.int16)
        assert saved.shape == (H, W, 3)
        assert _scene_change(saved, wired) < 0.01  # it is the frame on screen before F12

        t0 = time.monotonic()
        _key(env, wid, "Escape")
        # (communicate: a stream a child process of the viewer still held would not end a
        # bare read; this fails at the timeout instead)
        _, err = proc.communicate(timeout=10)
        rc, err = proc.returncode, err.decode()
        assert time.monotonic() - t0 < 8
        assert rc == 0, err
        assert f"F12 saves screenshots to {tmp_path / 'screenshots'}" in err
        assert f"screenshot: {shots[0]}" in err
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)


def _headless_shadow_frames(size):
    """What the viewer draws for the command line of the test below, headless: the frames
    with object shadow volumes and without object shadows (uint8, row 0 at the top)."""
    from terrascape.cli.cmd_render import load_objects_option
    from terrascape.cli.cmd_view import generate_terrain
    from terrascape.render.context import headless_context
    from terrascape.render.stencil import StencilFramebuffer
    from terrascape.viewer.session import ViewerSession

    hm = generate_terrain("fbm", 65, 4)
    inst = load_objects_option("default", hm, seed=4, exaggeration=1.0)
    frames = {}
    with headless_context() as ctx:
        target = StencilFramebuffer(ctx, size)
        session = ViewerSession(ctx, hm, size=size, technique="material", hud=False,
                                objects=inst, warn=lambda m: None)
        try:
            for mode in ("volumes", "none"):
                session.state.object_shadows = mode
                session.render(target.fbo, 0.0)
                raw = target.fbo.read(components=3, alignment=1)
                frames[mode] = np.frombuffer(raw, np.uint8).reshape(size[1], size[0], 3)[::-1]
        finally:
            session.release()
            target.release()
    return frames


def _shadowed(volumes: np.ndarray, none: np.ndarray) -> np.ndarray:
    """bool: pixels the object shadows darken (below 0.85× the frame without them)."""
    lum = lambda im: im.astype(np.float64).sum(axis=-1)  # noqa: E731
    return lum(volumes) < 0.85 * lum(none)


@pytest.mark.gl
def test_view_window_shadow_volumes_match_the_headless_render(xvfb, tmp_path):
    """Stencil shadow volumes in a real window (the window's own stencil buffer): the pixels
    they darken are the ones the headless renderer darkens, and G switches them off."""
    env = dict(xvfb, HOME=str(tmp_path), XDG_CONFIG_HOME=str(tmp_path / "config"))
    proc = subprocess.Popen(
        [sys.executable, "-c", CLI, "view", "--generate", "fbm", "--gen-size", "65", "--seed",
         "4", "--size", f"{W}x{H}", "--objects", "default", "--object-shadows", "volumes",
         "--no-hud", "--screenshot-dir", str(tmp_path)],
        env=env, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
    )
    try:
        wid = subprocess.run(
            ["xdotool", "search", "--sync", "--name", "terrascape view"], env=env,
            capture_output=True, text=True, timeout=60, check=True,
        ).stdout.split()[0]
        shaded = _wait_for(env, lambda im: im.std() > 10, 60, "a first frame")
        time.sleep(1.0)
        shaded = _grab(env)
        _key(env, wid, "g")  # volumes → none
        plain = _wait_for(env, lambda im: _scene_change(shaded, im) > 0.002, 30,
                          "G to switch the shadow volumes off")
        time.sleep(1.0)
        plain = _grab(env)
        _key(env, wid, "Escape")
        _, err = proc.communicate(timeout=30)
        rc, err = proc.returncode, err.decode()
        assert rc == 0, err
        assert "stencil" not in err, err  # no fallback to shadow maps: the window has one
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)
    ref = _headless_shadow_frames((W, H))
    window = _shadowed(shaded, plain)
    headless = _shadowed(ref["volumes"].astype(np.int16), ref["none"].astype(np.int16))
    assert headless.mean() > 0.01  # the objects cast real shadows in this view
    # the same frames: the window's pixels are the headless ones (a rounding step at most)
    assert np.abs(plain - ref["none"]).max(axis=-1).mean() < 1.0
    assert (window == headless).mean() > 0.995
    assert (window & headless).sum() > 0.98 * headless.sum()
