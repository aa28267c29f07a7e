"""Web-map elevation tiles: Mapbox Terrain-RGB or Terrarium PNGs in an XYZ pyramid (EPSG:3857).

Every 256 × 256 tile samples the map bilinearly at its pixel centres (the heights are resampled
first, then encoded — never the other way round), and encodes them as

* Terrain-RGB (``--format mapbox``, default): ``h = −10000 + (R·65536 + G·256 + B) · 0.1``
  (0.1 m steps, rounded);
* Terrarium (``--format terrarium``): ``h = R·256 + G + B/256 − 32768`` (1/256 m steps,
  truncated).

Pixels outside the data are transparent (alpha 0, height 0). Tiles go to ``{z}/{x}/{y}.png``
(XYZ: ``y`` from the north), levels 0 up to the first one whose pixels are as small as the
map's samples. MapLibre/Mapbox GL read them as a ``raster-dem`` source with ``encoding``
``mapbox`` or ``terrarium``.

References
----------
Mapbox, "Terrain-RGB v1"; Mapzen/AWS Terrain Tiles, "Terrarium format".
"""

from __future__ import annotations

import io
import json
import math
from pathlib import Path

import numpy as np
from PIL import Image

from terrascape.errors import InvalidParameterError
from terrascape.export._common import (
    ExportOptions,
    check_out_dir,
    one_unit,
    write_bytes,
    write_text,
)
from terrascape.export._geo import GeoGrid, geo_grid, mercator_tile_lonlat, mercator_tile_range
from terrascape.heightmap import Heightmap

NAME = "terrain_rgb"
SUMMARY = "Terrain-RGB (Mapbox) or Terrarium PNG tiles, XYZ Web Mercator pyramid."
TILE = 256
FORMATS = ("mapbox", "terrarium")
_EARTH_CIRCUMFERENCE = 2 * math.pi * 6378137.0


def encode_mapbox(heights: np.ndarray) -> np.ndarray:
    """uint8 ``(…, 3)`` Terrain-RGB codes of ``heights`` (metres, −10000 … 1667721.5)."""
    v = np.rint((np.asarray(heights, np.float64) + 10000.0) * 10.0)
    if v.min() < 0 or v.max() > 2**24 - 1:
        raise InvalidParameterError("heights outside Terrain-RGB's −10000 … 1667721 m")
    v = v.astype(np.int64)
    return np.stack([(v >> 16) & 255, (v >> 8) & 255, v & 255], axis=-1).astype(np.uint8)


def encode_terrarium(heights: np.ndarray) -> np.ndarray:
    """uint8 ``(…, 3)`` Terrarium codes of ``heights`` (metres, −32768 … 32767)."""
    v = np.asarray(heights, np.float64) + 32768.0
    if v.min() < 0 or v.max() >= 65536:
        raise InvalidParameterError("heights outside Terrarium's −32768 … 32767 m")
    whole = np.floor(v)
    return np.stack([whole // 256, whole % 256, np.floor((v - whole) * 256)],
                    axis=-1).astype(np.uint8)


def finest_zoom(grid: GeoGrid) -> int:
    """First zoom whose pixels (at the map's centre latitude) are ≤ the map's sample size."""
    _, s, _, n = grid.bounds
    lat = math.radians((s + n) / 2)
    _, mz = grid.metres_per_degree()
    sample = grid.dlat * mz
    pixel0 = _EARTH_CIRCUMFERENCE * math.cos(lat) / TILE
    return max(0, math.ceil(math.log2(pixel0 / sample)))


def tile_heights(grid: GeoGrid, z: int, x: int, y: int) -> tuple[np.ndarray, np.ndarray]:
    """Heights at the 256 × 256 pixel centres of XYZ tile ``z/x/y`` and the inside mask."""
    t = (np.arange(TILE) + 0.5) / TILE
    lon, lat = mercator_tile_lonlat(z, x + t[None, :], y + t[:, None])
    lon, lat = np.broadcast_arrays(lon, lat)
    return grid.sample(lon, lat)


@one_unit
def export(heightmap: Heightmap, out_dir, options: ExportOptions) -> list[Path]:
    out = check_out_dir(out_dir)
    fmt = options.format or "mapbox"
    if fmt not in FORMATS:
        raise InvalidParameterError(f"terrain_rgb --format must be mapbox or terrarium, "
                                    f"got {fmt!r}")
    encoder = encode_mapbox if fmt == "mapbox" else encode_terrarium
    grid = geo_grid(heightmap, options.lonlat)
    top = finest_zoom(grid) if options.max_zoom is None else options.max_zoom
    bottom = options.min_zoom or 0
    if bottom > top:
        raise InvalidParameterError(f"--min-zoom {bottom} is above --max-zoom {top}")
    written: list[Path] = []
    for z in range(bottom, top + 1):
        x0, y0, x1, y1 = mercator_tile_range(z, grid.bounds)
        for x in range(x0, x1 + 1):
            for y in range(y0, y1 + 1):
                h, inside = tile_heights(grid, z, x, y)
                rgba = np.zeros((TILE, TILE, 4), np.uint8)
                rgba[..., :3] = encoder(np.where(inside, h, 0.0))
                rgba[..., 3] = np.where(inside, 255, 0)
                buf = io.BytesIO()
                Image.fromarray(rgba, "RGBA").save(buf, format="PNG")
                path = out / str(z) / str(x) / f"{y}.png"
                path.parent.mkdir(parents=True, exist_ok=True)
                written.append(write_bytes(path, buf.getvalue(), force=options.force))
    w, s, e, n = grid.bounds
    tilejson = {
        "tilejson": "2.2.0", "name": options.name, "scheme": "xyz",
        "tiles": ["{z}/{x}/{y}.png"], "minzoom": bottom, "maxzoom": top,
        "bounds": [w, s, e, n], "encoding": fmt, "tileSize": TILE,
    }
    written.append(write_text(out / "tiles.json", json.dumps(tilejson, indent=1) + "\n",
                              force=options.force))
    formula = ("h = -10000 + (R*65536 + G*256 + B) * 0.1" if fmt == "mapbox"
               else "h = R*256 + G + B/256 - 32768")
    note = [
        f"{'Terrain-RGB' if fmt == 'mapbox' else 'Terrarium'} tiles for {options.name} "
        "(written by terrascape)",
        "",
        f"XYZ Web Mercator, {TILE} px, zoom {bottom} … {top}; {formula}",
        f"bounds lon {w:.8g} … {e:.8g}, lat {s:.8g} … {n:.8g}; outside the data alpha = 0",
        "MapLibre GL: map.addSource('dem', {type: 'raster-dem', tiles: "
        f"['http://HOST/PATH/{{z}}/{{x}}/{{y}}.png'], tileSize: {TILE}, encoding: '{fmt}', "
        f"maxzoom: {top}}}); map.setTerrain({{source: 'dem'}});",
    ]
    written.append(write_text(out / f"{options.name}_import.txt", "\n".join(note) + "\n",
                              force=options.force))
    return written
