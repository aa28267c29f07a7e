"""Sky light through the whole day: daylight, sunset, twilight, a moonlit or dark night.

:func:`sky_light` extends the clear-day model of :mod:`terrascape.lighting.daylight` below
the horizon:

* **Sunset** — the sun's direct light fades with the visible part of its disc (its centre
  from +0.27° to −0.27°); the Preetham sky stays the one of a sun at 0.5° (its fit is for a
  sun above the horizon), and with the sun under 10° the sky toward it takes the colour of
  the reddened sun (:func:`sunset_glow`).
* **Twilight** — the sky dims by about 2.5 decades per 6° of solar depression (civil,
  nautical, astronomical twilight end at −6°, −12°, −18°; zenith luminance from about
  10³ cd/m² at sunset to 10⁻³ cd/m²), and turns blue (ozone's Chappuis band absorbs the
  red and yellow of the long path of twilight light).
* **Moon** — moonlight is sunlight reflected by the moon: its illuminance at the ground is
  about 0.27 lx for a full moon (1/470 000 of the sun), falls with the phase (the Allen
  phase law ≈ lit fraction^1.5 near full, steeper toward new) and is extinguished by the
  same air mass as the sun. The moonlit sky is the day sky of a sun where the moon is,
  dimmed by the same ratio, so a moonlit night is a blue sky of very low luminance.
* **Night sky** — airglow and starlight, about 2·10⁻⁴ cd/m² (21.5 mag/arcsec²), brighter
  toward the horizon (van Rhijn's law); stars are drawn by the renderer on top.
* **Adaptation** — the eye (or camera) adapts only partly to the night: the exposure is the
  day model's automatic exposure for the scene's reference light, times
  ``(reference / sunset reference)^ADAPTATION``, so a moonlit landscape shows dim blue-grey,
  not as bright as day and not black. At night the displayed colours are tinted blue
  (``NIGHT_TINT``): scotopic vision sees moonlight as bluish, the convention of night
  photography and film.

References
----------
.. [1] A. J. Preetham, P. Shirley, B. Smits, "A Practical Analytic Model for Daylight",
   SIGGRAPH 1999.
.. [2] H. W. Jensen, F. Durand, M. M. Stark, S. Premože, J. Dorsey, P. Shirley, "A
   Physically-Based Night Sky Model", SIGGRAPH 2001 (moonlight, airglow, starlight,
   the blue shift of night scenes).
.. [3] C. W. Allen, *Astrophysical Quantities*, 3rd ed., 1973 (lunar phase law, night-sky
   brightness).
.. [4] R. L. Lee Jr., "Twilight and daytime colors of the clear sky", Applied Optics 33(21),
   1994 (twilight luminance and the Chappuis band).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from terrascape._validate import check_range
from terrascape.lighting.daylight import (
    _LUMA,
    MIN_SUN_ELEVATION,
    Daylight,
    daylight,
    sun_transmittance,
)
from terrascape.lighting.sun import sun_direction

#: Angular radius of the sun's and the moon's discs (degrees).
SUN_RADIUS = 0.27
#: Illuminance of a full moon at the zenith above the atmosphere (klx): 0.27 lx.
FULL_MOON_ILLUMINANCE = 2.7e-4
#: Zenith radiance of the moonless night sky (kcd/m²): airglow + starlight, 2·10⁻⁴ cd/m².
NIGHT_SKY_RADIANCE = 2.0e-7
#: Colour of the moonless night sky (linear RGB, luminance 1 after the night tint).
NIGHT_SKY_COLOR = np.array([0.55, 0.75, 1.6])
#: Blue shift of what is seen at night (scotopic vision), multiplied into moonlight.
NIGHT_TINT = np.array([0.62, 0.80, 1.45])
#: Exponent of the partial adaptation to darkness (see the module docstring).
ADAPTATION = 0.10
#: At night the sky is drawn this much darker than the physical model (which makes a
#: sky-lit sky as bright as white paper): the dark-sky convention of night photography.
NIGHT_SKY_DIM = 0.1
#: Share of the colour replaced by a blue-grey of the same luminance at full night
#: (scotopic vision sees little colour).
NIGHT_DESATURATION = 0.65
#: Twilight dimming: decades of sky luminance per degree of solar depression.
TWILIGHT_DECADES_PER_DEGREE = 0.42
#: Below this solar depression the sky is the night sky only (astronomical night).
ASTRONOMICAL_NIGHT = -18.0


def twilight_factor(sun_elevation: float) -> float:
    """Share of the sunset sky's luminance left at ``sun_elevation`` (1 at and above 0°,
    0 from astronomical night on)."""
    depth = min(max(-float(sun_elevation), 0.0), -ASTRONOMICAL_NIGHT)
    # from nautical to astronomical night the last sunlight fades out entirely: the
    # night sky (airglow) is all that is left
    t = min(max((depth - 12.0) / (-ASTRONOMICAL_NIGHT - 12.0), 0.0), 1.0)
    return 10.0 ** (-TWILIGHT_DECADES_PER_DEGREE * depth) * (1.0 - t * t * (3.0 - 2.0 * t))


def twilight_tint(sun_elevation: float) -> np.ndarray:
    """RGB multiplier of the twilight sky: neutral at sunset, blue by the end of civil
    twilight (the Chappuis absorption of ozone along the long light path)."""
    t = min(max(-float(sun_elevation) / 6.0, 0.0), 1.0)
    tint = (1.0 - t) * np.ones(3) + t * np.array([0.55, 0.75, 1.5])
    return tint / (tint @ _LUMA)


def sun_disc_fraction(sun_elevation: float) -> float:
    """Visible share of the sun's disc above the horizon (a linear fade across it)."""
    return min(max((float(sun_elevation) + SUN_RADIUS) / (2 * SUN_RADIUS), 0.0), 1.0)


def moon_phase_factor(illumination: float) -> float:
    """Brightness of the moon relative to full for a lit fraction (Allen's phase law: a
    quarter moon gives about 1/10 of the full moon's light, not 1/2)."""
    k = min(max(float(illumination), 0.0), 1.0)
    phase_angle = math.degrees(math.acos(2.0 * k - 1.0))
    # Allen 1973: magnitude change 0.026|i| + 4e-9 i⁴ (i in degrees)
    return 10.0 ** (-0.4 * (0.026 * phase_angle + 4.0e-9 * phase_angle**4))


def moon_irradiance(moon_elevation: float, illumination: float,
                    turbidity: float = 3.0) -> np.ndarray:
    """Moonlight at normal incidence on the ground (RGB, klx; the night tint applied)."""
    if moon_elevation <= -SUN_RADIUS:
        return np.zeros(3)
    trans = sun_transmittance(max(moon_elevation, MIN_SUN_ELEVATION), turbidity)
    noon = sun_transmittance(90.0, turbidity)
    lum = FULL_MOON_ILLUMINANCE * moon_phase_factor(illumination) * sun_disc_fraction(
        moon_elevation)
    return lum * (trans / (noon @ _LUMA)) * NIGHT_TINT


@dataclass(frozen=True)
class SkyLight:
    """The light of one moment: sky radiance, the key light (sun or moon), exposure.

    ``key`` is ``"sun"``, ``"moon"`` or ``"none"``; ``key_direction`` points toward it and
    ``key_irradiance`` is its RGB irradiance at normal incidence (klx).
    """

    sun_azimuth: float
    sun_elevation: float
    moon_azimuth: float | None
    moon_elevation: float | None
    moon_illumination: float
    day: Daylight  # the sky of the sun (at >= 0.5°)
    moon_day: Daylight | None  # the same model for a sun where the moon is
    twilight: float
    tint: np.ndarray
    moon_sky_scale: float
    key: str
    key_direction: np.ndarray
    key_irradiance: np.ndarray
    sky_irradiance: np.ndarray
    exposure: float
    star_visibility: float
    night: float  # 0 by day … 1 from 12° of solar depression on

    @property
    def sky_scale(self) -> float:
        """Factor of the drawn sky at night (``NIGHT_SKY_DIM`` at full night)."""
        return 1.0 - (1.0 - NIGHT_SKY_DIM) * self.night

    @property
    def desaturation(self) -> float:
        return NIGHT_DESATURATION * self.night

    def sky_radiance(self, directions) -> np.ndarray:
        """Sky radiance (RGB, kcd/m²) along unit ``directions`` (..., 3), without the discs
        of the sun and the moon and without the stars."""
        d = np.asarray(directions, dtype=np.float64)
        rad = sunset_glow(self.day.sky_radiance(d), d, self.day.sun_dir, self.sun_elevation,
                          self.day.turbidity)
        rad = rad * (self.twilight * self.tint)
        if self.moon_day is not None and self.moon_sky_scale > 0.0:
            rad = rad + self.moon_day.sky_radiance(d) * self.moon_sky_scale * NIGHT_TINT
        return (rad + night_sky_radiance(d)) * self.sky_scale

    def ground_irradiance(self) -> np.ndarray:
        return self.key_irradiance * max(float(self.key_direction[1]), 0.0) + self.sky_irradiance


def sunset_glow(radiance: np.ndarray, directions: np.ndarray, sun_dir: np.ndarray,
                sun_elevation: float, turbidity: float = 3.0) -> np.ndarray:
    """Warm the sky around a low sun with the colour of the reddened sun itself.

    Preetham's fit keeps the sky near a setting sun pale yellow; the light scattered once
    near the sun has crossed the same long air path as the sunlight and has its colour.
    Toward the sun (angle γ), low in the sky and with the sun under 10°, the radiance is
    multiplied channel-wise by ``sun_colour^w``, ``w = low·exp(-γ/40°)·(1 - 0.7·d_y)``, at
    the same luminance.
    """
    low = min(max((10.0 - float(sun_elevation)) / 10.0, 0.0), 1.0)
    if low <= 0.0:
        return radiance
    trans = sun_transmittance(max(float(sun_elevation), MIN_SUN_ELEVATION), turbidity)
    colour = trans / sun_transmittance(90.0, turbidity)
    colour = np.maximum(colour / colour.max(), 1e-3)
    d = np.asarray(directions, dtype=np.float64)
    gamma = np.arccos(np.clip(d @ sun_dir, -1.0, 1.0))
    w = low * np.exp(-gamma / np.radians(40.0)) * (1.0 - 0.7 * np.clip(d[..., 1], 0.0, 1.0))
    warm = radiance * colour ** (0.8 * w[..., None])
    lum = radiance @ _LUMA
    warm_lum = np.maximum(warm @ _LUMA, 1e-30)
    return warm * (lum / warm_lum)[..., None]


def night_sky_radiance(directions) -> np.ndarray:
    """Moonless night sky (RGB, kcd/m²): airglow brightening toward the horizon (van Rhijn:
    the path through the glowing layer at 90 km grows as 1/sqrt(1 - 0.965 sin²z))."""
    d = np.asarray(directions, dtype=np.float64)
    cos_z = np.clip(d[..., 1], 0.0, 1.0)
    sin2 = 1.0 - cos_z**2
    van_rhijn = 1.0 / np.sqrt(1.0 - 0.965 * sin2)
    return NIGHT_SKY_RADIANCE * (0.6 + 0.4 * van_rhijn)[..., None] * NIGHT_SKY_COLOR


def _reference(key_irr: np.ndarray, key_el: float, sky_irr: np.ndarray) -> float:
    """Luminance of white paper facing the key light (at least 20° of it) under the sky,
    the exposure reference of :func:`terrascape.lighting.daylight.daylight`."""
    s = max(math.sin(math.radians(max(key_el, MIN_SUN_ELEVATION))), math.sin(math.radians(20.0)))
    return float((key_irr @ _LUMA) * s + sky_irr @ _LUMA) / math.pi


@lru_cache(maxsize=16)
def _darkest_reference(turbidity: float) -> float:
    return _reference(moon_irradiance(30.0, 0.5, turbidity), 30.0, np.zeros(3))


@lru_cache(maxsize=256)
def _daylight(az: float, el: float, turbidity: float) -> Daylight:
    return daylight(az, el, turbidity=turbidity)


def sky_light(
    sun_azimuth: float,
    sun_elevation: float,
    *,
    moon_azimuth: float | None = None,
    moon_elevation: float | None = None,
    moon_illumination: float = 0.0,
    turbidity: float = 3.0,
    exposure: float = 0.0,
) -> SkyLight:
    """The sky and its light for a sun (and optionally a moon) anywhere above or below the
    horizon; above 0.5° of sun its light and exposure are exactly those of
    :func:`~terrascape.lighting.daylight.daylight`, and so is its sky above 10° (below, the
    sky toward the sun is warmed: :func:`sunset_glow`).

    Parameters
    ----------
    sun_azimuth, sun_elevation
        Degrees (clockwise from north; above the horizon, negative below).
    moon_azimuth, moon_elevation, moon_illumination
        The moon's position and lit fraction (0 new … 1 full); no moon if None.
    turbidity, exposure
        As in :func:`~terrascape.lighting.daylight.daylight`.
    """
    el = check_range(sun_elevation, "sun elevation (degrees)", -90.0, 90.0)
    ev = check_range(exposure, "exposure (EV)", -10.0, 10.0)
    az = float(sun_azimuth) % 360.0
    day = _daylight(az, max(el, MIN_SUN_ELEVATION), float(turbidity))
    twi = twilight_factor(el)
    tint = twilight_tint(el)
    sun_irr = day.sun_irradiance * sun_disc_fraction(el)
    sky_irr = day.sky_irradiance * twi * tint
    moon_day = None
    moon_scale = 0.0
    moon_irr = np.zeros(3)
    if moon_elevation is not None and moon_azimuth is not None:
        m_el = check_range(moon_elevation, "moon elevation (degrees)", -90.0, 90.0)
        m_az = float(moon_azimuth) % 360.0
        moon_irr = moon_irradiance(m_el, moon_illumination, turbidity)
        if m_el > -SUN_RADIUS:
            moon_day = _daylight(m_az, max(m_el, MIN_SUN_ELEVATION), float(turbidity))
            # the moonlit sky: the day sky of a sun there, dimmed as moonlight is to sunlight
            moon_scale = float(moon_irr @ _LUMA) / max(float(moon_day.sun_irradiance @ _LUMA),
                                                       1e-12) / float(NIGHT_TINT @ _LUMA)
            sky_irr = sky_irr + moon_day.sky_irradiance * moon_scale * NIGHT_TINT
    night_irr = math.pi * NIGHT_SKY_RADIANCE * NIGHT_SKY_COLOR  # ≈ the hemisphere's ∫L cos θ
    sky_irr = sky_irr + night_irr
    # Key light: the sun while any of its disc shows, else the moon if it is up.
    if el > -SUN_RADIUS:
        key, key_dir, key_irr, key_el = "sun", sun_direction(az, el), sun_irr, el
    elif moon_day is not None and float(moon_irr @ _LUMA) > 0.0:
        key, key_dir, key_irr, key_el = ("moon", sun_direction(moon_azimuth, moon_elevation),
                                         moon_irr, float(moon_elevation))
    else:
        key, key_dir, key_irr, key_el = "none", sun_direction(az, el), np.zeros(3), el
    if el >= MIN_SUN_ELEVATION:
        expo = day.exposure * 2.0**ev
    else:
        ref0 = 1.0 / day.exposure  # the sunset reference (daylight at 0.5°)
        ref = _reference(key_irr, key_el, sky_irr) if key != "sun" else _reference(
            sun_irr + moon_irr, key_el, sky_irr)
        # Adaptation stops at a twentieth of the light of a half moon 30° high: a moonless
        # night is darker than a moonlit one.
        ref = max(ref, 0.05 * _darkest_reference(float(turbidity)))
        expo = 2.0**ev / ref * min(1.0, ref / ref0) ** ADAPTATION
    stars = min(max((-el - 3.0) / 9.0, 0.0), 1.0)
    t = min(max(-el / 12.0, 0.0), 1.0)
    night = t * t * (3.0 - 2.0 * t)
    return SkyLight(az, el, moon_azimuth, moon_elevation, float(moon_illumination), day,
                    moon_day, twi, tint, moon_scale, key, key_dir, key_irr, sky_irr, expo,
                    stars, night)


__all__ = [
    "ADAPTATION",
    "FULL_MOON_ILLUMINANCE",
    "NIGHT_DESATURATION",
    "NIGHT_SKY_DIM",
    "NIGHT_SKY_RADIANCE",
    "SkyLight",
    "moon_irradiance",
    "moon_phase_factor",
    "night_sky_radiance",
    "sky_light",
    "sun_disc_fraction",
    "twilight_factor",
    "twilight_tint",
]
