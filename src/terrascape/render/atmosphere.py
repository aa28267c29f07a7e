"""Frame constants of the daylight look: sky model, sun disc, aerial perspective, exposure,
surround and water (uniforms of ``shaders/common/atmosphere.glsl``, ``lighting.glsl``,
``water.glsl``). No OpenGL here: :class:`~terrascape.render.terrain.TerrainRenderer` uploads
what these functions return.
"""

from __future__ import annotations

import functools
import math
import warnings
from collections.abc import Mapping
from typing import Any

import numpy as np

from terrascape._validate import check_positive, check_range
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.lighting.daylight import Daylight, daylight, srgb_to_linear

SURROUNDS = {"fade": 0, "plane": 1, "sea": 2}
# Haze ratios R:G:B of the extinction (small aerosols and air: blue scatters most).
_HAZE_RGB = np.array([0.55, 0.75, 1.0])
# Drawn radius of the sun's disc (degrees): the real 0.27°, a few pixels in a 1280×720 view.
SUN_DISC_RADIUS = 0.3


class WaterLevelWarning(UserWarning):
    """The sea level lies above or below the whole terrain (water everywhere or nowhere)."""


@functools.lru_cache(maxsize=64)
def cached_daylight(az: float, el: float, turbidity: float, exposure: float) -> Daylight:
    return daylight(az, el, turbidity=turbidity, exposure=exposure)


def sea_level_note(heightmap: Heightmap, sea_level: float | None) -> str | None:
    """A one-line note when ``sea_level`` floods or misses the whole terrain, else None."""
    if sea_level is None:
        return None
    lo, hi = heightmap.min, heightmap.max
    if sea_level <= lo:
        return (f"sea level {sea_level:g} is below the whole terrain (heights {lo:g} to "
                f"{hi:g}): no water on the terrain")
    if sea_level >= hi:
        return (f"sea level {sea_level:g} is above the whole terrain (heights {lo:g} to "
                f"{hi:g}): everything is under water")
    return None


def resolve_surround(params: Mapping[str, Any]) -> str:
    surround = params.get("surround")
    if surround is None:
        # Without a sea, haze: past the edge the land melts into the horizon (a flat plane
        # reads as a slab under the mountains; --surround plane still draws one).
        return "sea" if params.get("sea_level") is not None else "fade"
    if surround not in SURROUNDS:
        raise InvalidParameterError(
            f"surround must be one of {', '.join(SURROUNDS)}, got {surround!r}")
    return surround


def daylight_uniforms(
    world: Heightmap, params: Mapping[str, Any], *, edge_albedo: np.ndarray,
    exaggeration: float,
) -> dict[str, Any]:
    """Uniforms of one daylight frame for the exaggerated terrain ``world``."""
    az, el = (float(v) for v in params["sun"])
    turbidity = check_range(params["turbidity"], "turbidity", 1.7, 10.0)
    ev = check_range(params["exposure"], "exposure (EV)", -10.0, 10.0)
    day = cached_daylight(az, el, turbidity, ev)
    u = day.uniforms()
    u["u_perez"] = np.concatenate([u.pop("u_perez_Y"), u.pop("u_perez_x"), u.pop("u_perez_y")])
    u["u_sky_sun_dir"] = tuple(day.sun_dir if el >= 0.5 else _model_dir(az))
    if el <= 0.0:
        u["u_sun_irradiance"] = (0.0, 0.0, 0.0)  # below the horizon: sky light only
    sun = np.asarray(day.sun_irradiance)
    # The disc: the sun's colour at a brightness the tone curve keeps a little below white.
    u["u_sun_radiance"] = tuple(sun / max(float(sun.max()), 1e-9) * 6.0 / day.exposure
                                * (el > -0.5))
    u["u_sun_cos_radius"] = math.cos(math.radians(SUN_DISC_RADIUS))
    ex, ez = world.extent
    diag = math.sqrt(ex * ex + ez * ez + (world.max - world.min) ** 2)
    haze = params["haze"]
    if haze is None:
        # Optical depth 0.2 (green) over one terrain diagonal at the terrain's base.
        haze = 0.2 / diag
    haze = check_positive(haze, "haze", allow_zero=True)
    u["u_haze_beta"] = tuple(_HAZE_RGB / _HAZE_RGB[1] * haze)
    u["u_haze_base"] = world.min
    u["u_haze_height"] = max(world.max - world.min, 0.02 * diag, 1e-6)
    surround = resolve_surround(params)
    sea = params.get("sea_level")
    u["u_surround"] = SURROUNDS[surround]
    u["u_surround_albedo"] = tuple(edge_albedo)
    sea_world = world.min - 1.0 if sea is None else float(sea) * exaggeration
    u["u_sea_level"] = sea_world
    u["u_surround_height"] = sea_world if surround == "sea" else world.min
    relief = max(world.max - world.min, 1e-6)
    u["u_water_extinction"] = tuple(np.array([2.4, 0.9, 0.6]) / (0.06 * relief))
    u["u_foam_depth"] = 0.006 * relief
    u["u_shelf_slope"] = relief / (0.05 * diag)
    u["u_wave_length"] = max(0.004 * diag, 1e-6)
    u["u_height_extent"] = (ex, ez)
    u["u_time"] = float(params.get("time") or 0.0)
    # Techniques whose own shadowed branch uses the Phong ambient term (relief family):
    # make it the sky light, in the same units as the daylight radiance.
    # (u_ka stays the technique's parameter, 0.35 by default.)
    u["u_ambient_color"] = tuple(np.asarray(day.sky_irradiance) / math.pi * 0.7)
    return u


def _model_dir(az: float) -> np.ndarray:
    from terrascape.lighting.sun import sun_direction

    return sun_direction(az, 0.5)


def edge_albedo(heightmap: Heightmap, seed: int = 0) -> np.ndarray:
    """Linear albedo of the terrain's border (median of the default region texture there):
    the colour of the plane that continues the terrain beyond its edge."""
    from terrascape.texture import region_texture

    step = max(1, math.ceil(max(heightmap.shape) / 129))
    dx, dz = heightmap.spacing
    small = Heightmap(np.ascontiguousarray(heightmap.heights[::step, ::step]),
                      (dx * step, dz * step))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tex = region_texture(small, seed=seed).astype(np.float64) / 255.0
    border = np.concatenate([tex[0], tex[-1], tex[:, 0], tex[:, -1]])
    # Texels painted as water (blue above red and green) are not ground: the sea is drawn
    # as water; the plane continues the land.
    land = border[~((border[:, 2] > border[:, 0]) & (border[:, 2] > border[:, 1]))]
    if len(land) == 0:
        land = tex.reshape(-1, 3)
    return srgb_to_linear(np.median(land, axis=0))


__all__ = [
    "SURROUNDS",
    "WaterLevelWarning",
    "daylight_uniforms",
    "edge_albedo",
    "resolve_surround",
    "sea_level_note",
]
