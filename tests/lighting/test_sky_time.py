"""The place and time of the sky: a georeferenced map's centre, durations, day cycles."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.lighting.geolocation import map_lon_lat
from terrascape.lighting.sky_time import (
    DEFAULT_LATITUDE,
    day_cycle,
    parse_duration,
    resolve_place,
    sky_for,
)


def test_a_utm_map_is_placed_at_its_centre():
    # UTM zone 33N: easting 500 km is the central meridian 15° E, where northing / 0.9996 is
    # the meridian arc from the equator: 5 076.98 km ≈ 45.83° N (WGS 84)
    # 11 × 11 cells of 100 m from the outer corner (499 450, 5 075 550): centre (500 000, 5 075 000)
    hm = Heightmap(np.zeros((11, 11), np.float32), (100.0, 100.0), origin=(499450.0, 5075550.0),
                   crs="EPSG:32633")
    lon, lat = map_lon_lat(hm)
    assert lon == pytest.approx(15.0, abs=1e-6)
    assert lat == pytest.approx(45.83, abs=0.01)
    place = resolve_place(hm, None, None)
    assert (place.latitude, place.longitude, place.source) == (lat, lon, "map")
    # a given latitude wins; the longitude still comes from the map
    assert resolve_place(hm, 10.0, None).latitude == 10.0
    assert resolve_place(hm, 10.0, None).longitude == lon


def test_a_map_in_degrees_is_placed_by_its_pixel_size_not_its_metric_spacing(tmp_path):
    # A DEM in WGS 84 degrees: 0.001° pixels, corner at 15.2° E 45.9° N, 401 × 301 pixels, so
    # its centre is 15.4005° E 45.7495° N. The reader keeps its spacing in metres (78 × 111 m);
    # adding that metric extent to an origin in degrees put the sun over another continent.
    rasterio = pytest.importorskip("rasterio")
    from rasterio.transform import from_origin

    from terrascape.io.geotiff import read_geotiff

    path = tmp_path / "dem4326.tif"
    with rasterio.open(path, "w", driver="GTiff", width=401, height=301, count=1,
                       dtype="float32", crs="EPSG:4326",
                       transform=from_origin(15.2, 45.9, 0.001, 0.001)) as dst:
        dst.write(np.full((1, 301, 401), 300.0, np.float32))
    hm = read_geotiff(path)
    assert hm.spacing[0] > 50.0  # metres, as the reader keeps them
    lon, lat = map_lon_lat(hm)
    assert lon == pytest.approx(15.2 + 0.5 * 0.001 * 401, abs=1e-9)
    assert lat == pytest.approx(45.9 - 0.5 * 0.001 * 301, abs=1e-9)
    # the same map without the reader's degrees: the pixel size is recovered from the spacing
    bare = Heightmap(hm.heights, hm.spacing, origin=hm.origin, crs="EPSG:4326")
    lon2, lat2 = map_lon_lat(bare)
    assert lon2 == pytest.approx(lon, abs=1e-3) and lat2 == pytest.approx(lat, abs=1e-3)


def test_without_a_georeference_the_default_latitude():
    place = resolve_place(Heightmap(np.zeros((4, 4), np.float32)), None, None)
    assert place.latitude == DEFAULT_LATITUDE and place.longitude is None


def test_civil_time_on_a_georeferenced_map_needs_no_longitude():
    hm = Heightmap(np.zeros((11, 11), np.float32), (100.0, 100.0), origin=(499450.0, 5075550.0),
                   crs="EPSG:32633")
    s = sky_for("2026-06-21T13:00+02:00", resolve_place(hm, None, None))
    # 11:00 UTC at 15° E is 12:00 mean solar time: the sun close to due south
    assert abs(s.sun_azimuth - 180.0) < 3.0


@pytest.mark.parametrize("text, seconds", [("24h", 86400), ("90m", 5400), ("1.5d", 129600),
                                           ("30s", 30), ("45min", 2700)])
def test_durations(text, seconds):
    assert parse_duration(text) == seconds


@pytest.mark.parametrize("text", ["24", "h", "-3h", "0h", "2y", "400d"])
def test_bad_durations(text):
    with pytest.raises(InvalidParameterError):
        parse_duration(text)


def test_a_day_cycle_loops_and_the_sun_rises_and_sets():
    states = day_cycle("2026-03-20T00:00", 86400.0, 24, resolve_place(None, 0.0, None))
    el = np.array([s.sun_elevation for s in states])
    assert len(states) == 24
    assert el.argmax() == 12 and el.max() > 85  # equinox noon on the equator
    assert el[0] < -80  # midnight
    hours = [(s.when - states[0].when).total_seconds() / 3600 for s in states]
    assert hours == pytest.approx(list(range(24)))
