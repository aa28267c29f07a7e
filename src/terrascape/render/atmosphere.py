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
from terrascape.lighting.daylight import Daylight, daylight, srgb_to_linear, sun_transmittance
from terrascape.lighting.night_sky import (
    NIGHT_TINT,
    SUN_RADIUS,
    SkyLight,
    moon_phase_factor,
    sky_light,
    sun_disc_fraction,
)
from terrascape.lighting.solar_position import celestial_rotation
from terrascape.lighting.sun import sun_direction

SURROUNDS = {"fade": 0, "plane": 1, "sea": 2}
# Haze ratios R:G:B of the extinction (small aerosols and air: blue scatters most).
_HAZE_RGB = np.array([0.55, 0.75, 1.0])
# Drawn radius of the sun's disc (degrees): the real 0.27°, a few pixels in a 1280×720 view.
SUN_DISC_RADIUS = 0.3
# The moon's disc, drawn a little larger than its real 0.26° so its phase reads.
MOON_DISC_RADIUS = 0.6
# Sky radiance table: azimuth × elevation texels (one texture fetch per sky pixel).
SKY_LUT_WIDTH = 128
SKY_LUT_HEIGHT = 48
# The stars of a render without a date: sidereal time 0 h at 45° north.
_DEFAULT_CELESTIAL = celestial_rotation(45.0, 0.0)


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


def _sky_inputs(params: Mapping[str, Any]) -> tuple:
    """(sun az, sun el, moon az, moon el, moon lit fraction, turbidity, EV) of a frame: from
    ``params["sky_state"]`` (a :class:`~terrascape.lighting.solar_position.SkyState`) when
    given, else the ``sun`` parameter and no moon."""
    state = params.get("sky_state")
    turbidity = check_range(params["turbidity"], "turbidity", 1.7, 10.0)
    ev = check_range(params["exposure"], "exposure (EV)", -10.0, 10.0)
    if state is not None:
        return (round(float(state.sun_azimuth), 6), round(float(state.sun_elevation), 6),
                round(float(state.moon_azimuth), 6), round(float(state.moon_elevation), 6),
                round(float(state.moon_illumination), 6), float(turbidity), float(ev))
    az, el = (float(v) for v in params["sun"])
    return (az, el, None, None, 0.0, float(turbidity), float(ev))


@functools.lru_cache(maxsize=64)
def _cached_sky_light(az, el, moon_az, moon_el, moon_k, turbidity, ev) -> SkyLight:
    return sky_light(az, el, moon_azimuth=moon_az, moon_elevation=moon_el,
                     moon_illumination=moon_k, turbidity=turbidity, exposure=ev)


def frame_sky_light(params: Mapping[str, Any]) -> SkyLight:
    """The :class:`~terrascape.lighting.night_sky.SkyLight` of a frame's parameters."""
    return _cached_sky_light(*_sky_inputs(params))


def key_light(params: Mapping[str, Any]) -> tuple[float, float]:
    """(azimuth, elevation) of the light that casts the terrain's shadows in a daylight
    frame: the sun while it is up, else the moon (negative elevation: no direct light)."""
    light = frame_sky_light(params)
    if light.key == "moon":
        return float(light.moon_azimuth), float(light.moon_elevation)
    if light.key == "none":
        return light.sun_azimuth, min(light.sun_elevation, -1.0)
    return light.sun_azimuth, light.sun_elevation


def _lut_directions(width: int, height: int) -> np.ndarray:
    """World directions of the sky LUT's texel centres: columns are azimuths j/W·360°
    (clockwise from north), rows elevations 90°·(i/(H-1))² (dense near the horizon)."""
    az = np.radians(np.arange(width) * (360.0 / width))
    el = np.radians(90.0 * (np.arange(height) / (height - 1)) ** 2)
    ee, aa = np.meshgrid(el, az, indexing="ij")
    return np.stack([np.sin(aa) * np.cos(ee), np.sin(ee), -np.cos(aa) * np.cos(ee)], axis=-1)


@functools.lru_cache(maxsize=8)
def _sky_lut(inputs: tuple, width: int, height: int) -> np.ndarray:
    light = _cached_sky_light(*inputs)
    rad = light.sky_radiance(_lut_directions(width, height))
    return np.ascontiguousarray(rad, dtype=np.float32)


def sky_lut(params: Mapping[str, Any]) -> np.ndarray:
    """The sky's radiance (linear RGB, kcd/m²) as a ``(SKY_LUT_HEIGHT, SKY_LUT_WIDTH, 3)``
    float32 table over azimuth × elevation, which the shaders sample instead of evaluating
    the sky model per pixel (``sky_radiance`` in ``common/atmosphere.glsl``)."""
    return _sky_lut(_sky_inputs(params), SKY_LUT_WIDTH, SKY_LUT_HEIGHT)


def sky_lut_key(params: Mapping[str, Any]) -> tuple:
    """What the sky LUT depends on (rebuilt only when it changes)."""
    return _sky_inputs(params)


def daylight_uniforms(
    world: Heightmap, params: Mapping[str, Any], *, edge_albedo: np.ndarray,
    exaggeration: float,
) -> dict[str, Any]:
    """Uniforms of one daylight frame for the exaggerated terrain ``world``."""
    light = frame_sky_light(params)
    day = light.day
    az, el = light.sun_azimuth, light.sun_elevation
    u = day.uniforms()
    u["u_perez"] = np.concatenate([u.pop("u_perez_Y"), u.pop("u_perez_x"), u.pop("u_perez_y")])
    u["u_sky_sun_dir"] = tuple(day.sun_dir)
    # Direct light: the sun, or the moon at night (the frame's u_sun_dir is the sun's).
    u["u_sun_dir"] = tuple(light.key_direction)
    u["u_sun_irradiance"] = tuple(light.key_irradiance)
    u["u_sky_irradiance"] = tuple(light.sky_irradiance)
    u["u_ground_irradiance"] = tuple(day.ground_albedo * light.ground_irradiance())
    u["u_exposure"] = light.exposure
    u["u_night_desaturation"] = light.desaturation
    sun = np.asarray(day.sun_irradiance)
    # The disc: the sun's colour at a brightness the tone curve keeps a little below white.
    u["u_sun_radiance"] = tuple(sun / max(float(sun.max()), 1e-9) * 6.0 / light.exposure
                                * sun_disc_fraction(el))
    u["u_sun_cos_radius"] = math.cos(math.radians(SUN_DISC_RADIUS))
    u["u_true_sun_dir"] = tuple(sun_direction(az, el))
    u.update(_night_uniforms(light, params))
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
    u["u_ambient_color"] = tuple(np.asarray(light.sky_irradiance) / math.pi * 0.7)
    return u


def _night_uniforms(light: SkyLight, params: Mapping[str, Any]) -> dict[str, Any]:
    """The moon's disc and the stars (``sky.glsl``)."""
    state = params.get("sky_state")
    if state is not None:
        to_celestial = state.celestial_to_horizon().T
    else:
        # No date: the stars of a fixed sidereal time at 45° north.
        to_celestial = _DEFAULT_CELESTIAL.T
    u: dict[str, Any] = {"u_to_celestial": to_celestial}
    moon_up = light.moon_elevation is not None and light.moon_elevation > -SUN_RADIUS
    if moon_up:
        m = sun_direction(float(light.moon_azimuth), float(light.moon_elevation))
        trans = sun_transmittance(max(float(light.moon_elevation), 0.5), light.day.turbidity)
        colour = trans / trans.max() * NIGHT_TINT / NIGHT_TINT.max()
        # Like the sun's disc: bright, a little below white after the tone curve; dimmed by
        # day (the daytime moon is pale against the blue sky).
        u["u_moon_dir"] = tuple(m)
        u["u_moon_radiance"] = tuple(colour * 2.5 / light.exposure)
        u["u_moon_illumination"] = light.moon_illumination
    else:
        u["u_moon_dir"] = (0.0, -1.0, 0.0)
        u["u_moon_radiance"] = (0.0, 0.0, 0.0)
        u["u_moon_illumination"] = 0.0
    u["u_moon_cos_radius"] = math.cos(math.radians(MOON_DISC_RADIUS))
    # Stars: display-relative brightness (the brightest a little below white), faded in
    # with the twilight and washed out by a bright moon.
    moon_wash = moon_phase_factor(light.moon_illumination) if moon_up else 0.0
    u["u_star_radiance"] = light.star_visibility * (1.0 - 0.7 * moon_wash) * 3.0 / light.exposure
    u["u_star_seed"] = int(params.get("seed", 0)) & 0x7FFFFFFF
    return u


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
    "frame_sky_light",
    "key_light",
    "resolve_surround",
    "sea_level_note",
    "sky_lut",
    "sky_lut_key",
]
