"""From what a user types (a date and time, a place, a span of a day) to sky states.

``--time`` without a UTC offset is local true solar time; with one it is civil time and
needs a longitude. The place is ``--latitude``/``--longitude`` or, when the map has a
georeference, its centre (:func:`terrascape.lighting.geolocation.map_lon_lat`).
"""

from __future__ import annotations

import datetime as _dt
import math
import re
from dataclasses import dataclass

from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.lighting.geolocation import map_lon_lat
from terrascape.lighting.solar_position import (
    SkyState,
    check_latitude,
    check_longitude,
    parse_time,
    sky_state,
    solar_time_to_utc,
)

#: Latitude of a map without a georeference when none is given (degrees north).
DEFAULT_LATITUDE = 45.0
#: Start of a day cycle without ``--time``: midnight (solar time) of the June solstice.
DEFAULT_CYCLE_START = "2026-06-21T00:00"
_UNITS = {"s": 1.0, "m": 60.0, "min": 60.0, "h": 3600.0, "d": 86400.0}


def parse_duration(text: str) -> float:
    """``"24h"``, ``"90m"``, ``"1.5d"``, ``"3600s"`` → seconds (> 0, at most a year)."""
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+)\s*(s|m|min|h|d)\s*", str(text))
    if not m:
        raise InvalidParameterError(
            f"cannot read the duration {text!r}: give a number and a unit s, m, h or d "
            "(e.g. 24h)")
    seconds = float(m.group(1)) * _UNITS[m.group(2)]
    if not 0.0 < seconds <= 366 * 86400.0:
        raise InvalidParameterError(f"duration {text!r} must be > 0 and at most a year")
    return seconds


@dataclass(frozen=True)
class Place:
    latitude: float
    longitude: float | None
    source: str  # "given", "map" or "default"


def resolve_place(heightmap: Heightmap | None, latitude: float | None,
                  longitude: float | None) -> Place:
    """The observer's place: given values first, then the map's georeference, then 45° N."""
    lat = None if latitude is None else check_latitude(latitude)
    lon = None if longitude is None else check_longitude(longitude)
    source = "given"
    if (lat is None or lon is None) and heightmap is not None:
        where = map_lon_lat(heightmap)
        if where is not None:
            lon = where[0] if lon is None else lon
            lat = where[1] if lat is None else lat
            source = "map"
    if lat is None:
        lat, source = DEFAULT_LATITUDE, "default"
    return Place(lat, lon, source)


def start_instant(time: str, place: Place) -> tuple[_dt.datetime, float]:
    """(UTC instant, longitude used) of ``time`` at ``place`` (module docstring)."""
    when, civil = parse_time(time)
    if civil:
        if place.longitude is None:
            raise InvalidParameterError(
                f"--time {time} has a UTC offset (civil time): give --longitude (or a "
                "georeferenced map); without an offset the time is local solar time")
        return when.astimezone(_dt.UTC), place.longitude
    lon = 0.0 if place.longitude is None else place.longitude
    hours = when.hour + when.minute / 60.0 + (when.second + when.microsecond * 1e-6) / 3600.0
    return solar_time_to_utc(when.date(), hours, lon), lon


def sky_for(time: str, place: Place) -> SkyState:
    """The sky at ``time`` (ISO text) and ``place``."""
    utc, lon = start_instant(time, place)
    return sky_state(utc, place.latitude, lon)


def day_cycle(start: str, duration_s: float, frames: int, place: Place) -> list[SkyState]:
    """``frames`` sky states from ``start`` over ``duration_s`` seconds, evenly spaced, the
    last one step short of the end (a 24 h cycle loops)."""
    if not isinstance(frames, int) or frames < 1 or frames > 100_000:
        raise InvalidParameterError(f"--frames must be an integer in [1, 100000], got {frames}")
    if not math.isfinite(duration_s) or duration_s <= 0:
        raise InvalidParameterError(f"the day cycle's duration must be > 0, got {duration_s}")
    utc, lon = start_instant(start, place)
    step = duration_s / frames
    return [sky_state(utc + _dt.timedelta(seconds=k * step), place.latitude, lon)
            for k in range(frames)]


__all__ = [
    "DEFAULT_CYCLE_START",
    "DEFAULT_LATITUDE",
    "Place",
    "day_cycle",
    "parse_duration",
    "resolve_place",
    "sky_for",
    "start_instant",
]
