"""Solar and lunar positions against published and geometric reference values."""

from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pytest

from terrascape.errors import InvalidParameterError
from terrascape.lighting.solar_position import (
    parse_time,
    sky_at,
    sky_state,
    solar_position,
)
from terrascape.lighting.sun import sun_direction

UTC = dt.UTC

# (UTC time, latitude, longitude) → (azimuth, elevation) from pysolar 0.13 (an independent
# implementation of the NREL SPA), computed 2026-12-02.
PYSOLAR = [
    (dt.datetime(2026, 6, 21, 16, 30, tzinfo=UTC), 45.8, 16.0, 282.2416, 21.3031),
    (dt.datetime(2026, 1, 15, 14, 0, tzinfo=UTC), 40.71, -74.0, 135.7203, 14.7737),
    (dt.datetime(2025, 9, 1, 2, 0, tzinfo=UTC), -33.87, 151.21, 358.2330, 47.8999),
    (dt.datetime(2026, 12, 21, 10, 0, tzinfo=UTC), 64.13, -21.9, 133.8394, -6.2097),
    (dt.datetime(2026, 1, 15, 8, 0, tzinfo=UTC), 40.71, -74.0, 75.4467, -48.2735),
]


@pytest.mark.parametrize("when, lat, lon, az, el", PYSOLAR)
def test_sun_matches_an_independent_implementation(when, lat, lon, az, el):
    s = sky_state(when, lat, lon)
    assert s.sun_azimuth == pytest.approx(az, abs=0.03)
    # below the horizon NOAA still refracts (a few hundredths of a degree), pysolar does not
    assert s.sun_elevation == pytest.approx(el, abs=0.03 if el > 0 else 0.08)


@pytest.mark.parametrize("lat", [-60.0, -33.9, 0.0, 23.0, 45.8, 60.0])
def test_solstice_and_equinox_noon_elevations(lat):
    """At solar noon the elevation is 90 − |lat − δ| (δ = ±23.44° at the solstices, 0 at
    the equinox), plus < 0.1° of refraction."""
    for date, dec in (("2026-06-21", 23.44), ("2026-12-21", -23.44), ("2026-03-20", 0.0)):
        az, el = solar_position(f"{date}T12:00", lat)
        expect = 90.0 - abs(lat - dec)
        assert el == pytest.approx(expect, abs=0.15), (date, lat)
        if abs(lat - dec) > 1.0:  # the sun is on the meridian: due south or due north
            meridian = 180.0 if lat > dec else 0.0
            assert abs((az - meridian + 180.0) % 360.0 - 180.0) < 0.05, (date, lat, az)


def test_equinox_sunrise_is_due_east_and_solstice_sunrise_north_of_east():
    # At the equinox the sun rises at 90° wherever you are; at the June solstice the
    # sunrise azimuth is acos(sin δ / cos φ) (geometric, before refraction).
    for lat in (0.0, 30.0, 45.8):
        times = [f"2026-03-20T{h:02d}:{m:02d}" for h in (5, 6) for m in range(0, 60, 1)]
        rise = min(times, key=lambda t: abs(solar_position(t, lat)[1]))
        assert solar_position(rise, lat)[0] == pytest.approx(90.0, abs=1.0)
    lat = 45.8
    expect = math.degrees(math.acos(math.sin(math.radians(23.44)) / math.cos(math.radians(lat))))
    hours = np.arange(3.0, 6.0, 1 / 240)
    els = [sky_at(dt.datetime(2026, 6, 21) + dt.timedelta(hours=float(h)), lat).sun_elevation
           for h in hours]
    # refraction lifts the sun by about 0.57° at the horizon: the geometric horizon
    # crossing is where the apparent elevation is 0.57°
    h = hours[int(np.argmin(np.abs(np.array(els) - 0.57)))]
    az = sky_at(dt.datetime(2026, 6, 21) + dt.timedelta(hours=float(h)), lat).sun_azimuth
    assert az == pytest.approx(expect, abs=1.0)


def test_civil_time_needs_the_longitude_and_uses_it():
    with pytest.raises(InvalidParameterError, match="longitude"):
        sky_at("2026-06-21T18:30+02:00", 45.8)
    a = sky_at("2026-06-21T18:30+02:00", 45.8, 16.0)
    b = sky_at(dt.datetime(2026, 6, 21, 16, 30, tzinfo=UTC), 45.8, 16.0)
    assert a.sun == pytest.approx(b.sun)
    # solar time: 12:00 is the sun on the meridian whatever the longitude
    for lon in (-120.0, 0.0, 16.0, 170.0):
        az, _ = sky_at("2026-08-01T12:00", 45.8, lon).sun
        assert az == pytest.approx(180.0, abs=0.05)


@pytest.mark.parametrize("text, match", [
    ("18:30", "no date"),
    ("2026-06-21", "no time of day"),
    ("2026-13-01T10:00", "cannot read"),
    ("yesterday at noon", "cannot read"),
])
def test_bad_times_are_one_clear_error(text, match):
    with pytest.raises(InvalidParameterError, match=match):
        parse_time(text)


@pytest.mark.parametrize("lat", [90.5, -91.0, float("nan")])
def test_latitude_out_of_range(lat):
    with pytest.raises(InvalidParameterError, match="latitude"):
        solar_position("2026-06-21T12:00", lat)


def test_moon_covers_the_sun_in_the_2024_eclipse_and_is_full_two_weeks_later():
    # Total solar eclipse, Dallas, 2024-04-08 18:42 UTC: the moon stands on the sun.
    s = sky_state(dt.datetime(2024, 4, 8, 18, 42, tzinfo=UTC), 32.78, -96.80)
    sun = sun_direction(*s.sun)
    moon = sun_direction(*s.moon)
    assert math.degrees(math.acos(float(sun @ moon))) < 0.6
    assert s.moon_illumination < 0.01
    # Full moon 2024-04-23 23:49 UTC
    full = sky_state(dt.datetime(2024, 4, 23, 23, 49, tzinfo=UTC), 45.8, 16.0)
    assert full.moon_illumination > 0.99
    # First quarter 2024-04-15 19:13 UTC: half lit, waxing; last quarter 2024-05-01 11:27
    fq = sky_state(dt.datetime(2024, 4, 15, 19, 13, tzinfo=UTC), 45.8, 16.0)
    lq = sky_state(dt.datetime(2024, 5, 1, 11, 27, tzinfo=UTC), 45.8, 16.0)
    assert fq.moon_illumination == pytest.approx(0.5, abs=0.03) and fq.moon_waxing
    assert lq.moon_illumination == pytest.approx(0.5, abs=0.03) and not lq.moon_waxing


def test_celestial_rotation_puts_the_pole_at_the_latitude_and_the_moon_where_it_is():
    s = sky_state(dt.datetime(2026, 6, 21, 22, 0, tzinfo=UTC), 45.8, 16.0)
    rot = s.celestial_to_horizon()
    assert np.allclose(rot @ rot.T, np.eye(3), atol=1e-12)
    pole = rot @ np.array([0.0, 0.0, 1.0])
    assert pole == pytest.approx(sun_direction(0.0, 45.8), abs=1e-9)
    # Polaris-like check with the sidereal time: the vernal equinox (RA 0) has hour angle LST
    eq0 = rot @ np.array([1.0, 0.0, 0.0])
    assert eq0 @ eq0 == pytest.approx(1.0)
    # one sidereal day later the sky has turned back to the same place
    later = sky_state(s.when + dt.timedelta(seconds=86164.09), 45.8, 16.0)
    assert later.celestial_to_horizon() == pytest.approx(rot, abs=1e-4)
