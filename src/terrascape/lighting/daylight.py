"""Daylight: sun, sky and bounce light of a clear day, exposure and filmic tone mapping.

One model for the CPU lightmap and the GPU renderer (``shaders/common/lighting.glsl`` and
``shaders/common/atmosphere.glsl`` evaluate the same formulas from :meth:`Daylight.uniforms`):

* **Sky** — Preetham, Shirley & Smits' analytic clear sky: the Perez distribution
  ``F(θ, γ) = (1 + A·e^(B/cos θ))·(1 + C·e^(D·γ) + E·cos² γ)`` for luminance ``Y`` and the
  chromaticities ``x, y``, scaled to the zenith values that depend on the turbidity ``T`` and
  the sun's zenith angle ``θs``: ``Y(θ, γ) = Y_z·F(θ, γ) / F(0, θs)`` (kcd/m²); ``Yxy`` is
  converted to linear sRGB. ``e^(B/cos θ)`` and all its derivatives vanish at the horizon,
  so the sky continues below it with the horizon value without a crease.
* **Sun** — extraterrestrial illuminance 127 klx attenuated along the Kasten–Young air mass by
  Rayleigh and Ångström aerosol optical depths at 680/550/440 nm (aerosol β from the same
  turbidity as the sky): a low sun is dimmer and red, as in the sky model.
* **White balance** — the camera is balanced for the overhead sun (its colour after one air
  mass is neutral), so a midday sun is white and shadows lit by the sky are blue.
* **Surface** — irradiance ``E = E_sun·max(N·L, 0)·v_sun + E_sky·(1 + N_y)/2·v_sky + ρ_g·
  E_ground·((1 - N_y)/2 + (1 - v_sky)·(1 + N_y)/2)``: direct sun times the visible fraction
  of the sun's disc (soft shadow), sky light over the visible sky (sky-view factor), and one
  bounce from the terrain that hides the sky or lies below the surface. A Lambertian surface
  of albedo ``a`` has radiance ``a·E/π``.
* **Display** — ``exposure`` (automatic: a white surface facing a sun ≥ 20° high maps to 1),
  Narkowicz's ACES fit ``x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14)`` and the sRGB transfer
  curve: highlights roll off instead of clipping.

References
----------
.. [1] A. J. Preetham, P. Shirley, B. Smits, "A Practical Analytic Model for Daylight",
   SIGGRAPH 1999.
.. [2] F. Kasten, A. T. Young, "Revised optical air mass tables and approximation formula",
   Applied Optics 28(22), 1989.
.. [3] K. Narkowicz, "ACES Filmic Tone Mapping Curve", 2015 (blog post).
.. [4] R. Perez, R. Seals, J. Michalsky, "All-weather model for sky luminance
   distribution", Solar Energy 50(3), 1993.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from terrascape._stoppable import for_each_band, run_stoppable
from terrascape._validate import check_range
from terrascape.errors import InvalidParameterError
from terrascape.lighting.sun import sun_direction

# Extraterrestrial solar illuminance (klx) and the optical depths per air mass at the three
# wavelengths standing for R, G, B (µm): Rayleigh (Bucholtz' fit) + aerosol (Ångström 1.3).
SOLAR_ILLUMINANCE = 127.0
_WAVELENGTHS = np.array([0.680, 0.550, 0.440])
# XYZ → linear sRGB (D65).
_XYZ_TO_RGB = np.array(
    [[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]]
)
_LUMA = np.array([0.2126, 0.7152, 0.0722])
# Preetham's chromaticity fit drifts below the Planckian locus (magenta) toward the horizon;
# keeping y >= x + this (0.01) keeps the low sky neutral to blue after the white balance.
_MAGENTA_GUARD = 0.01
# Below this the sun model is evaluated at the horizon (the Preetham fit is for a sun above).
MIN_SUN_ELEVATION = 0.5

# The lightmap's float64 RGB steps run a band of rows at a time, about this many samples
# (3 MB per float64 RGB temporary): on the whole map they held 165 bytes a sample.
_BAND_SAMPLES = 1 << 17
# Maps above this many samples are lit on the worker thread (Ctrl-C stops them between two
# bands) with the bands shared among the numba threads (numpy's loops release the GIL).
_LONG_SAMPLES = 1 << 20


def _rayleigh_depth(lam: np.ndarray) -> np.ndarray:
    return 0.008569 * lam**-4 * (1.0 + 0.0113 * lam**-2 + 0.00013 * lam**-4)


def _aerosol_depth(lam: np.ndarray, turbidity: float) -> np.ndarray:
    beta = 0.04608 * turbidity - 0.04586  # Preetham's turbidity → Ångström β
    return beta * lam**-1.3


def air_mass(elevation_deg: float) -> float:
    """Relative optical air mass toward a sun at ``elevation_deg`` (Kasten & Young 1989)."""
    el = max(float(elevation_deg), 0.0)
    z = 90.0 - el
    return 1.0 / (math.cos(math.radians(z)) + 0.50572 * (96.07995 - z) ** -1.6364)


def sun_transmittance(elevation_deg: float, turbidity: float = 3.0) -> np.ndarray:
    """RGB share of sunlight that reaches the ground (Rayleigh + aerosol extinction)."""
    tau = _rayleigh_depth(_WAVELENGTHS) + _aerosol_depth(_WAVELENGTHS, turbidity)
    return np.exp(-tau * air_mass(elevation_deg))


def _perez_coefficients(turbidity: float) -> np.ndarray:
    """Rows Y, x, y; columns A..E (Preetham et al. 1999, appendix A.2)."""
    t = turbidity
    return np.array([
        [0.1787 * t - 1.4630, -0.3554 * t + 0.4275, -0.0227 * t + 5.3251,
         0.1206 * t - 2.5771, -0.0670 * t + 0.3703],
        [-0.0193 * t - 0.2592, -0.0665 * t + 0.0008, -0.0004 * t + 0.2125,
         -0.0641 * t - 0.8989, -0.0033 * t + 0.0452],
        [-0.0167 * t - 0.2608, -0.0950 * t + 0.0092, -0.0079 * t + 0.2102,
         -0.0441 * t - 1.6537, -0.0109 * t + 0.0529],
    ])  # fmt: skip


def _zenith(turbidity: float, theta_s: float) -> np.ndarray:
    """Zenith luminance (kcd/m²) and chromaticity ``(Y, x, y)`` (Preetham et al., A.2)."""
    t = turbidity
    chi = (4.0 / 9.0 - t / 120.0) * (math.pi - 2.0 * theta_s)
    lum = (4.0453 * t - 4.9710) * math.tan(chi) - 0.2155 * t + 2.4192
    th = np.array([theta_s**3, theta_s**2, theta_s, 1.0])
    mx = np.array([[0.00166, -0.00375, 0.00209, 0.0],
                   [-0.02903, 0.06377, -0.03202, 0.00394],
                   [0.11693, -0.21196, 0.06052, 0.25886]])  # fmt: skip
    my = np.array([[0.00275, -0.00610, 0.00317, 0.0],
                   [-0.04214, 0.08970, -0.04153, 0.00516],
                   [0.15346, -0.26756, 0.06670, 0.26688]])  # fmt: skip
    tt = np.array([t * t, t, 1.0])
    return np.array([max(lum, 0.05), tt @ mx @ th, tt @ my @ th])


def _perez(coef: np.ndarray, cos_theta: np.ndarray, gamma: np.ndarray) -> np.ndarray:
    a, b, c, d, e = (coef[..., k, None] for k in range(5))
    # exp(B / cos θ) → 0 with every derivative at the horizon: clamping cos θ at a tiny
    # positive value continues the sky below it smoothly.
    ct = np.maximum(cos_theta, 1e-4)
    return (1.0 + a * np.exp(b / ct)) * (1.0 + c * np.exp(d * gamma) + e * np.cos(gamma) ** 2)


def aces_filmic(x: Any) -> np.ndarray:
    """Narkowicz's fit of the ACES filmic curve, clamped to [0, 1] (linear in, linear out)."""
    x = np.maximum(np.asarray(x, dtype=np.float64), 0.0)
    return np.clip(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)


def linear_to_srgb(x: Any) -> np.ndarray:
    """sRGB transfer curve (IEC 61966-2-1) of linear values in [0, 1]."""
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def srgb_to_linear(x: Any) -> np.ndarray:
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


@dataclass(frozen=True)
class Daylight:
    """Sun and sky of a clear day for one sun position (build with :func:`daylight`).

    Colours are linear sRGB, white-balanced for the overhead sun; irradiances in klx, sky
    radiance in kcd/m² (so a Lambertian surface's radiance ``albedo·E/π`` is comparable).
    """

    sun_dir: np.ndarray  # unit vector toward the sun
    sun_elevation: float
    turbidity: float
    sun_irradiance: np.ndarray  # RGB at normal incidence
    sky_irradiance: np.ndarray  # RGB on a horizontal surface, whole sky visible
    white_balance: np.ndarray
    perez: np.ndarray  # (3, 5)
    zenith: np.ndarray  # Y, x, y
    exposure: float
    ground_albedo: float

    def sky_radiance(self, directions: Any) -> np.ndarray:
        """Sky radiance (RGB, kcd/m², white-balanced) seen along unit ``directions`` (..., 3)."""
        d = np.asarray(directions, dtype=np.float64)
        shape = d.shape[:-1]
        d = d.reshape(-1, 3)
        d = d / np.linalg.norm(d, axis=1, keepdims=True)
        cos_theta = d[:, 1]
        gamma = np.arccos(np.clip(d @ self.sun_dir, -1.0, 1.0))
        theta_s = math.acos(max(self.sun_dir[1], math.sin(math.radians(MIN_SUN_ELEVATION))))
        f = _perez(self.perez, cos_theta[None, :], gamma[None, :])
        f0 = _perez(self.perez, np.ones((1, 1)), np.full((1, 1), theta_s))
        yxy = self.zenith[:, None] * f / f0
        lum, x, y = yxy
        y = np.maximum(np.maximum(y, x + _MAGENTA_GUARD), 1e-4)
        xyz = np.stack([x * lum / y, lum, (1.0 - x - y) * lum / y], axis=1)
        rgb = np.maximum(xyz @ _XYZ_TO_RGB.T, 0.0) * self.white_balance
        return rgb.reshape(*shape, 3)

    def surface_irradiance(
        self, normals: Any, sun_visibility: Any = 1.0, sky_visibility: Any = 1.0
    ) -> np.ndarray:
        """Irradiance (RGB, klx) on surfaces with unit ``normals`` (..., 3) (module docstring)."""
        n = np.asarray(normals, dtype=np.float64)
        vs = np.asarray(sun_visibility, dtype=np.float64)[..., None]
        vk = np.asarray(sky_visibility, dtype=np.float64)[..., None]
        ndotl = np.maximum(n @ self.sun_dir, 0.0)[..., None]
        up = 0.5 + 0.5 * n[..., 1:2]
        ground = self.ground_albedo * self.ground_irradiance()
        return (self.sun_irradiance * ndotl * vs + self.sky_irradiance * up * vk
                + ground * ((1.0 - up) + (1.0 - vk) * up))

    def ground_irradiance(self) -> np.ndarray:
        """Irradiance of open, flat, sunlit ground (the light the bounce term reflects)."""
        return self.sun_irradiance * max(self.sun_dir[1], 0.0) + self.sky_irradiance

    def display(self, radiance: Any) -> np.ndarray:
        """Exposure, ACES tone map and sRGB encoding of linear radiance: values in [0, 1]."""
        return linear_to_srgb(aces_filmic(np.asarray(radiance) * self.exposure))

    def uniforms(self) -> dict[str, Any]:
        """The model's constants under the GLSL names of ``common/atmosphere.glsl``."""
        theta_s = math.acos(max(self.sun_dir[1], math.sin(math.radians(MIN_SUN_ELEVATION))))
        f0 = _perez(self.perez, np.ones((1, 1)), np.full((1, 1), theta_s))[:, 0]
        return {
            "u_sun_irradiance": tuple(self.sun_irradiance),
            "u_sky_irradiance": tuple(self.sky_irradiance),
            "u_ground_irradiance": tuple(self.ground_albedo * self.ground_irradiance()),
            "u_white_balance": tuple(self.white_balance),
            "u_perez_Y": tuple(self.perez[0]),
            "u_perez_x": tuple(self.perez[1]),
            "u_perez_y": tuple(self.perez[2]),
            # zenith value / F(0, θs) per channel: the sky is zenith·F(θ, γ)/F(0, θs)
            "u_sky_zenith": tuple(self.zenith / f0),
            "u_exposure": self.exposure,
        }


def daylight(
    sun_azimuth: float,
    sun_elevation: float,
    *,
    turbidity: float = 3.0,
    exposure: float = 0.0,
    ground_albedo: float = 0.2,
) -> Daylight:
    """Sun and sky for a sun position.

    Parameters
    ----------
    sun_azimuth, sun_elevation
        Degrees (clockwise from north; above the horizon). Below ``0.5°`` the sun and sky
        are evaluated at 0.5° (dusk light); the direction stays the given one.
    turbidity
        Haze of the atmosphere, 1.7 (very clear) to 10 (hazy); 2–3 is a clear day.
    exposure
        Exposure correction in stops (EV) on top of the automatic exposure.
    ground_albedo
        Mean reflectance of the terrain for the bounce light.
    """
    el = check_range(sun_elevation, "sun elevation (degrees)", -90.0, 90.0)
    t = check_range(turbidity, "turbidity", 1.7, 10.0)
    ev = check_range(exposure, "exposure (EV)", -10.0, 10.0)
    rho = check_range(ground_albedo, "ground_albedo", 0.0, 1.0)
    el_model = max(el, MIN_SUN_ELEVATION)
    direction = sun_direction(sun_azimuth, el)
    model_dir = sun_direction(sun_azimuth, el_model)
    trans = sun_transmittance(el_model, t)
    noon = sun_transmittance(90.0, t)
    wb = (noon @ _LUMA) / noon
    sun_e = SOLAR_ILLUMINANCE * trans * wb
    partial = Daylight(model_dir, el_model, t, sun_e, np.zeros(3), wb,
                       _perez_coefficients(t), _zenith(t, math.radians(90.0 - el_model)), 1.0,
                       rho)
    # Sky irradiance on a horizontal surface: ∫ L cos θ dω over the hemisphere (midpoint rule).
    n_t, n_p = 24, 48
    th = (np.arange(n_t) + 0.5) * (0.5 * math.pi / n_t)
    ph = (np.arange(n_p) + 0.5) * (2.0 * math.pi / n_p)
    tt, pp = np.meshgrid(th, ph, indexing="ij")
    dirs = np.stack([np.sin(tt) * np.sin(pp), np.cos(tt), -np.sin(tt) * np.cos(pp)], axis=-1)
    rad = partial.sky_radiance(dirs)
    weight = (np.cos(tt) * np.sin(tt))[..., None] * (0.5 * math.pi / n_t) * (2 * math.pi / n_p)
    sky_e = (rad * weight).sum(axis=(0, 1))
    # Automatic exposure: white paper facing the sun (at least 20° of it) maps to 1.
    ref = (sun_e @ _LUMA) * max(math.sin(math.radians(el_model)), math.sin(math.radians(20.0)))
    ref = (ref + sky_e @ _LUMA) / math.pi
    exposure_value = 2.0**ev / max(ref, 1e-6)
    if not np.isfinite(sky_e).all():  # pragma: no cover - guarded by the clamps above
        raise InvalidParameterError("sky model produced a non-finite irradiance")
    return Daylight(direction, el, t, sun_e, sky_e, wb, partial.perez, partial.zenith,
                    exposure_value, rho)


def daylight_lightmap(
    heightmap: Any,
    sun_azimuth: float,
    sun_elevation: float,
    *,
    shadows: bool = True,
    sun_radius_deg: float = 0.5,
    shadow_samples: int = 8,
    sky_visibility: Any = None,
    turbidity: float = 3.0,
    exposure: float = -1.0,
    color: bool = False,
) -> np.ndarray:
    """Displayed light on a white surface per sample under :func:`daylight` (tone-mapped).

    Parameters
    ----------
    heightmap
        Heightmap or 2-D array (spacing 1).
    shadows
        Soft cast shadows (visible fraction of the sun's disc, ``soft_shadow``); False: the
        sun reaches every sample.
    sun_radius_deg, shadow_samples
        Angular radius of the sun's disc and the number of shadow sweeps over it.
    sky_visibility
        Sky-view factor per sample (``sky_view_factor``); None computes a local one (radius
        1/8 of the map, 8 directions) on a map of at most 257² samples, bilinearly enlarged.
    exposure
        Stops on top of the automatic exposure; the default -1 keeps sunlit white at about
        0.8 (a multiplier that leaves slopes and shadows readable on a texture).
    color
        RGB ``(rows, cols, 3)`` instead of the luminance.

    Returns
    -------
    numpy.ndarray
        float32 in [0, 1): sRGB-encoded display value of an albedo-1 surface — a multiplier
        for the albedo (and what ``terrascape shade`` writes).
    """
    from terrascape.lighting._common import as_heightmap, sun_above_horizon
    from terrascape.lighting.normals import normal_map
    from terrascape.lighting.shadows import soft_shadow

    hm = as_heightmap(heightmap)
    sun_above_horizon(sun_azimuth, sun_elevation)
    day = daylight(sun_azimuth, sun_elevation, turbidity=turbidity, exposure=exposure)
    if sky_visibility is not None:
        svf = np.asarray(sky_visibility)  # converted to float64 a band at a time
        if svf.shape != hm.shape:
            raise InvalidParameterError(
                f"sky_visibility must have the heightmap's shape {hm.shape}, got {svf.shape}")
    normals = normal_map(hm)
    vis = (soft_shadow(hm, sun_azimuth, sun_elevation, sun_radius_deg=sun_radius_deg,
                       samples=shadow_samples) if shadows else np.ones(hm.shape, np.float32))
    if sky_visibility is None:
        coarse, step = _coarse_sky_visibility(hm)

        def svf_rows(rows: slice) -> np.ndarray:
            return _enlarged_rows(coarse, step, rows, hm.shape)
    else:
        def svf_rows(rows: slice) -> np.ndarray:
            return svf[rows].astype(np.float64)
    out = np.empty(hm.shape + ((3,) if color else ()), np.float32)
    long = hm.heights.size > _LONG_SAMPLES
    run_stoppable(long, _light_in_bands, day, normals, vis, svf_rows, out, long)
    return out


def _light_in_bands(day: Daylight, normals: np.ndarray, vis: np.ndarray,
                    svf_rows: Callable[[slice], np.ndarray], out: np.ndarray, parallel: bool,
                    stop: np.ndarray) -> None:
    """:func:`daylight_lightmap`'s light into ``out`` (RGB, or grey when 2-D) a band of rows
    at a time, the bands shared among the numba threads when ``parallel``; no band begins
    once ``stop[0]`` is set. Every step works sample by sample, so the bands give the whole
    map's values bit for bit."""
    band_rows = max(1, _BAND_SAMPLES // out.shape[1])
    luma = _LUMA.astype(np.float32)

    def band(start: int) -> None:
        rows = slice(start, start + band_rows)
        n = normals[rows].astype(np.float64)
        radiance = day.surface_irradiance(n, vis[rows], svf_rows(rows)) / math.pi
        rgb = day.display(radiance).astype(np.float32)
        if out.ndim == 3:
            out[rows] = rgb
        else:
            # sample by sample in a fixed order: a BLAS product (rgb @ luma) rounds the
            # vector's tail differently from its SIMD body (seen with AVX-512), so a flat map
            # would not light evenly and bands would not give the whole map's values
            out[rows] = rgb[..., 0] * luma[0] + rgb[..., 1] * luma[1] + rgb[..., 2] * luma[2]

    for_each_band(band, range(0, out.shape[0], band_rows), parallel, stop)


def local_sky_visibility(heightmap: Any, *, max_side: int = 257, directions: int = 8) -> np.ndarray:
    """Sky-view factor over a radius of 1/8 of the map, computed on a map of at most
    ``max_side`` samples a side and enlarged bilinearly to the heightmap's shape (the full
    sky-view factor of a 1025² map takes tens of seconds)."""
    from terrascape.lighting._common import as_heightmap

    hm = as_heightmap(heightmap)
    coarse, step = _coarse_sky_visibility(hm, max_side=max_side, directions=directions)
    return _enlarged_rows(coarse, step, slice(0, hm.rows), hm.shape)


def _coarse_sky_visibility(hm: Any, *, max_side: int = 257,
                           directions: int = 8) -> tuple[np.ndarray, int]:
    """:func:`local_sky_visibility` on the coarse grid (float64) and its step in samples."""
    from terrascape.heightmap import Heightmap
    from terrascape.lighting.ambient_occlusion import sky_view_factor

    step = max(1, math.ceil(max(hm.shape) / max_side))
    small = Heightmap(np.ascontiguousarray(hm.heights[::step, ::step]),
                      spacing=(hm.spacing[0] * step, hm.spacing[1] * step))
    radius = 0.125 * max(hm.extent)
    svf = sky_view_factor(small, directions=directions, max_distance=max(radius, 1e-6))
    return svf.astype(np.float64), step


def _enlarged_rows(coarse: np.ndarray, step: int, rows: slice,
                   shape: tuple[int, int]) -> np.ndarray:
    """Rows ``rows`` of the coarse sky visibility enlarged bilinearly to ``shape`` (each
    sample on its own: a band's values are the whole map's)."""
    from scipy import ndimage

    if step == 1:
        return coarse[rows]
    # original sample r sits at r / step on the coarse grid
    r = np.minimum(np.arange(shape[0])[rows] / step, coarse.shape[0] - 1)
    c = np.minimum(np.arange(shape[1]) / step, coarse.shape[1] - 1)
    rr, cc = np.meshgrid(r, c, indexing="ij")
    return ndimage.map_coordinates(coarse, [rr, cc], order=1, mode="nearest")

LIGHTING_MODELS = ("daylight", "classic")
#: Earlier names of the lighting models, still accepted with a note naming the current one.
LIGHTING_MODEL_ALIASES = {"seed": "classic"}


def lighting_model(name: str) -> str:
    """The lighting model called ``name``: itself, or the current name of an earlier one
    (with a ``FutureWarning`` saying so); unknown names raise listing the models."""
    if name in LIGHTING_MODEL_ALIASES:
        import warnings

        new = LIGHTING_MODEL_ALIASES[name]
        warnings.warn(f"lighting model {name!r} is now called {new!r}; the old name will "
                      "stop working in a later version", FutureWarning, stacklevel=3)
        return new
    if name not in LIGHTING_MODELS:
        raise InvalidParameterError(
            f"lighting model must be one of {', '.join(LIGHTING_MODELS)}, got {name!r}")
    return name


def lightmap(
    heightmap: Any,
    sun_azimuth: float,
    sun_elevation: float,
    *,
    model: str = "daylight",
    shadows: bool = True,
    soft: bool = False,
    ambient: float = 0.2,
    method: str = "fast",
    sun_radius_deg: float | None = None,
    color: bool = False,
    **daylight_options: Any,
) -> np.ndarray:
    """Precomputed light per sample, ``[0, 1]`` — the ``terrascape shade`` lightmap.

    Parameters
    ----------
    model
        ``"daylight"`` (default, :func:`daylight_lightmap`: sun + sky + bounce, soft shadows,
        tone-mapped) or ``"classic"`` (:func:`terrascape.lighting.shadows.lightmap`:
        ``min(1, ambient + 0.5·(1 + N·L))`` where lit, ``ambient`` in shadow; ``"seed"``
        is its earlier name).
    shadows
        Cast shadows (both models).
    soft, ambient, method
        Classic model only: soft shadows, ambient level, ``"fast"``/``"reference"`` shadows.
    sun_radius_deg
        Angular radius of the sun (default 0.5° daylight — the sun plus its aureole — and
        0.27° classic).
    color
        Daylight only: RGB ``(rows, cols, 3)`` instead of luminance.
    daylight_options
        ``turbidity``, ``exposure``, ``shadow_samples``, ``sky_visibility`` of
        :func:`daylight_lightmap`.
    """
    model = lighting_model(model)
    if model == "classic":
        from terrascape.lighting.shadows import lightmap as classic_lightmap

        if color or daylight_options:
            extra = ["color"] * bool(color) + sorted(daylight_options)
            raise InvalidParameterError(
                f"the classic lighting model has no option {', '.join(extra)}")
        return classic_lightmap(heightmap, sun_azimuth, sun_elevation, ambient=ambient,
                             shadows=shadows, soft=soft, method=method,
                             sun_radius_deg=0.27 if sun_radius_deg is None else sun_radius_deg)
    return daylight_lightmap(heightmap, sun_azimuth, sun_elevation, shadows=shadows,
                             sun_radius_deg=0.5 if sun_radius_deg is None else sun_radius_deg,
                             color=color, **daylight_options)


__all__ = [
    "LIGHTING_MODELS",
    "LIGHTING_MODEL_ALIASES",
    "Daylight",
    "aces_filmic",
    "air_mass",
    "daylight",
    "daylight_lightmap",
    "lighting_model",
    "lightmap",
    "linear_to_srgb",
    "local_sky_visibility",
    "srgb_to_linear",
    "sun_transmittance",
]
