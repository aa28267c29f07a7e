"""Where a georeferenced map lies on the Earth: the longitude and latitude of its centre.

A map read from a GeoTIFF keeps its coordinate reference system (``Heightmap.crs``) and the
outer corner of its first sample's cell (``Heightmap.origin``); the centre is reprojected to
WGS 84 longitude/latitude with GDAL through rasterio (``rasterio.warp.transform``). Rows grow
southward (a north-up map), as GeoTIFF's geotransform has them. The centre is measured in
the CRS's own units: the pixel size in degrees for a geographic map, whose ``spacing`` the
readers keep in metres.
"""

from __future__ import annotations

import math

from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.io.geotiff import crs_pixel_size


def map_lon_lat(heightmap: Heightmap) -> tuple[float, float] | None:
    """(longitude, latitude) in degrees of the map's centre, or None without a georeference.

    Raises
    ------
    InvalidParameterError
        The CRS cannot be reprojected to longitude/latitude (an unknown or local CRS).
    """
    if heightmap.crs is None:
        return None
    try:
        from rasterio.crs import CRS
        from rasterio.errors import CRSError
        from rasterio.warp import transform
    except ImportError:  # pragma: no cover - rasterio is a core dependency
        return None
    ox, oy = heightmap.origin
    # the outer corners span cols × rows pixels; spacing is in metres for a map in degrees
    px, py = crs_pixel_size(heightmap)
    x, y = ox + 0.5 * px * heightmap.cols, oy - 0.5 * py * heightmap.rows
    try:
        lon, lat = transform(CRS.from_user_input(heightmap.crs), CRS.from_epsg(4326), [x], [y])
    except (CRSError, ValueError, RuntimeError) as exc:
        raise InvalidParameterError(
            f"cannot place the map on the Earth (CRS {heightmap.crs!r}): {exc}; give "
            "--latitude/--longitude") from None
    lon, lat = float(lon[0]), float(lat[0])
    if not (math.isfinite(lon) and math.isfinite(lat)):
        raise InvalidParameterError(
            f"the map's centre does not reproject to longitude/latitude (CRS {heightmap.crs!r});"
            " give --latitude/--longitude")
    return lon, lat


__all__ = ["map_lon_lat"]
