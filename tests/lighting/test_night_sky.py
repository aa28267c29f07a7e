"""The sky light below the horizon: twilight, moonlight, the night sky, the exposure."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape.lighting.daylight import _LUMA, daylight
from terrascape.lighting.night_sky import (
    moon_irradiance,
    moon_phase_factor,
    sky_light,
    twilight_factor,
)
from terrascape.lighting.sun import sun_direction

ZENITH = np.array([0.0, 1.0, 0.0])


def test_above_half_a_degree_it_is_the_daylight_model():
    """Exactly the daylight model's light and exposure; its sky too with the sun above 10°,
    below that the sky toward the sun is warmed at the same luminance (sunset glow)."""
    for el in (0.5, 5.0, 10.0, 45.0, 80.0):
        light = sky_light(135.0, el)
        day = daylight(135.0, el)
        assert light.exposure == pytest.approx(day.exposure)
        assert np.allclose(light.key_irradiance, day.sun_irradiance)
        dirs = np.array([sun_direction(a, e) for a in (0, 90, 200) for e in (2, 30, 70)])
        ours, theirs = light.sky_radiance(dirs), day.sky_radiance(dirs)
        assert np.allclose(ours @ _LUMA, theirs @ _LUMA, rtol=1e-5)
        if el >= 10.0:
            assert np.allclose(ours, theirs, rtol=1e-5)
        else:  # warmer toward the sun than away from it
            toward = ours[np.argmax(dirs @ light.day.sun_dir)]
            assert toward[0] / toward[2] > theirs[np.argmax(dirs @ light.day.sun_dir)][0] / \
                theirs[np.argmax(dirs @ light.day.sun_dir)][2]


def test_twilight_dims_by_decades_and_the_night_keeps_a_floor():
    assert twilight_factor(5.0) == 1.0
    assert twilight_factor(-6.0) == pytest.approx(10 ** -2.52)
    assert twilight_factor(-30.0) == twilight_factor(-18.0) == 0.0
    lum = [float(sky_light(200.0, el).sky_radiance(ZENITH) @ _LUMA) for el in (0, -3, -6, -12)]
    assert lum == sorted(lum, reverse=True)
    night = sky_light(200.0, -30.0).sky_radiance(ZENITH)
    assert 0.0 < night @ _LUMA < 1e-5 and night[2] > night[1] > night[0]


def test_moonlight_is_weak_bluish_and_follows_the_phase():
    full = moon_irradiance(60.0, 1.0)
    quarter = moon_irradiance(60.0, 0.5)
    assert 1.5e-4 < full @ _LUMA < 3e-4  # about 0.25 lx, in klx
    assert full[2] > full[0]  # bluish
    assert quarter @ _LUMA == pytest.approx(full @ _LUMA * moon_phase_factor(0.5))
    assert 0.05 < moon_phase_factor(0.5) < 0.2  # a quarter gives ~1/10 of the full moon
    assert np.all(moon_irradiance(-5.0, 1.0) == 0.0)


def test_the_key_light_is_the_sun_then_the_moon_then_none():
    assert sky_light(270.0, 10.0, moon_azimuth=90.0, moon_elevation=30.0,
                     moon_illumination=1.0).key == "sun"
    night = sky_light(0.0, -20.0, moon_azimuth=90.0, moon_elevation=30.0, moon_illumination=1.0)
    assert night.key == "moon"
    assert night.key_direction == pytest.approx(sun_direction(90.0, 30.0))
    assert sky_light(0.0, -20.0, moon_azimuth=90.0, moon_elevation=-30.0).key == "none"


def test_exposure_adapts_only_partly_and_a_moonless_night_is_darker():
    """White paper facing the key light displays darker at night than by day (not black)."""
    def paper(light):
        e = light.key_irradiance * max(light.key_direction[1], np.sin(np.radians(20)))
        return float((e + light.sky_irradiance) @ _LUMA) / np.pi * light.exposure

    day = paper(sky_light(180.0, 40.0))
    moon = paper(sky_light(0.0, -25.0, moon_azimuth=180.0, moon_elevation=40.0,
                           moon_illumination=1.0))
    dark = paper(sky_light(0.0, -25.0))
    assert day > moon > dark > 0.1
    assert moon < 0.6 * day
