"""A heightmap on a longitude/latitude grid, for the web tile pyramids (quantized-mesh,
Terrain-RGB): built from a georeferenced map (reprojected to EPSG:4326 with rasterio) or from a
local grid placed with its centre at a chosen longitude/latitude."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap


@dataclass(frozen=True)
class GeoGrid:
    """Heights on a regular lon/lat grid: sample ``[r, c]`` is at
    ``(west + (c + ½)·dlon, north − (r + ½)·dlat)`` degrees (cell centres, EPSG:4326)."""

    heights: np.ndarray
    west: float
    north: float
    dlon: float
    dlat: float

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """``(west, south, east, north)`` of the cell corners, degrees."""
        rows, cols = self.heights.shape
        return (self.west, self.north - rows * self.dlat, self.west + cols * self.dlon,
                self.north)

    @property
    def centre_bounds(self) -> tuple[float, float, float, float]:
        """``(west, south, east, north)`` of the outermost sample centres — the data extent."""
        w, s, e, n = self.bounds
        return (w + self.dlon / 2, s + self.dlat / 2, e - self.dlon / 2, n - self.dlat / 2)

    def sample(self, lon: np.ndarray, lat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Bilinear heights at ``(lon, lat)`` and a mask of points inside the data extent
        (outside points get the nearest edge sample's height)."""
        col = (np.asarray(lon, np.float64) - self.west) / self.dlon - 0.5
        row = (self.north - np.asarray(lat, np.float64)) / self.dlat - 0.5
        rows, cols = self.heights.shape
        eps = 1e-9
        inside = (col >= -eps) & (col <= cols - 1 + eps) & (row >= -eps) & (row <= rows - 1 + eps)
        coords = np.stack([np.clip(row, 0, rows - 1), np.clip(col, 0, cols - 1)])
        # float32 in, float64 out: no per-call copy of the whole map (tiles sample it often)
        h = ndimage.map_coordinates(self.heights, coords.reshape(2, -1), order=1,
                                    mode="nearest", output=np.float64).reshape(np.shape(lon))
        return h, inside

    def metres_per_degree(self) -> tuple[float, float]:
        from terrascape.io.tiff import geographic_spacing

        _w, s, _e, n = self.bounds
        return geographic_spacing(1.0, 1.0, (s + n) / 2)


def geo_grid(heightmap: Heightmap, lonlat: tuple[float, float] | None = None) -> GeoGrid:
    """The map on a lon/lat grid.

    ``lonlat`` places a local (or any) map with its centre at that longitude/latitude, using
    the WGS84 metres per degree there (the spacing must be in metres). Without it the map must
    carry a CRS: EPSG:4326 maps are used as they are, others are reprojected.
    """
    from terrascape.io.tiff import geographic_spacing

    if lonlat is not None:
        lon, lat = (float(v) for v in lonlat)
        if not (-180 <= lon <= 180 and -85 <= lat <= 85):
            raise InvalidParameterError(
                f"--lonlat must be a longitude in [-180, 180] and latitude in [-85, 85], "
                f"got {lon}, {lat}"
            )
        mx, mz = geographic_spacing(1.0, 1.0, lat)
        dlon, dlat = heightmap.spacing[0] / mx, heightmap.spacing[1] / mz
        rows, cols = heightmap.shape
        return GeoGrid(heightmap.heights, lon - cols * dlon / 2, lat + rows * dlat / 2, dlon,
                       dlat)
    if heightmap.crs is None:
        raise InvalidParameterError(
            "this map has no georeference: give --lonlat LON,LAT to place it on the globe"
        )
    from terrascape.io.geotiff import crs_pixel_size, reproject

    hm = heightmap if heightmap.crs == "EPSG:4326" else reproject(heightmap, "EPSG:4326")
    px, py = crs_pixel_size(hm)
    return GeoGrid(hm.heights, hm.origin[0], hm.origin[1], px, py)


# --- tiling schemes -------------------------------------------------------------------------
def tms_geographic_bounds(z: int, x: int, y: int) -> tuple[float, float, float, float]:
    """``(west, south, east, north)`` of Cesium's geographic TMS tile (2 × 1 tiles at level 0,
    ``y`` counted from the south)."""
    size = 180.0 / (1 << z)
    return (-180.0 + x * size, -90.0 + y * size, -180.0 + (x + 1) * size, -90.0 + (y + 1) * size)


def tms_geographic_range(z: int, bounds: tuple[float, float, float, float]
                         ) -> tuple[int, int, int, int]:
    """``(x0, y0, x1, y1)`` inclusive tiles of level ``z`` touching ``bounds``."""
    size = 180.0 / (1 << z)
    w, s, e, n = bounds
    x0 = max(0, math.floor((w + 180.0) / size))
    x1 = min((2 << z) - 1, math.floor((e + 180.0) / size - 1e-12))
    y0 = max(0, math.floor((s + 90.0) / size))
    y1 = min((1 << z) - 1, math.floor((n + 90.0) / size - 1e-12))
    return x0, y0, x1, y1


def mercator_tile_lonlat(z: int, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Longitude/latitude of fractional XYZ (Web Mercator, y from the north) tile coordinates."""
    n = float(1 << z)
    lon = np.asarray(x, np.float64) / n * 360.0 - 180.0
    lat = np.degrees(np.arctan(np.sinh(np.pi * (1.0 - 2.0 * np.asarray(y, np.float64) / n))))
    return lon, lat


def mercator_tile_range(z: int, bounds: tuple[float, float, float, float]
                        ) -> tuple[int, int, int, int]:
    """``(x0, y0, x1, y1)`` inclusive XYZ tiles of zoom ``z`` touching ``bounds``."""
    n = 1 << z
    w, s, e, nth = bounds

    def tx(lon: float) -> float:
        return (lon + 180.0) / 360.0 * n

    def ty(lat: float) -> float:
        phi = math.radians(max(-85.05112878, min(85.05112878, lat)))
        return (1.0 - math.asinh(math.tan(phi)) / math.pi) / 2.0 * n

    x0, x1 = math.floor(tx(w)), math.floor(tx(e) - 1e-12)
    y0, y1 = math.floor(ty(nth)), math.floor(ty(s) - 1e-12)
    return max(0, x0), max(0, y0), min(n - 1, x1), min(n - 1, y1)
