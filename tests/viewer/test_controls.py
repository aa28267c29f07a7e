import itertools

import numpy as np
import pytest

from terrascape.camera import Camera
from terrascape.viewer.controls import TECHNIQUES, Action, ViewerState, fly, look


def test_seed_defaults_and_parallax_steps():
    s = ViewerState()
    assert (s.parallax_scale, s.linear_steps) == (0.01, 11)
    s.handle_key("EQUAL")
    assert s.parallax_scale == pytest.approx(0.011)
    for _ in range(20):
        s.handle_key("MINUS")
    assert s.parallax_scale == 0.0  # never negative, as in the seed
    s.handle_key("RIGHT_BRACKET")
    assert s.linear_steps == 12
    for _ in range(50):
        s.handle_key("LEFT_BRACKET")
    assert s.linear_steps == 1
    s.handle_key("PERIOD")
    assert s.binary_steps == 9
    assert s.uniforms()["linear_steps"] == 1
    assert s.uniforms()["binary_steps"] == 9


def test_technique_cycles_both_ways():
    s = ViewerState(technique=TECHNIQUES[0])
    seen = [s.technique]
    for _ in range(len(TECHNIQUES)):
        s.handle_key("TAB")
        seen.append(s.technique)
    assert seen[0] == seen[-1] and set(seen) == set(TECHNIQUES)
    s.handle_key("TAB", shift=True)
    assert s.technique == TECHNIQUES[-1]


def test_only_available_techniques_are_cycled():
    s = ViewerState(technique="relief", available=("plain", "bump"))
    assert s.technique == "plain"
    s.handle_key("TAB")
    assert s.technique == "bump"


def test_escape_releases_then_quits():
    s = ViewerState(mouse_captured=True)
    assert s.handle_key("ESCAPE") is Action.RELEASE_MOUSE
    assert s.handle_key("ESCAPE") is Action.QUIT
    assert s.handle_key("F12") is Action.SCREENSHOT


def test_toggles_lod_and_detail():
    s = ViewerState()
    for key, attr in (("X", "self_shadow"), ("Z", "wireframe"), ("F", "fog"), ("K", "lightmap")):
        before = getattr(s, attr)
        s.handle_key(key)
        assert getattr(s, attr) is (not before)
    assert s.lod == "none"
    s.handle_key("L")
    assert s.lod == "roam"
    s.handle_key("PAGE_UP")
    assert s.triangle_target == 100_000
    # J moves PgUp/PgDn to ROAM's tolerance: off (refine to the budget) until PgDn
    assert s.lod_update_settings() == {"max_triangles": 100_000}
    s.handle_key("J")
    s.handle_key("PAGE_UP")
    assert s.lod_update_settings() == {"max_triangles": 100_000}
    s.handle_key("PAGE_DOWN")
    s.handle_key("PAGE_DOWN")
    assert s.lod_update_settings() == {"max_triangles": 100_000, "tolerance_px": 0.3125}
    assert "tolerance 0.31 px" in s.status_lines()[-2]
    s.handle_key("PAGE_UP")
    s.handle_key("PAGE_UP")
    assert s.lod_update_settings() == {"max_triangles": 100_000}
    s.handle_key("L")
    assert s.lod == "turner" and s.lod_update_settings() == {"max_triangles": 80_000}
    s.handle_key("L")
    assert s.lod == "geomipmap"
    s.handle_key("PAGE_DOWN")
    assert s.lod_update_settings() == {"tolerance_px": pytest.approx(2.5)}
    assert "tolerance 2.50 px" in s.status_lines()[-2]
    s.handle_key("L")
    assert s.lod == "none"
    s.handle_key("h")
    assert s.show_help


def test_sun_keys_reach_night():
    s = ViewerState(sun_elevation=10)
    assert s.daylight == 1.0
    for _ in range(4):
        s.handle_key("N")
    assert s.sun_elevation == -10
    assert s.daylight == 0.0
    s.handle_key("P")
    assert s.sun_azimuth == 145


def test_fly_moves_along_view_and_follows_ground():
    cam = Camera.look_at((0, 10, 0), (0, 10, -1))  # looking north (-Z)
    moved = fly(cam, {"W"}, dt=0.5, speed=4.0)
    assert np.allclose(moved.eye, [0, 10, -2])
    strafed = fly(cam, {"D"}, dt=1.0, speed=1.0, fast=True)
    assert np.allclose(strafed.eye, [4, 10, 0])
    sunk = fly(cam, {"Q"}, dt=1.0, speed=100.0, ground=lambda x, z: 5.0, clearance=1.0)
    assert sunk.eye[1] == pytest.approx(6.0)


def test_look_clamps_pitch():
    cam = look(Camera(), 0, -10_000)
    assert cam.pitch == pytest.approx(89.9)
    assert look(cam, float("nan"), 0) is cam


def test_default_cycle_uses_the_registry_names():
    from terrascape.render.techniques import technique_names
    from terrascape.viewer.controls import TECHNIQUES
    from terrascape.viewer.session import ordered_techniques

    assert set(TECHNIQUES) <= set(technique_names())
    assert ordered_techniques(technique_names())[:len(TECHNIQUES)] == TECHNIQUES


# --- the sky clock -----------------------------------------------------------------------
def test_time_keys_start_run_reverse_speed_and_step_the_clock():
    import datetime as dt

    from terrascape.viewer.controls import DEFAULT_TIME_RATE, TIME_RATES

    s = ViewerState(sun_azimuth=135.0, sun_elevation=35.0, latitude=45.8)
    assert s.clock is None and s.time_line() is None
    s.handle_key("SPACE")  # starts a clock near the hand-placed sun, running
    assert s.clock is not None and s.time_running
    assert abs(s.sun_elevation - 35.0) < 4.0 and 90.0 < s.sun_azimuth < 180.0  # morning
    t0 = s.clock
    s.advance_time(0.1)
    assert (s.clock - t0).total_seconds() == pytest.approx(0.1 * DEFAULT_TIME_RATE)
    s.handle_key("R")  # backward
    t1 = s.clock
    s.advance_time(0.1)
    assert (s.clock - t1).total_seconds() == pytest.approx(-0.1 * DEFAULT_TIME_RATE)
    s.handle_key("V")
    assert s.time_rate == TIME_RATES[TIME_RATES.index(DEFAULT_TIME_RATE) + 1]
    for _ in range(20):
        s.handle_key("C")
    assert s.time_rate == TIME_RATES[0]
    s.handle_key("SPACE")  # pause
    t2 = s.clock
    s.advance_time(1.0)
    assert s.clock == t2 and "paused" in s.time_line()
    s.handle_key("U")
    assert s.clock - t2 == dt.timedelta(minutes=15)
    el_before = s.sun_elevation
    s.advance_time(0.0)
    assert s.sun_elevation == el_before
    # the HUD shows the date and the solar time
    assert "2026-06-21" in s.time_line() and "solar" in s.time_line()
    assert s.time_line() in s.status_lines()
    # the sun keys take the sun back by hand
    s.handle_key("P")
    assert s.clock is None


def test_the_clock_moves_the_sun_through_a_day():
    import datetime as dt

    s = ViewerState()
    s.set_clock(dt.datetime(2026, 6, 21, 3, 0, tzinfo=dt.UTC), 45.8, 16.0, running=True)
    els = []
    for _ in range(40):
        s.advance_time(0.25)  # 7.5 minutes a step at the default rate
        els.append(s.sun_elevation)
    assert els[0] < 5.0 < max(els)  # sunrise ~03:10 UTC there, then the sun climbs
    assert all(b > a for a, b in itertools.pairwise(els))
    assert s.sky_state().sun == (s.sun_azimuth, s.sun_elevation)


def test_time_keys_are_in_the_help():
    from terrascape.viewer.controls import HELP

    text = " ".join(f"{k} {d}" for k, d in HELP)
    for word in ("Space", "R", "C / V", "Y / U"):
        assert word in text
