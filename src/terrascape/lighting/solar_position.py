"""Where the sun and the moon stand in the sky: date, time and place → azimuth, elevation.

The sun follows NOAA's solar position algorithm (the equations of NOAA's solar calculator
spreadsheet, after Meeus): Julian century, the sun's geometric mean longitude and anomaly,
the equation of centre, apparent longitude, the corrected obliquity of the ecliptic, the
declination, the equation of time, the true solar time and hour angle, and the atmospheric
refraction correction of the elevation. It is accurate to a small fraction of a degree for
the years 1800–2100.

The moon uses the Astronomical Almanac's low-precision series (ecliptic longitude,
latitude and horizontal parallax, a few periodic terms each; about 0.3° accurate), with a
topocentric parallax correction of the elevation; its phase comes from the elongation from
the sun.

A time without a UTC offset is *local solar time* (12:00 = the sun on the meridian, due
south in the northern hemisphere); with an offset it is civil time and needs the
longitude. Azimuth is in degrees clockwise from north, elevation above the horizon (the
convention of :func:`terrascape.lighting.sun.sun_direction`).

References
----------
.. [1] NOAA Global Monitoring Laboratory, "NOAA Solar Calculator" and its spreadsheet
   ("NOAA_Solar_Calculations_day.xls"), https://gml.noaa.gov/grad/solcalc/.
.. [2] J. Meeus, *Astronomical Algorithms*, 2nd ed., Willmann-Bell, 1998 (ch. 12 sidereal
   time, ch. 25 solar coordinates, ch. 28 equation of time, ch. 47 position of the moon,
   ch. 48 illuminated fraction).
.. [3] *The Astronomical Almanac*, section D: "Low-precision formulas for the Moon's
   coordinates" (U.S. Naval Observatory / HM Nautical Almanac Office).
"""

from __future__ import annotations

import datetime as _dt
import math
from dataclasses import dataclass

import numpy as np

from terrascape.errors import InvalidParameterError

_J2000 = 2451545.0
_UNIX_EPOCH_JD = 2440587.5


def _sin(deg: float) -> float:
    return math.sin(math.radians(deg))


def _cos(deg: float) -> float:
    return math.cos(math.radians(deg))


def julian_day(utc: _dt.datetime) -> float:
    """Julian day of an aware (or naive = UTC) datetime."""
    if utc.tzinfo is not None:
        utc = utc.astimezone(_dt.UTC).replace(tzinfo=None)
    delta = utc - _dt.datetime(1970, 1, 1)
    return _UNIX_EPOCH_JD + delta.days + (delta.seconds + delta.microseconds * 1e-6) / 86400.0


def check_latitude(latitude: float) -> float:
    lat = float(latitude)
    if not math.isfinite(lat) or not -90.0 <= lat <= 90.0:
        raise InvalidParameterError(f"latitude must be in [-90, 90] degrees, got {latitude:g}")
    return lat


def check_longitude(longitude: float) -> float:
    lon = float(longitude)
    if not math.isfinite(lon) or not -180.0 <= lon <= 360.0:
        raise InvalidParameterError(
            f"longitude must be in [-180, 180] degrees (east positive), got {longitude:g}")
    return (lon + 180.0) % 360.0 - 180.0


@dataclass(frozen=True)
class _SunEquatorial:
    declination: float  # degrees
    right_ascension: float  # degrees
    equation_of_time: float  # minutes
    apparent_longitude: float  # degrees (ecliptic)
    obliquity: float  # degrees


def _sun_equatorial(jd: float) -> _SunEquatorial:
    """NOAA spreadsheet columns G–V for one Julian day."""
    t = (jd - _J2000) / 36525.0  # Julian century
    l0 = (280.46646 + t * (36000.76983 + t * 0.0003032)) % 360.0
    m = 357.52911 + t * (35999.05029 - 0.0001537 * t)
    e = 0.016708634 - t * (0.000042037 + 0.0000001267 * t)
    c = (_sin(m) * (1.914602 - t * (0.004817 + 0.000014 * t))
         + _sin(2 * m) * (0.019993 - 0.000101 * t) + _sin(3 * m) * 0.000289)
    true_long = l0 + c
    omega = 125.04 - 1934.136 * t
    app_long = true_long - 0.00569 - 0.00478 * _sin(omega)
    eps0 = 23.0 + (26.0 + (21.448 - t * (46.815 + t * (0.00059 - t * 0.001813))) / 60.0) / 60.0
    eps = eps0 + 0.00256 * _cos(omega)
    ra = math.degrees(math.atan2(_cos(eps) * _sin(app_long), _cos(app_long))) % 360.0
    dec = math.degrees(math.asin(_sin(eps) * _sin(app_long)))
    y = math.tan(math.radians(eps / 2.0)) ** 2
    eot = 4.0 * math.degrees(
        y * _sin(2 * l0) - 2 * e * _sin(m) + 4 * e * y * _sin(m) * _cos(2 * l0)
        - 0.5 * y * y * _sin(4 * l0) - 1.25 * e * e * _sin(2 * m))
    return _SunEquatorial(dec, ra, eot, app_long, eps)


def refraction_correction(elevation_deg: float) -> float:
    """Atmospheric refraction (degrees) to add to a geometric elevation (NOAA's fit)."""
    h = float(elevation_deg)
    if h > 85.0:
        return 0.0
    te = math.tan(math.radians(h))
    if h > 5.0:
        arcsec = 58.1 / te - 0.07 / te**3 + 0.000086 / te**5
    elif h > -0.575:
        arcsec = 1735.0 + h * (-518.2 + h * (103.4 + h * (-12.79 + h * 0.711)))
    else:
        arcsec = -20.772 / te
    return arcsec / 3600.0


def _horizontal(hour_angle: float, dec: float, lat: float) -> tuple[float, float]:
    """Azimuth (from north, clockwise) and geometric elevation of hour angle/declination."""
    sh, ch = _sin(hour_angle), _cos(hour_angle)
    sd, cd = _sin(dec), _cos(dec)
    sl, cl = _sin(lat), _cos(lat)
    el = math.degrees(math.asin(max(-1.0, min(1.0, sl * sd + cl * cd * ch))))
    az = math.degrees(math.atan2(-cd * sh, sd * cl - cd * ch * sl)) % 360.0
    return az, el


def greenwich_sidereal_deg(jd: float) -> float:
    """Greenwich mean sidereal time in degrees (Meeus eq. 12.4)."""
    t = (jd - _J2000) / 36525.0
    return (280.46061837 + 360.98564736629 * (jd - _J2000) + 0.000387933 * t * t
            - t**3 / 38710000.0) % 360.0


@dataclass(frozen=True)
class SkyState:
    """Sun, moon and the rotation of the stars for one instant and place.

    Angles in degrees; ``moon_illumination`` is the lit fraction of the moon's disc
    (0 new … 1 full); ``moon_waxing`` tells which limb is lit; ``local_sidereal`` is the
    local sidereal time (the right ascension on the meridian), which turns the celestial
    sphere of the stars.
    """

    when: _dt.datetime  # UTC
    latitude: float
    longitude: float | None
    sun_azimuth: float
    sun_elevation: float
    moon_azimuth: float
    moon_elevation: float
    moon_illumination: float
    moon_waxing: bool
    local_sidereal: float
    equation_of_time: float  # minutes
    solar_time: float  # hours of local true solar time

    @property
    def sun(self) -> tuple[float, float]:
        return (self.sun_azimuth, self.sun_elevation)

    @property
    def moon(self) -> tuple[float, float]:
        return (self.moon_azimuth, self.moon_elevation)

    def celestial_to_horizon(self) -> np.ndarray:
        """3×3 rotation taking equatorial unit vectors to the world's horizontal frame
        (:func:`celestial_rotation` at this latitude and sidereal time)."""
        return celestial_rotation(self.latitude, self.local_sidereal)


def celestial_rotation(latitude: float, local_sidereal_deg: float) -> np.ndarray:
    """3×3 rotation taking equatorial unit vectors (x → right ascension 0 h, z → the north
    celestial pole) to the world's horizontal frame (X east, Y up, Z south) at ``latitude``
    when the local sidereal time is ``local_sidereal_deg``."""
    lst = math.radians(local_sidereal_deg)
    lat = math.radians(latitude)
    # equatorial → hour-angle frame (a: the equator on the meridian, b: hour angle 90°
    # (west), c: the pole), since H = LST − RA
    to_hour = np.array([[math.cos(lst), math.sin(lst), 0.0],
                        [math.sin(lst), -math.cos(lst), 0.0],
                        [0.0, 0.0, 1.0]])
    sl, cl = math.sin(lat), math.cos(lat)
    # columns a, b, c in (east, north, up)
    hour_to_enu = np.array([[0.0, -1.0, 0.0], [-sl, 0.0, cl], [cl, 0.0, sl]])
    enu_to_world = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
    return enu_to_world @ hour_to_enu @ to_hour


def _moon_ecliptic(jd: float) -> tuple[float, float, float]:
    """Ecliptic longitude, latitude and horizontal parallax (degrees) of the moon."""
    t = (jd - _J2000) / 36525.0
    lam = (218.32 + 481267.881 * t
           + 6.29 * _sin(135.0 + 477198.87 * t) - 1.27 * _sin(259.3 - 413335.36 * t)
           + 0.66 * _sin(235.7 + 890534.22 * t) + 0.21 * _sin(269.9 + 954397.74 * t)
           - 0.19 * _sin(357.5 + 35999.05 * t) - 0.11 * _sin(186.5 + 966404.03 * t))
    beta = (5.13 * _sin(93.3 + 483202.02 * t) + 0.28 * _sin(228.2 + 960400.89 * t)
            - 0.28 * _sin(318.3 + 6003.15 * t) - 0.17 * _sin(217.6 - 407332.21 * t))
    parallax = (0.9508 + 0.0518 * _cos(135.0 + 477198.87 * t)
                + 0.0095 * _cos(259.3 - 413335.36 * t) + 0.0078 * _cos(235.7 + 890534.22 * t)
                + 0.0028 * _cos(269.9 + 954397.74 * t))
    return lam % 360.0, beta, parallax


def _ecliptic_to_equatorial(lam: float, beta: float, eps: float) -> tuple[float, float]:
    ra = math.degrees(math.atan2(_sin(lam) * _cos(eps) - math.tan(math.radians(beta)) * _sin(eps),
                                 _cos(lam))) % 360.0
    dec = math.degrees(math.asin(_sin(beta) * _cos(eps) + _cos(beta) * _sin(eps) * _sin(lam)))
    return ra, dec


def sky_state(utc: _dt.datetime, latitude: float, longitude: float) -> SkyState:
    """Sun and moon positions for an instant (aware datetime, or naive = UTC) and place."""
    lat = check_latitude(latitude)
    lon = check_longitude(longitude)
    if utc.tzinfo is None:
        utc = utc.replace(tzinfo=_dt.UTC)
    jd = julian_day(utc)
    sun = _sun_equatorial(jd)
    minutes = (utc.astimezone(_dt.UTC) - utc.astimezone(_dt.UTC).replace(
        hour=0, minute=0, second=0, microsecond=0)).total_seconds() / 60.0
    true_solar = (minutes + sun.equation_of_time + 4.0 * lon) % 1440.0
    hour_angle = true_solar / 4.0 - 180.0
    sun_az, sun_el = _horizontal(hour_angle, sun.declination, lat)
    sun_el += refraction_correction(sun_el)
    # The sun's right ascension plus its hour angle is the local sidereal time; the same
    # from GMST + longitude differs by the mean/true sun (well under a degree).
    lst = (greenwich_sidereal_deg(jd) + lon) % 360.0
    lam, beta, parallax = _moon_ecliptic(jd)
    m_ra, m_dec = _ecliptic_to_equatorial(lam, beta, sun.obliquity)
    moon_az, moon_el = _horizontal(lst - m_ra, m_dec, lat)
    moon_el -= math.degrees(math.asin(_sin(parallax) * _cos(moon_el)))  # topocentric
    moon_el += refraction_correction(moon_el)
    # Phase angle ≈ 180° − elongation (Meeus eq. 48.2–48.4 with the distance ratio ≈ 0).
    cos_elong = _cos(beta) * _cos(lam - sun.apparent_longitude)
    elong = math.degrees(math.acos(max(-1.0, min(1.0, cos_elong))))
    phase_angle = 180.0 - elong
    illum = 0.5 * (1.0 + _cos(phase_angle))
    waxing = (lam - sun.apparent_longitude) % 360.0 < 180.0
    return SkyState(utc.astimezone(_dt.UTC), lat, lon, sun_az, sun_el, moon_az,
                    moon_el, illum, waxing, lst, sun.equation_of_time, true_solar / 60.0)


def solar_time_to_utc(date: _dt.date, solar_hours: float, longitude: float) -> _dt.datetime:
    """UTC instant at which the local true solar time at ``longitude`` is ``solar_hours``."""
    lon = check_longitude(longitude)
    base = _dt.datetime(date.year, date.month, date.day, tzinfo=_dt.UTC)
    guess = base + _dt.timedelta(minutes=solar_hours * 60.0 - 4.0 * lon)
    for _ in range(2):  # the equation of time changes by < 1 s an hour: two steps converge
        eot = _sun_equatorial(julian_day(guess)).equation_of_time
        guess = base + _dt.timedelta(minutes=solar_hours * 60.0 - eot - 4.0 * lon)
    return guess


def parse_time(text: str) -> tuple[_dt.datetime, bool]:
    """``YYYY-MM-DDTHH:MM[:SS][±HH:MM|Z]`` → (datetime, civil). A time without an offset is
    local solar time (naive datetime, ``civil`` False); with one it is an aware civil time."""
    s = str(text).strip()
    if "T" not in s.upper() and " " not in s:
        if ":" in s:
            raise InvalidParameterError(
                f"time {text!r} has no date: give YYYY-MM-DDTHH:MM (e.g. 2026-06-21T18:30)")
        raise InvalidParameterError(
            f"time {text!r} has no time of day: give YYYY-MM-DDTHH:MM (e.g. 2026-06-21T18:30)")
    try:
        when = _dt.datetime.fromisoformat(s.replace("z", "Z").replace("Z", "+00:00"))
    except ValueError:
        raise InvalidParameterError(
            f"cannot read the time {text!r}: give YYYY-MM-DDTHH:MM[:SS] with an optional UTC "
            "offset (e.g. 2026-06-21T18:30 or 2026-06-21T18:30+02:00)") from None
    if not 1800 <= when.year <= 2200:
        raise InvalidParameterError(f"year {when.year} is outside 1800–2200 (the solar "
                                    "position formulas' range)")
    return when, when.tzinfo is not None


def sky_at(time: str | _dt.datetime, latitude: float, longitude: float | None = None) -> SkyState:
    """Sun and moon for ``time`` (ISO text or datetime) at ``latitude``/``longitude``.

    A time without a UTC offset is local true solar time (12:00 = the sun on the meridian)
    and the longitude only moves the moon and the stars (0 if not given); a time with an
    offset is civil time and needs the longitude.
    """
    if isinstance(time, str):
        when, civil = parse_time(time)
    else:
        when, civil = time, time.tzinfo is not None
    lat = check_latitude(latitude)
    if civil:
        if longitude is None:
            raise InvalidParameterError(
                f"the time {when.isoformat()} has a UTC offset (civil time): give the "
                "longitude (--longitude) or a georeferenced map; without an offset the time "
                "is local solar time")
        return sky_state(when, lat, longitude)
    lon = 0.0 if longitude is None else check_longitude(longitude)
    hours = when.hour + when.minute / 60.0 + (when.second + when.microsecond * 1e-6) / 3600.0
    return sky_state(solar_time_to_utc(when.date(), hours, lon), lat, lon)


def solar_position(time: str | _dt.datetime, latitude: float,
                   longitude: float | None = None) -> tuple[float, float]:
    """The sun's ``(azimuth, elevation)`` in degrees, refraction included (:func:`sky_at`).

    Examples
    --------
    >>> az, el = solar_position("2026-03-20T12:00", 45.0)
    >>> round(az), round(el)
    (180, 45)
    """
    return sky_at(time, latitude, longitude).sun


__all__ = [
    "SkyState",
    "celestial_rotation",
    "check_latitude",
    "greenwich_sidereal_deg",
    "julian_day",
    "parse_time",
    "refraction_correction",
    "sky_at",
    "sky_state",
    "solar_position",
    "solar_time_to_utc",
]
