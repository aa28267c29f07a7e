"""Maps in degrees made metric: warped to the UTM zone of their centre before they are drawn.

A DEM in geographic coordinates (EPSG:4326 and the like) has its samples a fraction of a
degree apart while its heights are in metres. Drawn, meshed or exported as it is, a 403 × 344
DEM 0.00083° apart is a needle 0.3 units wide and 800 tall. :func:`to_metric` warps such a map
(``rasterio.warp``, bilinear) to the Universal Transverse Mercator zone that holds its centre,
a conformal projection whose scale error is below 0.1 % within the zone, so the terrain keeps
its shape. Two kinds of maps count as being in degrees:

* a map whose CRS is geographic (a GeoTIFF in EPSG:4326, or ``--crs EPSG:4326``);
* a map without a CRS whose spacing looks like degrees (:func:`~terrascape.io.geotiff.
  degree_warning`: below 0.01 while its relief is over 100× its extent); it is taken as WGS
  84 degrees with its corner at its origin (0, 0 when the file has none: a UTM zone at the
  equator, where a degree is 111 km both ways).

References
----------
.. [1] J. P. Snyder, "Map Projections — A Working Manual", USGS Professional Paper 1395,
   1987, ch. 8 (Universal Transverse Mercator).
"""

from __future__ import annotations

import math

from terrascape.heightmap import Heightmap
from terrascape.io.geotiff import (
    _crs_is_geographic,
    assign_crs,
    crs_pixel_size,
    degree_warning,
    rasterio_available,
    reproject,
)

__all__ = ["centre_lon_lat", "to_metric", "utm_crs"]


def utm_crs(lon: float, lat: float) -> str:
    """The EPSG code of the UTM zone (WGS 84) that holds ``(lon, lat)`` degrees:
    ``EPSG:326zz`` north of the equator, ``EPSG:327zz`` south; the polar stereographic
    (UPS, ``EPSG:32661``/``EPSG:32761``) beyond 84° N / 80° S, where UTM is not defined."""
    if lat > 84.0:
        return "EPSG:32661"
    if lat < -80.0:
        return "EPSG:32761"
    zone = min(60, max(1, math.floor((((lon + 180.0) % 360.0)) / 6.0) + 1))
    return f"EPSG:{32600 + zone if lat >= 0.0 else 32700 + zone}"


def centre_lon_lat(heightmap: Heightmap) -> tuple[float, float]:
    """``(lon, lat)`` of the centre of a map in a geographic CRS (its pixel size in degrees,
    not its spacing, which the readers keep in metres)."""
    px, py = crs_pixel_size(heightmap)
    lon = heightmap.origin[0] + 0.5 * px * heightmap.cols
    lat = heightmap.origin[1] - 0.5 * py * heightmap.rows
    return lon, max(-90.0, min(90.0, lat))


def to_metric(heightmap: Heightmap) -> tuple[Heightmap, str | None]:
    """The map warped to the UTM zone of its centre when it is in degrees (see the module
    docstring), and a sentence saying what was done; ``(heightmap, None)`` when it is not in
    degrees (or rasterio, the ``geo`` extra, is not installed: then the readers' spacing in
    metres at the centre latitude stands)."""
    guessed = False
    if not _crs_is_geographic(heightmap.crs):
        if heightmap.crs is not None or degree_warning(heightmap) is None:
            return heightmap, None
        guessed = True
    if not rasterio_available():
        return heightmap, None
    source = assign_crs(heightmap, "EPSG:4326") if guessed else heightmap
    lon, lat = centre_lon_lat(source)
    target = utm_crs(lon, lat)
    metric = reproject(source, target)
    dx, dz = metric.spacing
    what = ("the map's spacing looks like degrees and it has no CRS: taken as WGS 84 degrees "
            "and converted" if guessed else
            f"the map is in degrees ({heightmap.crs[:40]}): converted")
    zone = int(target[-2:])
    name = ("UPS" if zone == 61 else f"UTM zone {zone}{'N' if target[5:8] == '326' else 'S'}")
    return metric, (
        f"{what} to {name} ({target}), {metric.cols}×{metric.rows} samples "
        f"{dx:.4g} × {dz:.4g} m apart; --no-reproject keeps it as it is")
