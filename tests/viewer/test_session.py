"""The viewer without a window: parameters, camera flight, LOD, fallback, HUD, screenshots."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from terrascape.camera import Camera
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.render.techniques import COMMON_PARAMS, get_technique
from terrascape.viewer.controls import ViewerState
from terrascape.viewer.session import (
    KeyRepeat,
    LodManager,
    Smoothed,
    ground_height,
    ordered_techniques,
    sky_colors,
    start_camera,
    technique_params,
)

SIZE = (96, 64)


def _terrain(n: int = 33) -> Heightmap:
    from terrascape.generate import diamond_square

    return diamond_square(n, roughness=0.55, seed=3, spacing=2.0).normalised(0.0, 12.0)


# --- pure helpers ------------------------------------------------------------------------
def test_ordered_techniques_puts_known_first_and_appends_others():
    got = ordered_techniques(["relief", "zeta", "plain", "alpha", "bump", "plain"])
    assert got == ("plain", "bump", "relief", "alpha", "zeta")


def test_technique_params_maps_state_to_each_technique():
    st = ViewerState(parallax_scale=0.03, linear_steps=20, binary_steps=5, self_shadow=True)
    relief = get_technique("relief")
    p = technique_params(st, relief.parameters(), has_lightmap=False, fog_density=0.01)
    assert p["depth"] == pytest.approx(0.03)
    assert p["parallax_scale"] == pytest.approx(0.03) and p["parallax_bias"] == pytest.approx(-0.03)
    assert (p["linear_steps"], p["binary_steps"], p["self_shadow"]) == (20, 5, True)
    # the daylight model lights every technique by day (it replaced the lightmap/vertex
    # choice); the shadow key switches its cast shadows, the fog key its haze
    assert p["lighting"] == "daylight" and p["fog_density"] == 0.01 and p["haze"] is None
    plain = get_technique("plain")
    q = technique_params(st, plain.parameters(), has_lightmap=True, time_s=2.5, sea_level=1.0)
    assert "depth" not in q and "linear_steps" not in q
    assert q["lighting"] == "daylight" and q["shadows"] is True
    assert q["time"] == 2.5 and q["sea_level"] == 1.0
    assert q["sun"] == (st.sun_azimuth, st.sun_elevation)
    st.lightmap = False
    off = technique_params(st, plain.parameters(), has_lightmap=True)
    assert off["lighting"] == "daylight" and off["shadows"] is False
    st.lightmap, st.sun_elevation, st.fog = True, -10.0, False
    night = technique_params(st, plain.parameters(), has_lightmap=True)
    assert night["lighting"] == "vertex"  # no lightmap for a sun below the horizon
    assert night["fog_density"] == 0.0
    # every name is a parameter the technique accepts
    assert set(night) <= set(plain.parameters())


def test_sky_colors_day_is_renderer_default_night_is_dark_dusk_is_warm():
    day = sky_colors(1.0)
    assert day["horizon_color"] == pytest.approx(COMMON_PARAMS["horizon_color"])
    assert day["zenith_color"] == pytest.approx(COMMON_PARAMS["zenith_color"])
    night = sky_colors(0.0)
    assert sum(night["horizon_color"]) < 0.3 * sum(day["horizon_color"])
    assert night["diffuse_color"] == (0.0, 0.0, 0.0)
    dusk = sky_colors(0.5)["horizon_color"]
    assert dusk[0] > dusk[2]  # reddish horizon at sunset


def test_ground_height_is_bilinear_and_clamped():
    z, x = np.mgrid[0:5, 0:7].astype(np.float32)
    h = 0.5 * x * 2.0 + 0.25 * z * 3.0 + 1.0  # plane in world units (dx=2, dz=3)
    spacing = (2.0, 3.0)
    for wx, wz in [(0.0, 0.0), (3.3, 4.1), (11.9, 11.9), (5.0, 7.5)]:
        assert ground_height(h, spacing, wx, wz) == pytest.approx(0.5 * wx + 0.25 * wz + 1.0)
    # outside the map: the edge value
    assert ground_height(h, spacing, -10.0, -10.0) == pytest.approx(1.0)
    assert ground_height(h, spacing, 1e6, 1e6) == pytest.approx(float(h[-1, -1]))


def test_start_camera_sees_the_whole_terrain():
    hm = _terrain()
    cam = start_camera(hm, (640, 360))
    ex, ez = hm.extent
    corners = np.array([[0, hm.min, 0], [ex, hm.min, 0], [0, hm.max, ez], [ex, hm.max, ez]])
    px = cam.project(corners, (640, 360))
    assert (px[:, 0] >= 0).all() and (px[:, 0] <= 640).all()
    assert (px[:, 1] >= 0).all() and (px[:, 1] <= 360).all()
    assert (px[:, 2] > cam.near).all() and (px[:, 2] < cam.far).all()


def test_smoothed_average_and_key_repeat():
    s = Smoothed(0.5)
    assert s.add(10.0, 0.016) == 10.0
    s.add(20.0, 0.5)  # one time constant: 1 - 1/e of the way
    assert s.value == pytest.approx(20.0 - 10.0 / math.e)
    for _ in range(400):
        s.add(20.0, 0.016)
    assert s.value == pytest.approx(20.0, abs=0.01)
    r = KeyRepeat(delay=0.3, interval=0.1)
    r.press("EQUAL", 0.0)
    r.press("W", 0.0)  # not a repeating key
    assert r.due(0.2) == []
    assert r.due(0.31) == ["EQUAL"]
    assert r.due(0.35) == []
    assert r.due(0.42) == ["EQUAL"]
    r.release("EQUAL")
    assert r.due(5.0) == []


def test_lod_manager_recomputes_only_on_change():
    hm = _terrain(65)
    lod = LodManager(hm, time_budget_ms=None)
    cam = start_camera(hm, SIZE)
    tris, changed = lod.update("roam", cam, SIZE, {"max_triangles": 500})
    assert changed and 2 <= len(tris) <= 500 and tris.dtype == np.uint32
    assert int(tris.max()) < hm.rows * hm.cols
    assert lod.update("roam", cam, SIZE, {"max_triangles": 500}) == (None, False)
    moved = cam.moved((5.0, 0.0, 0.0))
    assert lod.update("roam", moved, SIZE, {"max_triangles": 500})[1]
    # ROAM's tolerance (the viewer's J + PgDn) reaches Roam.update: a coarse one stops early
    coarse, changed = lod.update("roam", moved, SIZE, {"max_triangles": 500, "tolerance_px": 40})
    assert changed and len(coarse) < 500 and lod.last_detail.endswith("(tolerance)")
    assert lod.update("roam", moved, SIZE, {"max_triangles": 500})[1]
    geo, changed = lod.update("geomipmap", moved, SIZE, {"tolerance_px": 4.0})
    assert changed and len(geo) > 0
    turner, _ = lod.update("turner", moved, SIZE, {"max_triangles": 2000})
    assert 0 < len(turner) <= 2 * 64 * 64
    assert lod.update("none", moved, SIZE) == (None, True)
    odd = LodManager(Heightmap(np.zeros((20, 30), np.float32)))
    with pytest.raises(InvalidParameterError, match="2\\^n\\+1"):
        odd.update("roam", cam, SIZE, {"max_triangles": 100})


# --- with GL -----------------------------------------------------------------------------
def _frame(fbo) -> np.ndarray:
    w, h = fbo.size
    return np.frombuffer(fbo.read(components=3), np.uint8).reshape(h, w, 3)[::-1].astype(int)


@pytest.fixture
def session(gl_ctx):
    from terrascape.viewer.session import ViewerSession

    warnings = []
    s = ViewerSession(gl_ctx, _terrain(), size=SIZE, hud=False, warn=warnings.append)
    s.test_warnings = warnings
    fbo = gl_ctx.simple_framebuffer(SIZE)
    yield s, fbo
    fbo.release()
    s.release()


@pytest.mark.gl
def test_first_frame_has_sky_and_terrain_and_keys_change_it(session):
    s, fbo = session
    stats = s.render(fbo, 0.02)
    img = _frame(fbo)
    # (+10: the daylight sky's hazy horizon is paler than the old gradient's horizon colour)
    sky = (img[..., 2] > img[..., 0] + 10) & (img[..., 2] > 120)
    assert sky[:4].mean() > 0.95  # the top of the frame is sky
    assert 0.1 < (~sky).mean() < 0.95  # the terrain fills part of it
    assert stats["triangles"] == 2 * 32 * 32
    s.state.handle_key("Z")  # wireframe
    s.render(fbo, 0.02)
    wired = _frame(fbo)
    diff = np.abs(wired - img).sum(-1) > 30
    assert diff.mean() > 0.02
    assert (wired.sum(-1)[diff] < img.sum(-1)[diff]).mean() > 0.8  # dark edges
    s.state.handle_key("Z")
    s.state.handle_key("N")
    for _ in range(8):  # sun down to -5°: night
        s.state.handle_key("N")
    assert s.state.sun_elevation < 0
    s.render(fbo, 0.02)
    night = _frame(fbo)
    assert night.mean() < 0.5 * img.mean()


@pytest.mark.gl
def test_technique_switch_and_lod_mode(session):
    s, fbo = session
    s.render(fbo, 0.02)
    plain = _frame(fbo)
    s.state.handle_key("TAB")
    assert s.state.technique == "regions"
    s.render(fbo, 0.02)
    assert (np.abs(_frame(fbo) - plain).sum(-1) > 30).mean() > 0.02
    s.state.handle_key("TAB", shift=True)
    s.state.lod, s.state.triangle_target = "roam", 300
    stats = s.render(fbo, 0.02)
    assert 2 <= stats["triangles"] <= 300
    s.state.lod = "none"
    assert s.render(fbo, 0.02)["triangles"] == 2 * 32 * 32


@pytest.mark.gl
def test_broken_technique_falls_back_to_plain_once(session, tmp_path, monkeypatch):
    from terrascape.render import techniques

    bad = tmp_path / "broken.glsl"
    bad.write_text("#if defined VERTEX_SHADER\nvoid main() { nonsense; }\n"
                   "#elif defined FRAGMENT_SHADER\nvoid main() {}\n#endif\n")
    monkeypatch.setitem(techniques._REGISTRY, "h9_broken",
                        techniques.Technique("h9_broken", str(bad)))
    s, fbo = session
    s.state.available = (*s.state.available, "h9_broken")
    s.state.technique = "h9_broken"
    s.render(fbo, 0.02)
    assert s.state.technique == "plain"
    assert "h9_broken" not in s.state.available
    assert len(s.test_warnings) == 1 and "h9_broken" in s.test_warnings[0]
    s.render(fbo, 0.02)
    assert len(s.test_warnings) == 1


@pytest.mark.gl
def test_flight_mouse_look_and_terrain_following(session):
    s, _ = session
    cam0 = s.camera
    s.advance(0.1, {"W"})
    step = s.camera.eye - cam0.eye
    assert np.linalg.norm(step) == pytest.approx(s.state.speed * 0.1, rel=1e-6)
    assert np.dot(step, cam0.forward) > 0.99 * np.linalg.norm(step)
    s.advance(0.1, {"W"}, fast=True)  # Shift: four times faster
    assert np.linalg.norm(s.camera.eye - cam0.eye) == pytest.approx(5 * s.state.speed * 0.1)
    s.look(100, 0)  # mouse not captured: ignored
    assert s.camera.yaw == pytest.approx(cam0.yaw)
    s.state.mouse_captured = True
    s.look(100, 0)
    assert s.camera.yaw == pytest.approx((cam0.yaw + 15.0) % 360)
    s.state.terrain_following = True
    s.advance(0.01, set())
    x, y, z = s.camera.eye
    assert y == pytest.approx(s.ground(x, z) + s.clearance)


@pytest.mark.gl
def test_hud_and_screenshot(gl_ctx, tmp_path):
    from PIL import Image

    from terrascape.viewer.session import ViewerSession

    s = ViewerSession(gl_ctx, _terrain(), size=(320, 240), warn=lambda m: None)
    fbo = gl_ctx.simple_framebuffer((320, 240))
    try:
        s.render(fbo, 0.02)
        s.render(fbo, 0.02)
        lines = s.status_lines()
        assert lines[0].strip().startswith("50.0 fps")
        assert "triangles 2,048" in lines[1] and "technique: plain" in lines
        with_hud = _frame(fbo)
        white = with_hud.min(-1) > 200
        assert white[8:100, 8:150].sum() > 100  # text in the status panel
        s.state.show_help = True
        panels = s.hud_panels((320, 240))
        assert any(p.anchor == "top-right" and any("wireframe" in t for t in p.lines)
                   for p in panels)
        path = s.screenshot(fbo, tmp_path)
        assert path.parent == tmp_path and path.suffix == ".png"
        saved = np.asarray(Image.open(path).convert("RGB")).astype(int)
        np.testing.assert_array_equal(saved, with_hud)
        assert s.screenshot(fbo, tmp_path) != path  # never overwrites
        with pytest.raises(InvalidParameterError, match="does not exist"):
            s.screenshot(fbo, tmp_path / "missing")
    finally:
        fbo.release()
        s.release()


@pytest.mark.gl
def test_another_current_context_leaves_the_frame_and_hud_alone(gl_ctx):
    """Another context created between two frames (the caller's own, a command run
    in-process) is the current one; the session still draws its frame, HUD included, with
    its own context, and leaves the other one current."""
    from terrascape.render.context import create_headless_context, current
    from terrascape.viewer.session import ViewerSession

    with current(gl_ctx):  # gives the test's own context back at the end
        s = ViewerSession(gl_ctx, _terrain(), size=(160, 120), warn=lambda m: None)
        fbo = gl_ctx.simple_framebuffer((160, 120))
        try:
            s.render(fbo, 0.02)  # the HUD's font texture and program are made here
            before = _frame(fbo)
            other = create_headless_context()
            try:
                s.render(fbo, 0.02)
                probe = other.texture((2, 2), 4, bytes(range(16)))  # still the current one
                assert probe.read() == bytes(range(16))
                probe.release()
                with current(gl_ctx):
                    after = _frame(fbo)
            finally:
                other.release()
        finally:
            fbo.release()
            s.release()
    assert (before.min(-1) > 200)[8:60, 8:150].sum() > 50  # the HUD's text
    np.testing.assert_array_equal(after, before)


@pytest.mark.gl
def test_session_validates_inputs(gl_ctx):
    from terrascape.viewer.session import ViewerSession

    hm = _terrain()
    with pytest.raises(InvalidParameterError, match="unknown technique"):
        ViewerSession(gl_ctx, hm, technique="nope", hud=False)
    with pytest.raises(InvalidParameterError, match="--lod"):
        ViewerSession(gl_ctx, hm, lod="quadtree", hud=False)
    with pytest.raises(InvalidParameterError, match="Heightmap"):
        ViewerSession(gl_ctx, np.zeros((9, 9)), hud=False)
    notes = []
    odd = Heightmap(np.zeros((20, 30), np.float32) + np.arange(30, dtype=np.float32))
    s = ViewerSession(gl_ctx, odd, lod="roam", hud=False, warn=notes.append)
    try:
        assert s.state.lod == "none" and "--pad" in notes[0]
    finally:
        s.release()
    assert isinstance(start_camera(hm, (4, 3)), Camera)
    assert math.isfinite(start_camera(hm, (4, 3)).near)


@pytest.mark.gl
def test_sky_clock_runs_the_day_into_a_blue_night(gl_ctx):
    import datetime as dt

    from terrascape.viewer.session import ViewerSession

    s = ViewerSession(gl_ctx, _terrain(), size=SIZE, hud=True, warn=lambda m: None,
                      sky_clock=(dt.datetime(2026, 6, 21, 18, 0, tzinfo=dt.UTC), 45.8, 16.0))
    fbo = gl_ctx.simple_framebuffer(SIZE)
    try:
        assert s.state.time_running
        day_params = s.frame_params()
        assert day_params["sky_state"].sun_elevation > 0
        lines = s.status_lines()
        assert any("2026-06-21" in line and "solar" in line for line in lines)
        s.render(fbo, 0.02)
        day = _frame(fbo)
        s.state.time_rate = 14400.0
        for _ in range(6):  # 6 × 0.25 s × 4 h/s = 6 h later: solar 01:00
            s.state.advance_time(0.25)
        night_params = s.frame_params()
        assert night_params["sky_state"].sun_elevation < -15
        assert night_params["lighting"] == "daylight"  # the night model, not the vertex look
        s.render(fbo, 0.02)
        night = _frame(fbo)
        assert night.mean() < 0.5 * day.mean()
        top = night[:6].reshape(-1, 3).mean(0)
        assert top[2] > top[0] and top[2] > top[1] and top.sum() > 0
    finally:
        fbo.release()
        s.release()


def test_lod_manager_budgeted_roam_settles_over_frames():
    hm = _terrain(129)
    lod = LodManager(hm, time_budget_ms=1e-3)  # the first 64 operations of each update
    reference = LodManager(hm, time_budget_ms=None)
    cam = start_camera(hm, SIZE)
    settings = {"max_triangles": 3000}
    want, _ = reference.update("roam", cam, SIZE, settings)
    frames = 0
    while True:
        tris, changed = lod.update("roam", cam, SIZE, settings)
        frames += 1
        if lod.settled or frames > 500:
            break
        assert changed  # not settled: the same view is updated again next frame
    assert lod.settled and frames > 3
    assert lod.update("roam", cam, SIZE, settings) == (None, False)  # nothing left to do
    assert {tuple(t) for t in tris.tolist()} == {tuple(t) for t in want.tolist()}


@pytest.mark.gl
def test_moving_frames_are_drawn_smaller_and_still_ones_at_full_size(gl_ctx):
    from terrascape.viewer.session import ViewerSession

    size = (240, 160)
    s = ViewerSession(gl_ctx, _terrain(), size=size, hud=False, warn=lambda m: None,
                      target_fps=15.0)
    fbo = gl_ctx.simple_framebuffer(size)
    try:
        s.render(fbo, 0.0)
        s.render(fbo, 0.0)  # the camera has not moved: full size
        assert s.drawn_scale == 1.0
        full = _frame(fbo)
        start = s.camera
        s.resolution.scale = 0.6
        s.camera = replace(start, yaw=start.yaw + 5.0)
        s.render(fbo, 0.05)
        s.camera = start  # moved back: a moving frame of the first view
        s.render(fbo, 0.05)
        assert s.drawn_scale == 0.6
        assert s._scaled.size == (144, 96)
        scaled = _frame(fbo)
        # the same picture, softer: in place (not shifted or flipped) and close in colour
        diff = np.abs(scaled - full).sum(-1)
        assert diff.mean() < 12
        assert np.corrcoef(scaled.sum(-1).ravel(), full.sum(-1).ravel())[0, 1] > 0.9
        s.render(fbo, 0.05)  # held: full size again
        assert s.drawn_scale == 1.0
        np.testing.assert_array_equal(_frame(fbo), full)
        s.camera = replace(start, yaw=start.yaw + 5.0)
        s.render(fbo, 0.05, full_size=True)  # a screenshot's frame
        assert s.drawn_scale == 1.0
        s.state.handle_key("TAB")  # another look: measured afresh from full size
        s.camera = start
        s.render(fbo, 0.05)
        assert s.resolution.scale == 1.0 and s.drawn_scale == 1.0
        assert "drawn at" not in s.status_lines()[0]
    finally:
        fbo.release()
        s.release()


@pytest.mark.gl
def test_a_slow_look_is_drawn_smaller_until_it_holds_the_rate(gl_ctx):
    """Frames that take 200 ms at full size (a clock the test advances) shrink the scale
    to where the modelled time holds 15 frames/s; the scripted default stays full size."""
    from terrascape.viewer.session import ViewerSession

    clock = [0.0]
    s = ViewerSession(gl_ctx, _terrain(), size=SIZE, hud=False, warn=lambda m: None,
                      target_fps=15.0)
    s.clock = lambda: clock[0]
    fbo = gl_ctx.simple_framebuffer(SIZE)
    try:
        start = s.camera
        for k in range(30):
            s.camera = replace(start, yaw=start.yaw + k)
            s.render(fbo, 0.1)
            clock[0] += 0.200 * s.drawn_scale ** 2  # all of the time per pixel
        assert 0.5 <= s.drawn_scale <= 0.6  # sqrt(66.7 / 200) = 0.58
        assert s.drawn_scale ** 2 * 200.0 <= 1000.0 / 15.0
    finally:
        fbo.release()
        s.release()
    scripted = ViewerSession(gl_ctx, _terrain(), size=SIZE, hud=False, warn=lambda m: None)
    assert not scripted.resolution.active
    scripted.release()


@pytest.mark.gl
def test_a_moving_frame_keeps_stencil_shadow_volumes(gl_ctx):
    """On an output with a stencil buffer, the smaller moving frame has one too: object
    shadow volumes stay volumes (no fallback to shadow maps) and darken the same places."""
    import warnings

    from terrascape.cli.cmd_render import load_objects_option
    from terrascape.cli.cmd_view import generate_terrain
    from terrascape.render.shadow_volumes import ShadowVolumeFallbackWarning
    from terrascape.render.stencil import StencilFramebuffer
    from terrascape.viewer.session import ViewerSession

    size = (200, 120)
    hm = generate_terrain("fbm", 65, 4)
    inst = load_objects_option("default", hm, seed=4, exaggeration=1.0)
    target = StencilFramebuffer(gl_ctx, size)
    s = ViewerSession(gl_ctx, hm, size=size, technique="plain", hud=False, objects=inst,
                      warn=lambda m: None, target_fps=15.0)
    try:
        frames = {}
        with warnings.catch_warnings():
            warnings.simplefilter("error", ShadowVolumeFallbackWarning)
            start = s.camera
            for mode in ("volumes", "none"):
                s.state.object_shadows = mode
                s.resolution.scale = 0.6
                s.camera = replace(start, yaw=start.yaw + 2.0)
                s.render(target.fbo, 0.05)
                s.camera = start
                s.render(target.fbo, 0.05)
                assert s.drawn_scale == 0.6
                frames[mode] = _frame(target.fbo)
        darker = frames["volumes"].sum(-1) < 0.85 * frames["none"].sum(-1)
        assert darker.mean() > 0.005  # the volumes' shadows are in the moving frame
    finally:
        s.release()
        target.release()
