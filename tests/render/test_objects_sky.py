"""Objects under the sky of the day: the haze of their distance and the light of the hour
(sun, sunset, moon), the same as the terrain around them."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape.camera import Camera
from terrascape.heightmap import Heightmap
from terrascape.lighting.solar_position import sky_at
from terrascape.objects.model import Instances
from terrascape.render.offscreen import OffscreenRenderer

pytestmark = pytest.mark.gl

LUMA = np.array([0.2126, 0.7152, 0.0722])
PLACE = (45.8, 16.0)


def luma(img):
    return img[..., :3].astype(np.float64) @ LUMA


def sky_params(time: str) -> dict:
    state = sky_at(f"2026-06-21T{time}", *PLACE)
    return {"sun": state.sun, "sky_state": state}


def render_pair(ctx, hm, cam, inst, params, size):
    """(without objects, with them) of one frame, and the frame's drawing statistics."""
    r = OffscreenRenderer(ctx, hm, size=size)
    try:
        empty = r.render(cam, "plain", params)[..., :3].astype(np.float64)
        r.terrain.set_objects(inst)
        full = r.render(cam, "plain", params)[..., :3].astype(np.float64)
        stats = dict(r.terrain.last_stats)
    finally:
        r.release()
    return empty, full, stats


@pytest.mark.parametrize(("shadows", "impostor_pixels"),
                         [("cascades", 0), ("cascades", 1e6), ("volumes", 0)],
                         ids=["meshes", "impostors", "volumes"])
@pytest.mark.parametrize("time", ["12:00", "19:45"])
def test_far_objects_take_the_haze_colour_of_the_terrain_behind_them(gl_ctx, time, shadows,
                                                                     impostor_pixels, box_mesh):
    """A row of dark red boxes 3 km away in thick haze: their pixels are the colour of the
    terrain at the same distance beside them (both the sky's horizon colour, within a few
    levels) — not the box's own red, not black. Without haze the same boxes stand out."""
    hm = Heightmap(np.zeros((65, 65), np.float32), spacing=(60.0, 60.0))  # 3.84 km
    size = (160, 90)
    mesh = box_mesh((60.0, 80.0, 60.0), (0.45, 0.03, 0.03))
    xs = np.linspace(900.0, 2940.0, 7)
    pos = np.c_[xs, np.zeros(7), np.full(7, 500.0)]
    inst = Instances((mesh,), np.zeros(7, int), pos, np.ones(7), np.zeros(7))
    # north (-z), a little down: the boxes stand on terrain that goes on behind them
    cam = Camera.look_at((1920.0, 40.0, 3700.0), (1920.0, 0.0, 0.0), fov_y=30.0, near=2.0,
                         far=10000.0, aspect=size[0] / size[1])
    sky = sky_params(time)
    # transmittance to the boxes about exp(-4)
    thick = {**sky, "haze": 1.6e-3, "impostor_pixels": impostor_pixels,
             "object_shadows": shadows}
    empty, hazed, stats = render_pair(gl_ctx, hm, cam, inst, thick, size)
    assert stats["objects_impostors" if impostor_pixels else "objects_meshes"] == 7
    clear_empty, clear, _ = render_pair(gl_ctx, hm, cam, inst, {**thick, "haze": 0.0}, size)

    box = np.abs(clear - clear_empty).max(axis=-1) > 30  # the boxes, seen without haze
    assert box.sum() > 40
    rows = np.flatnonzero(box.any(axis=1))
    # the terrain in the boxes' rows, away from them: the same distance, the same haze
    beside = np.zeros_like(box)
    beside[rows] = True
    beside &= ~box
    for shift in (-3, -2, -1, 1, 2, 3):
        beside &= ~np.roll(box, shift, axis=1)
    ground = empty[beside]
    assert len(ground) > 40
    terrain_colour = ground.mean(axis=0)
    object_colour = hazed[box].mean(axis=0)
    # without haze the boxes are far from the terrain's colour: the test can tell
    assert np.abs(clear[box].mean(axis=0) - clear_empty[beside].mean(axis=0)).max() > 30
    assert luma(terrain_colour) > 60, terrain_colour  # a daylight horizon, not night
    np.testing.assert_allclose(object_colour, terrain_colour, atol=10,
                               err_msg=f"objects {object_colour} vs terrain {terrain_colour}")


@pytest.mark.parametrize("shadows", ["cascades", "volumes"])
def test_objects_at_night_are_moonlit_like_the_terrain(gl_ctx, shadows, box_mesh):
    """Seen from above, the top of a flat dark box and the ground around it keep their ratio
    of brightness from noon to night (23:30, moon and night sky): lit by the same light, not
    black and not glowing."""
    hm = Heightmap(np.zeros((65, 65), np.float32), spacing=(1.0, 1.0))
    size = (96, 96)
    mesh = box_mesh((16.0, 2.0, 16.0), (0.1, 0.1, 0.1))
    inst = Instances((mesh,), np.zeros(1, int), np.array([[32.0, 0.0, 32.0]]), np.ones(1),
                     np.zeros(1))
    cam = Camera.look_at((32.0, 60.0, 32.001), (32.0, 0.0, 32.0), fov_y=40.0, near=1.0,
                         far=200.0, aspect=1.0)
    top = (slice(40, 56), slice(40, 56))  # inside the box's top, seen from above
    ratio = {}
    for time in ("12:00", "23:30"):
        params = {**sky_params(time), "object_shadows": shadows}
        empty, full, _ = render_pair(gl_ctx, hm, cam, inst, params, size)
        ratio[time] = luma(full[top]).mean() / luma(empty[top]).mean()
        if time == "23:30":
            night_object = full[top].reshape(-1, 3).mean(axis=0)
            night_ground = empty[top].reshape(-1, 3).mean(axis=0)
    assert ratio["23:30"] == pytest.approx(ratio["12:00"], rel=0.3), ratio
    # and night-dark, like the ground: not the day's brightness
    assert luma(night_object) < 1.6 * luma(night_ground), (night_object, night_ground)


@pytest.mark.parametrize("shadows", ["cascades", "volumes"])
def test_render_cli_objects_at_night_neither_glow_nor_vanish(tmp_path, shadows):
    """``render --time 2026-06-21T23:30 --latitude 45.8 --objects default``: the built-in
    trees and rocks are no brighter than the moonlit ground (they glowed white while their
    programs read no sky table) and not black either."""
    from PIL import Image

    from terrascape.cli.app import run_app

    args = ["render", "--generate", "hills", "--gen-size", "65", "--seed", "1", "--size",
            "160x96", "--orbit", "200,25,70", "--latitude", "45.8", "-q"]
    imgs = {}
    for time in ("12:00", "23:30"):
        for objects in ((), ("--objects", "default", "--object-shadows", shadows)):
            out = tmp_path / f"{time[:2]}{len(objects)}.png"
            assert run_app([*args, "--time", f"2026-06-21T{time}", *objects,
                            "-o", str(out)]) == 0
            imgs[time, bool(objects)] = luma(np.asarray(Image.open(out)).astype(np.float64))
    # the objects: where they change the noon frame (and, far less, their shadows)
    drawn = np.abs(imgs["12:00", True] - imgs["12:00", False]) > 12
    assert drawn.mean() > 0.02
    night, ground = imgs["23:30", True][drawn], imgs["23:30", False]
    assert np.percentile(night, 95) <= np.percentile(ground, 99) + 4, (
        np.percentile(night, 95), np.percentile(ground, 99))
    assert night.mean() > 0.25 * ground.mean(), (night.mean(), ground.mean())


@pytest.mark.parametrize(("technique", "shadows"),
                         [("plain", "cascades"), ("plain", "volumes"),
                          ("material", "volumes")])
def test_every_program_that_reads_the_sky_table_has_it_bound(gl_ctx, monkeypatch, technique,
                                                             shadows, box_mesh):
    """Each program a daylight frame with objects, water and sky draws with, that declares
    ``u_sky_lut`` (it includes common/atmosphere.glsl), samples the unit the table is on."""
    import importlib
    import sys

    from terrascape.render import shaders
    from terrascape.render.terrain import _SKY_LUT_UNIT

    # imported before the patch: a module first imported under it would keep the wrapper
    for name in ("objects", "shadow_volumes", "terrain", "offscreen"):
        importlib.import_module(f"terrascape.render.{name}")

    used = []
    original = shaders.load_program

    def recording(*args, **kwargs):
        program = original(*args, **kwargs)
        used.append((args[1], program))
        return program

    for name, module in list(sys.modules.items()):
        if name.startswith("terrascape.render.") and module is not shaders and \
                getattr(module, "load_program", None) is original:
            monkeypatch.setattr(module, "load_program", recording)
    hm = Heightmap(np.linspace(0, 8, 33 * 33, dtype=np.float32).reshape(33, 33), (2.0, 2.0))
    mesh = box_mesh((3.0, 6.0, 3.0), (0.3, 0.3, 0.3))
    pos = np.array([[20.0, 3.0, 20.0], [44.0, 6.0, 40.0]])
    inst = Instances((mesh,), np.zeros(2, int), pos, np.ones(2), np.zeros(2))
    cam = Camera.look_at((32.0, 30.0, 90.0), (32.0, 0.0, 30.0), fov_y=50.0, near=1.0,
                         far=500.0, aspect=1.5)
    r = OffscreenRenderer(gl_ctx, hm, size=(96, 64))
    try:
        r.terrain.set_objects(inst)
        r.render(cam, technique, {**sky_params("17:00"), "object_shadows": shadows,
                                  "sea_level": 2.0, "impostor_pixels": 20.0})
    finally:
        r.release()
    readers = {name: p for name, p in used if "u_sky_lut" in p}
    assert {"objects/mesh", "objects/impostor", "water", "sky"} <= set(readers), sorted(readers)
    for name, program in readers.items():
        assert program["u_sky_lut"].value == _SKY_LUT_UNIT, name
