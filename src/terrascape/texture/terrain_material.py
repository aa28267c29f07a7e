"""The default terrain material: photo layers blended by slope, height, curvature and masks.

Per heightmap vertex, :func:`material_weights` gives one weight per layer of
:data:`~terrascape.texture.photo_materials.MATERIAL_LAYERS` (sum 1):

* **rock** on cliffs (slope ramp ``rock_slope``, degrees), more on convex ridges and less in
  concave hollows (curvature: exposed edges lose their soil first);
* **scree** on the debris slopes under cliffs: near rock (a blur of the rock weight) and
  below the rock's mean height there, plus moderately steep slopes (``scree_slope``);
* **sediment** in channels where the ``flow`` mask (accumulated water, e.g. the hydraulic
  erosion's flow) is high on gentle slopes, and where the ``deposition`` mask says material
  was laid down;
* **snow** on flats above ``snow_line`` only (never below it; its edge climbs with noise);
* **water** where the ``water`` mask is > 0 or the height is ≤ ``water_level`` (if given);
* **grass** and **meadow** (dry grass) share the rest, split by a large-scale seeded noise;
  the ``wear`` mask strips grass toward scree (trampled or eroded ground).

Masks are optional float arrays of the heightmap's shape; flow and deposition are scaled by
their 95th percentile, wear and water are read in [0, 1].

:func:`material_texture` draws the blend as a top-down colour image: each layer hex-tiled
(:mod:`terrascape.texture.hextile`) from the photo layers, and the layers combined with
height-based blending (a layer's detail height decides who wins a transition: stones poke
through grass instead of a cross-fade; Mitton 2013). The renderer's ``material`` technique
(``render/shaders/terrain/material.glsl``) samples the same weights, layers, hex grid and
blend per pixel.

References
----------
.. [1] A. Mitton, "Advanced Terrain Texture Splatting", Gamasutra, 2013.
.. [2] M. S. Mikkelsen, "Practical Real-Time Hex-Tiling", JCGT 11(3), 2022.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import ndimage

from terrascape._numba import CACHE, FASTMATH, njit, prange
from terrascape._validate import check_int, check_positive, check_range, make_rng
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.texture._noise import periodic_fbm
from terrascape.texture.hextile import (
    HEX_CONTRAST,
    HEX_ROTATION,
    HEX_SHARPNESS,
    _bilinear_wrap_all,
    _hex_grid,
    _hex_weights,
    _vertex_uv,
    box_mip,
    mip_levels_for,
)
from terrascape.texture.photo_materials import MATERIAL_LAYERS, photo_material_layers

MASK_NAMES: tuple[str, ...] = ("flow", "deposition", "wear", "water")
#: Minimum relief / extent for the automatic snow line.
SNOW_RELIEF = 0.08
#: Height-blend transition depth (fraction of the detail height range).
BLEND_DEPTH = 0.2

_L = {name: k for k, name in enumerate(MATERIAL_LAYERS)}


@dataclass(frozen=True)
class MaterialRules:
    """Thresholds of the default blend (angles in degrees, heights in world units).

    ``snow_line=None``: 78 % of the way from the lowest to the highest height, on terrain
    whose relief is at least ``SNOW_RELIEF`` (8 %) of its extent (none on gentle country);
    ``water_level=None``: no water except where the ``water`` mask says so.
    """

    rock_slope: tuple[float, float] = (34.0, 48.0)
    scree_slope: tuple[float, float] = (24.0, 34.0)
    snow_line: float | None = None
    snow_max_slope: tuple[float, float] = (30.0, 42.0)
    water_level: float | None = None
    meadow_share: float = 0.35

    def __post_init__(self) -> None:
        for name in ("rock_slope", "scree_slope", "snow_max_slope"):
            lo, hi = getattr(self, name)
            check_range(lo, f"{name} start", 0.0, 90.0)
            check_range(hi, f"{name} end", 0.0, 90.0)
            if hi <= lo:
                raise InvalidParameterError(f"{name} needs start < end, got ({lo}, {hi})")
        check_range(self.meadow_share, "meadow_share", 0.0, 1.0)


def _smoothstep(e0: float, e1: float, x: np.ndarray) -> np.ndarray:
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def check_masks(shape: tuple[int, int], masks: dict[str, Any] | None) -> dict[str, np.ndarray]:
    """Validate optional masks: known names, the heightmap's shape, finite values."""
    out: dict[str, np.ndarray] = {}
    for name, value in (masks or {}).items():
        if name not in MASK_NAMES:
            raise InvalidParameterError(
                f"unknown mask {name!r}; expected some of {', '.join(MASK_NAMES)}"
            )
        if value is None:
            continue
        a = np.asarray(value)
        if a.shape != tuple(shape):
            raise InvalidParameterError(
                f"{name} mask must have the heightmap's shape {tuple(shape)}, got {a.shape}"
            )
        if not np.issubdtype(a.dtype, np.number) or a.dtype == np.bool_:
            a = a.astype(np.float32)
        a = a.astype(np.float32)
        if not np.isfinite(a).all():
            raise InvalidParameterError(f"{name} mask contains NaN/infinite values")
        if float(a.min()) < 0.0:
            raise InvalidParameterError(f"{name} mask must be >= 0, got minimum {a.min():.4g}")
        out[name] = a
    return out


def _scaled(mask: np.ndarray) -> np.ndarray:
    """Flow/deposition to [0, 1]: smoothed over about a cell (droplet erosion leaves speckled
    deposits; a channel is a connected band), divided by the 95th percentile of the
    positive values."""
    mask = ndimage.gaussian_filter(mask.astype(np.float64), 1.0, mode="nearest")
    pos = mask[mask > 0]
    if pos.size == 0:
        return np.zeros_like(mask, dtype=np.float64)
    return np.clip(mask / max(float(np.percentile(pos, 95.0)), 1e-12), 0.0, 1.0)


def _field_noise(shape: tuple[int, int], seed: int, salt: int, cells: int) -> np.ndarray:
    """Smooth seeded noise in about [-1, 1] on the map, resampled from a periodic fBm."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, salt, 31]))
    side = 256
    n = periodic_fbm(side, (cells, cells), rng, octaves=4, gain=0.5)
    n /= max(float(np.abs(n).max()), 1e-9)
    zr = np.linspace(0, side - 1, shape[0])
    zc = np.linspace(0, side - 1, shape[1])
    return ndimage.map_coordinates(n, np.meshgrid(zr, zc, indexing="ij"), order=1)


def material_weights(
    heightmap: Heightmap | Any,
    *,
    masks: dict[str, Any] | None = None,
    rules: MaterialRules | None = None,
    seed: int = 0,
) -> np.ndarray:
    """Per-vertex weights of the material layers (see the module docstring).

    Parameters
    ----------
    heightmap
        A :class:`~terrascape.heightmap.Heightmap` or 2-D array (unit spacing).
    masks
        Optional ``{"flow" | "deposition" | "wear" | "water": float array (rows, cols)}``;
        NaN/inf or negative values and other shapes are rejected.
    rules
        :class:`MaterialRules` (default thresholds when ``None``).
    seed
        Seeds the noise that roughens the transitions (same seed, same weights).

    Returns
    -------
    numpy.ndarray
        ``float32 (L, rows, cols)``, ``L = len(MATERIAL_LAYERS)``; non-negative, sum 1.
    """
    hm = heightmap if isinstance(heightmap, Heightmap) else Heightmap(heightmap)
    rules = MaterialRules() if rules is None else rules
    if not isinstance(rules, MaterialRules):
        raise InvalidParameterError(f"rules must be MaterialRules, got {type(rules).__name__}")
    make_rng(seed)
    seed = int(seed)
    m = check_masks(hm.shape, masks)
    h = hm.heights.astype(np.float64)
    lo, hi = float(h.min()), float(h.max())
    span = hi - lo if hi > lo else 1.0
    slope = np.degrees(hm.slope().astype(np.float64))
    # Curvature: Laplacian in world units, scaled by its spread (>0 concave, <0 convex).
    dx, dz = hm.spacing
    lap = ndimage.laplace(ndimage.gaussian_filter(h, 1.0, mode="nearest"), mode="nearest")
    lap /= dx * dz
    curv = np.clip(lap / max(float(np.percentile(np.abs(lap), 90.0)), 1e-12), -1.0, 1.0)
    n1 = _field_noise(hm.shape, seed, 1, 6)
    n2 = _field_noise(hm.shape, seed, 2, 3)

    # Rock: slope ramp, shifted by curvature (convex ridges bare earlier) and noise.
    s_rock = slope + 6.0 * (-curv) + 3.0 * n1
    rock = _smoothstep(*rules.rock_slope, s_rock)
    # Scree: moderately steep ground, and debris fans below nearby rock.
    sigma = 2.0
    near = ndimage.gaussian_filter(rock, sigma, mode="nearest")
    rock_h = ndimage.gaussian_filter(rock * h, sigma, mode="nearest") / np.maximum(near, 1e-6)
    below = _smoothstep(0.0, 2.0 * max(dx, dz), rock_h - h)
    scree = np.maximum(_smoothstep(*rules.scree_slope, slope + 3.0 * n1),
                       np.clip(2.5 * near, 0.0, 1.0) * below)
    scree *= 1.0 - rock
    # Sediment: channels (flow on gentle slopes) and deposits.
    sediment = np.zeros_like(h)
    if "flow" in m:
        flow = _scaled(m["flow"])
        sediment = np.maximum(sediment, flow * (1.0 - _smoothstep(12.0, 28.0, slope)))
    if "deposition" in m:
        # Thin deposits (a film in every hollow) stay grass; thick ones become sediment.
        sediment = np.maximum(sediment, _smoothstep(0.25, 0.85, _scaled(m["deposition"])))
    sediment = np.clip(sediment, 0.0, 1.0) * (1.0 - rock)
    # Snow: above the line only (noise raises the edge, never lowers it), on flats.
    if rules.snow_line is not None:
        line = float(rules.snow_line)
    elif span >= SNOW_RELIEF * max(hm.extent):
        line = lo + 0.78 * span
    else:
        line = math.inf  # gentle country: no snow caps on its highest hillock

    fade = 0.04 * span
    edge = line + fade * (0.5 + 0.5 * n2)
    snow = _smoothstep(0.0, fade, h - edge) * (1.0 - _smoothstep(*rules.snow_max_slope, slope))
    snow = np.where(h > line, snow, 0.0)
    # Water: the mask, or at/below the water level.
    water = np.zeros_like(h)
    if "water" in m:
        water = np.clip(m["water"].astype(np.float64), 0.0, 1.0)
    if rules.water_level is not None:
        water = np.where(h <= float(rules.water_level), 1.0, water)

    w = np.zeros((len(MATERIAL_LAYERS), *h.shape))
    w[_L["water"]] = water
    rest = 1.0 - water
    w[_L["snow"]] = rest * snow
    rest = rest * (1.0 - snow)
    w[_L["rock"]] = rest * rock
    w[_L["scree"]] = rest * scree
    rest = rest * (1.0 - rock - scree)
    w[_L["sediment"]] = rest * sediment
    rest = rest * (1.0 - sediment)
    if "wear" in m:
        wear = np.clip(m["wear"].astype(np.float64), 0.0, 1.0)
        w[_L["scree"]] += rest * wear
        rest = rest * (1.0 - wear)
    meadow = rules.meadow_share * np.clip(1.0 + 1.6 * n2 - 0.4 * curv, 0.0, 2.0)
    meadow = np.clip(meadow, 0.0, 1.0)
    w[_L["meadow"]] = rest * meadow
    w[_L["grass"]] = rest * (1.0 - meadow)
    w = np.clip(w, 0.0, None)
    w /= np.maximum(w.sum(axis=0, keepdims=True), 1e-12)
    return w.astype(np.float32)


# --- the top-down colour image ----------------------------------------------------------------
@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _material_kernel(weights, layers, lightmap, use_light, tex_per_x, tex_per_z, seed, rotation,
                     contrast, sharpness, depth, out):
    n_layers, rows, cols = weights.shape
    h_out, w_out = out.shape[0], out.shape[1]
    sy = (rows - 1) / max(h_out - 1, 1)
    sx = (cols - 1) / max(w_out - 1, 1)
    ly = (lightmap.shape[0] - 1) / max(h_out - 1, 1)
    lx = (lightmap.shape[1] - 1) / max(w_out - 1, 1)
    for oi in prange(h_out):
        wk = np.empty(n_layers)
        c1 = np.empty(4)
        c2 = np.empty(4)
        c3 = np.empty(4)
        col = np.empty((n_layers, 3))
        hk = np.empty(n_layers)
        y = oi * sy
        i0 = min(int(y), rows - 2)
        fy = y - i0
        for oj in range(w_out):
            x = oj * sx
            j0 = min(int(x), cols - 2)
            fx = x - j0
            u = x * tex_per_x
            v = y * tex_per_z
            g = _hex_grid(u, v)
            u1, v1, _, _ = _vertex_uv(g[0], g[1], u, v, seed, rotation)
            u2, v2, _, _ = _vertex_uv(g[2], g[3], u, v, seed, rotation)
            u3, v3, _, _ = _vertex_uv(g[4], g[5], u, v, seed, rotation)
            best = -1e30
            for k in range(n_layers):
                a = weights[k, i0, j0] + (weights[k, i0, j0 + 1] - weights[k, i0, j0]) * fx
                b = weights[k, i0 + 1, j0] + (weights[k, i0 + 1, j0 + 1]
                                              - weights[k, i0 + 1, j0]) * fx
                wk[k] = a + (b - a) * fy
                if wk[k] <= 1e-3:
                    hk[k] = -1e30
                    continue
                tex = layers[k]
                _bilinear_wrap_all(tex, u1, v1, c1)
                _bilinear_wrap_all(tex, u2, v2, c2)
                _bilinear_wrap_all(tex, u3, v3, c3)
                p, q, r = _hex_weights(g[6], g[7], g[8], c1[3], c2[3], c3[3], contrast,
                                       sharpness)
                for c in range(3):
                    col[k, c] = p * c1[c] + q * c2[c] + r * c3[c]
                hk[k] = p * c1[3] + q * c2[3] + r * c3[3] + wk[k]
                if hk[k] > best:
                    best = hk[k]
            # Height-based blend: layers within `depth` of the highest (height + weight) mix.
            total = 0.0
            acc0 = 0.0
            acc1 = 0.0
            acc2 = 0.0
            for k in range(n_layers):
                if hk[k] < -1e29:
                    continue
                b = hk[k] - best + depth
                if b <= 0.0:
                    continue
                total += b
                acc0 += b * col[k, 0]
                acc1 += b * col[k, 1]
                acc2 += b * col[k, 2]
            light = 1.0
            if use_light:
                yy = oi * ly
                xx = oj * lx
                li = min(int(yy), lightmap.shape[0] - 2)
                lj = min(int(xx), lightmap.shape[1] - 2)
                gy = yy - li
                gx = xx - lj
                t0 = lightmap[li, lj] + (lightmap[li, lj + 1] - lightmap[li, lj]) * gx
                t1 = lightmap[li + 1, lj] + (lightmap[li + 1, lj + 1] - lightmap[li + 1, lj]) * gx
                light = t0 + (t1 - t0) * gy
            scale = light * 255.0 / total
            out[oi, oj, 0] = np.uint8(min(max(acc0 * scale + 0.5, 0.0), 255.0))
            out[oi, oj, 1] = np.uint8(min(max(acc1 * scale + 0.5, 0.0), 255.0))
            out[oi, oj, 2] = np.uint8(min(max(acc2 * scale + 0.5, 0.0), 255.0))


def material_texture(
    heightmap: Heightmap | Any,
    *,
    masks: dict[str, Any] | None = None,
    rules: MaterialRules | None = None,
    weights: np.ndarray | None = None,
    scale: int = 1,
    seed: int = 0,
    tile_size: float | None = None,
    material_size: int = 256,
    lightmap: Any = None,
    rotation: float = HEX_ROTATION,
    contrast: float = HEX_CONTRAST,
    sharpness: float = HEX_SHARPNESS,
) -> np.ndarray:
    """Top-down colour image of the default terrain material.

    Parameters
    ----------
    heightmap, masks, rules, seed
        As in :func:`material_weights` (``seed`` also seeds the photo layers and hex grid).
    weights
        Precomputed :func:`material_weights` (skips their computation).
    scale
        Output texels per heightmap sample along each axis (corner-aligned grid, as
        :func:`terrascape.texture.region_texture`).
    tile_size
        World units per material repeat; default ``32 × max(spacing)`` like the renderer.
    material_size
        Side of the photo layers (power of two).
    lightmap
        Optional float ``(r, c)`` in [0, 1] multiplied in (any size ≥ 2×2, resampled).
    rotation, contrast, sharpness
        Hex-tiling parameters (:func:`terrascape.texture.hextile.hex_tile`).

    Returns
    -------
    numpy.ndarray
        ``uint8 (rows·scale, cols·scale, 3)`` RGB.
    """
    from terrascape.texture.regions import _check_lightmap

    hm = heightmap if isinstance(heightmap, Heightmap) else Heightmap(heightmap)
    scale = check_int(scale, "scale", minimum=1, maximum=64)
    rotation = check_range(rotation, "rotation", 0.0, 1.0)
    contrast = check_range(contrast, "contrast", 0.0, 1.0)
    sharpness = check_range(sharpness, "sharpness", 1.0, 64.0)
    if weights is None:
        w = material_weights(hm, masks=masks, rules=rules, seed=seed)
    else:
        w = np.ascontiguousarray(weights, dtype=np.float32)
        if w.shape != (len(MATERIAL_LAYERS), *hm.shape) or not np.isfinite(w).all():
            raise InvalidParameterError(
                f"weights must be finite (L={len(MATERIAL_LAYERS)}, rows, cols) = "
                f"{(len(MATERIAL_LAYERS), *hm.shape)}, got {w.shape}"
            )
    dx, dz = hm.spacing
    tile = 32.0 * max(dx, dz) if tile_size is None else check_positive(tile_size, "tile_size")
    lm = _check_lightmap(lightmap) if lightmap is not None else np.ones((2, 2), np.float32)
    layers = photo_material_layers(material_size, seed=seed).albedo
    h_out, w_out = hm.rows * scale, hm.cols * scale
    world_per_px = min(dx * (hm.cols - 1) / max(w_out - 1, 1),
                       dz * (hm.rows - 1) / max(h_out - 1, 1))
    level = mip_levels_for(material_size, tile / world_per_px)
    stack = np.stack([box_mip(layers[k].astype(np.float32), level)
                      for k in range(len(MATERIAL_LAYERS))])
    stack[..., :3] /= 255.0
    stack[..., 3] /= 255.0
    out = np.empty((h_out, w_out, 3), dtype=np.uint8)
    _material_kernel(w, np.ascontiguousarray(stack), lm, lightmap is not None, dx / tile,
                     dz / tile, int(seed), rotation, contrast, sharpness, BLEND_DEPTH, out)
    return out


def _lowest_ground_weights(heightmap: Heightmap | Any, seed: int, share: float) -> np.ndarray:
    """Material layer weights (summing to 1) of the lowest ``share`` of the samples, water
    left out (grass where nothing else is left)."""
    share = check_range(share, "share", 1e-4, 1.0)
    hm = heightmap if isinstance(heightmap, Heightmap) else Heightmap(heightmap)
    step = max(1, math.ceil(max(hm.shape) / 257))  # the weights of a coarser copy suffice
    dx, dz = hm.spacing
    small = Heightmap(np.ascontiguousarray(hm.heights[::step, ::step]), (dx * step, dz * step))
    weights = material_weights(small, seed=seed).astype(np.float64)
    h = small.heights
    low = h <= np.quantile(h, share)
    w = weights[:, low].sum(axis=1)
    w[_L["water"]] = 0.0
    if w.sum() <= 0.0:
        w[:] = 0.0
        w[_L["grass"]] = 1.0
    return w / w.sum()


def _srgb_to_linear(srgb: np.ndarray) -> np.ndarray:
    return np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)


def lowest_ground_albedo(heightmap: Heightmap | Any, *, seed: int = 0,
                         share: float = 0.05, material_size: int = 64) -> np.ndarray:
    """Linear RGB albedo of the terrain's lowest ground: the material blend (mean colour of
    each photo layer, by :func:`material_weights`) over the lowest ``share`` of the
    samples, water left out. The colour of the plane that continues the terrain beyond its
    edge, so the world past the edge is made of the ground the terrain ends in.
    """
    w = _lowest_ground_weights(heightmap, seed, share)
    layers = photo_material_layers(material_size, seed=seed).albedo[..., :3]
    srgb = layers.reshape(len(MATERIAL_LAYERS), -1, 3).astype(np.float64) / 255.0
    return w @ _srgb_to_linear(srgb).mean(axis=1)


def lowest_ground_texture(heightmap: Heightmap | Any, *, seed: int = 0,
                          share: float = 0.05, material_size: int = 256) -> np.ndarray:
    """The lowest ground's material as a tileable texture: the photo layers blended texel
    by texel in linear light by the weights of :func:`lowest_ground_albedo` (so its mean
    colour is that albedo), ``uint8 (material_size, material_size, 4)``: sRGB colour and
    the blended detail height in A (for hex-tiling's contrast weights). The ground of the
    plane beyond the terrain's edge.
    """
    w = _lowest_ground_weights(heightmap, seed, share)
    layers = photo_material_layers(material_size, seed=seed).albedo.astype(np.float64) / 255.0
    linear = np.tensordot(w, _srgb_to_linear(layers[..., :3]), axes=1)
    height = np.tensordot(w, layers[..., 3], axes=1)
    srgb = np.where(linear <= 0.0031308, 12.92 * linear,
                    1.055 * np.power(linear, 1.0 / 2.4) - 0.055)
    out = np.concatenate([srgb, height[..., None]], axis=-1)
    return np.round(np.clip(out, 0.0, 1.0) * 255.0).astype(np.uint8)


def dominant_layer(weights: np.ndarray) -> np.ndarray:
    """Index of the heaviest layer per vertex, ``uint8 (rows, cols)``."""
    return np.argmax(np.asarray(weights), axis=0).astype(np.uint8)


__all__ = [
    "BLEND_DEPTH",
    "MASK_NAMES",
    "MaterialRules",
    "check_masks",
    "dominant_layer",
    "lowest_ground_albedo",
    "lowest_ground_texture",
    "material_texture",
    "material_weights",
]

