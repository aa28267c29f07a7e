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
from terrascape.texture._block_percentile import block_percentiles
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
    ``water_level=None``: no water except where the ``water`` mask says so;
    ``floodplain_bare``: the share of thick deposits away from running water left as bare
    sediment (the rest is meadow: a filled basin reads as an alluvial flat).
    """

    rock_slope: tuple[float, float] = (34.0, 48.0)
    scree_slope: tuple[float, float] = (24.0, 34.0)
    snow_line: float | None = None
    snow_max_slope: tuple[float, float] = (30.0, 42.0)
    water_level: float | None = None
    meadow_share: float = 0.35
    floodplain_bare: float = 0.2

    def __post_init__(self) -> None:
        for name in ("rock_slope", "scree_slope", "snow_max_slope"):
            lo, hi = getattr(self, name)
            check_range(lo, f"{name} start", 0.0, 90.0)
            check_range(hi, f"{name} end", 0.0, 90.0)
            if hi <= lo:
                raise InvalidParameterError(f"{name} needs start < end, got ({lo}, {hi})")
        check_range(self.meadow_share, "meadow_share", 0.0, 1.0)
        check_range(self.floodplain_bare, "floodplain_bare", 0.0, 1.0)


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


#: Heightmap samples per block of rows: the weights are computed block by block (with a
#: halo), so their float64 temporaries are a few blocks, never whole maps.
_BLOCK_SAMPLES = 1 << 15
#: Halo rows a block needs for exact values: the Gaussian (σ 1, 4 rows) and Laplacian (1 row)
#: of the curvature feed the rock weight, which is blurred by a Gaussian of σ 2 (8 rows).
_HALO = 13
#: Halo of the curvature alone, and of the smoothed flow and deposition masks.
_CURVATURE_HALO = 5
_MASK_HALO = 4


def _row_blocks(rows: int, cols: int) -> list[tuple[int, int]]:
    step = max(1, min(rows, _BLOCK_SAMPLES // max(1, cols)))
    return [(r0, min(rows, r0 + step)) for r0 in range(0, rows, step)]


def _smoothed_mask(mask: np.ndarray, r0: int, r1: int) -> np.ndarray:
    """Rows ``r0:r1`` of the flow/deposition mask smoothed over about a cell (droplet erosion
    leaves speckled deposits; a channel is a connected band): the rows of the whole map's
    Gaussian, from a block with its halo."""
    lo, hi = max(0, r0 - _MASK_HALO), min(mask.shape[0], r1 + _MASK_HALO)
    smooth = ndimage.gaussian_filter(mask[lo:hi].astype(np.float64), 1.0, mode="nearest")
    return smooth[r0 - lo:r1 - lo]


def _mask_scale(mask: np.ndarray) -> float | None:
    """The 95th percentile of the smoothed mask's positive values (``None``: none is > 0)."""
    def blocks():
        for r0, r1 in _row_blocks(*mask.shape):
            smooth = _smoothed_mask(mask, r0, r1)
            yield smooth[smooth > 0]

    found = block_percentiles(blocks, [95.0])
    return None if found is None else found[0]


def _scaled_rows(smooth: np.ndarray, p95: float | None) -> np.ndarray:
    """Flow/deposition to [0, 1]: the smoothed mask divided by its 95th percentile."""
    if p95 is None:
        return np.zeros_like(smooth, dtype=np.float64)
    return np.clip(smooth / max(p95, 1e-12), 0.0, 1.0)


def _field_noise_grid(seed: int, salt: int, cells: int) -> np.ndarray:
    """Smooth seeded periodic fBm in about [-1, 1], 256², resampled onto the map by
    :func:`_field_noise_rows`."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, salt, 31]))
    n = periodic_fbm(256, (cells, cells), rng, octaves=4, gain=0.5)
    n /= max(float(np.abs(n).max()), 1e-9)
    return n


def _field_noise_rows(grid: np.ndarray, shape: tuple[int, int], r0: int, r1: int
                      ) -> np.ndarray:
    """Rows ``r0:r1`` of the noise grid stretched over a map of ``shape`` (bilinear)."""
    side = grid.shape[0]
    zr = np.linspace(0, side - 1, shape[0])[r0:r1]
    zc = np.linspace(0, side - 1, shape[1])
    return ndimage.map_coordinates(grid, np.meshgrid(zr, zc, indexing="ij"), order=1)


def _curvature_rows(hm: Heightmap, r0: int, r1: int, halo: int) -> tuple[np.ndarray, slice]:
    """The Laplacian of the smoothed heights (world units) on rows ``r0 - halo : r1 + halo``
    (clipped to the map) and the slice of that block that holds rows ``r0:r1``."""
    lo, hi = max(0, r0 - halo), min(hm.rows, r1 + halo)
    h = hm.heights[lo:hi].astype(np.float64)
    lap = ndimage.laplace(ndimage.gaussian_filter(h, 1.0, mode="nearest"), mode="nearest")
    dx, dz = hm.spacing
    lap /= dx * dz
    return lap, slice(r0 - lo, r1 - lo)


@dataclass(frozen=True)
class _WeightContext:
    """What every block of weights shares: the global statistics and the noise grids."""

    hm: Heightmap
    masks: dict[str, np.ndarray]
    rules: MaterialRules
    lo: float
    span: float
    line: float
    curvature_scale: float
    flow_scale: float | None
    deposition_scale: float | None
    noise1: np.ndarray
    noise2: np.ndarray


def _weight_context(hm: Heightmap, masks: dict[str, np.ndarray], rules: MaterialRules,
                    seed: int) -> _WeightContext:
    lo, hi = float(hm.heights.min()), float(hm.heights.max())
    span = hi - lo if hi > lo else 1.0
    if rules.snow_line is not None:
        line = float(rules.snow_line)
    elif span >= SNOW_RELIEF * max(hm.extent):
        line = lo + 0.78 * span
    else:
        line = math.inf  # gentle country: no snow caps on its highest hillock

    def curvature_blocks():
        for r0, r1 in _row_blocks(hm.rows, hm.cols):
            lap, inner = _curvature_rows(hm, r0, r1, _CURVATURE_HALO)
            yield np.abs(lap[inner])

    # Curvature is scaled by its spread: the 90th percentile of |Laplacian| over the map.
    (p90,) = block_percentiles(curvature_blocks, [90.0])
    return _WeightContext(
        hm, masks, rules, lo, span, line, p90,
        _mask_scale(masks["flow"]) if "flow" in masks else None,
        _mask_scale(masks["deposition"]) if "deposition" in masks else None,
        _field_noise_grid(seed, 1, 6), _field_noise_grid(seed, 2, 3))


def _weight_rows(ctx: _WeightContext, r0: int, r1: int) -> np.ndarray:
    """Rows ``r0:r1`` of :func:`material_weights`, float32 ``(L, r1 - r0, cols)``: the same
    values as those rows of the whole map's weights (each filter gets its halo)."""
    hm, m, rules = ctx.hm, ctx.masks, ctx.rules
    dx, dz = hm.spacing
    lap, inner = _curvature_rows(hm, r0, r1, _HALO)
    lo_e = r0 - inner.start
    hi_e = lo_e + lap.shape[0]
    h_ext = hm.heights[lo_e:hi_e].astype(np.float64)
    slope_ext = np.degrees(Heightmap(hm.heights[lo_e:hi_e], hm.spacing).slope()
                           .astype(np.float64))
    curv_ext = np.clip(lap / max(ctx.curvature_scale, 1e-12), -1.0, 1.0)
    del lap
    n1_ext = _field_noise_rows(ctx.noise1, hm.shape, lo_e, hi_e)

    # Rock: slope ramp, shifted by curvature (convex ridges bare earlier) and noise.
    s_rock = slope_ext + 6.0 * (-curv_ext) + 3.0 * n1_ext
    rock_ext = _smoothstep(*rules.rock_slope, s_rock)
    del s_rock
    # Scree: moderately steep ground, and debris fans below nearby rock.
    sigma = 2.0
    near = ndimage.gaussian_filter(rock_ext, sigma, mode="nearest")[inner]
    rock_h = (ndimage.gaussian_filter(rock_ext * h_ext, sigma, mode="nearest")[inner]
              / np.maximum(near, 1e-6))
    h, slope, curv, n1, rock = (a[inner] for a in (h_ext, slope_ext, curv_ext, n1_ext,
                                                   rock_ext))
    del h_ext, slope_ext, curv_ext, n1_ext, rock_ext
    n2 = _field_noise_rows(ctx.noise2, hm.shape, r0, r1)
    below = _smoothstep(0.0, 2.0 * max(dx, dz), rock_h - h)
    scree = np.maximum(_smoothstep(*rules.scree_slope, slope + 3.0 * n1),
                       np.clip(2.5 * near, 0.0, 1.0) * below)
    del below, near, rock_h
    scree *= 1.0 - rock
    # Sediment: channels (flow on gentle slopes) and deposits.
    sediment = np.zeros_like(h)
    active = np.zeros_like(h)
    if "flow" in m:
        flow = _scaled_rows(_smoothed_mask(m["flow"], r0, r1), ctx.flow_scale)
        sediment = np.maximum(sediment, flow * (1.0 - _smoothstep(12.0, 28.0, slope)))
        active = _smoothstep(0.15, 0.6, flow)
        del flow
    floodplain = np.zeros_like(h)
    if "deposition" in m:
        # Thin deposits (a film in every hollow) stay grass; thick ones are sediment where
        # water still runs over them. Away from the channels a filled basin is a floodplain:
        # vegetated (dry meadow grass) with bare patches, as alluvial flats are, instead of
        # one flat sediment colour. Noise on the threshold frays the fill's rim, which is
        # otherwise one contour line of the fill level.
        deposits = _scaled_rows(_smoothed_mask(m["deposition"], r0, r1), ctx.deposition_scale)
        fill = _smoothstep(0.25, 0.85, deposits + 0.3 * n1)
        bare = np.clip(rules.floodplain_bare + 0.5 * n1, 0.0, 1.0)
        share = np.maximum(active, bare)
        sediment = np.maximum(sediment, fill * share)
        floodplain = fill * (1.0 - share)
        del deposits, fill, bare, share
    del n1, active
    sediment = np.clip(sediment, 0.0, 1.0) * (1.0 - rock)
    # Snow: above the line only (noise raises the edge, never lowers it), on flats.
    line = ctx.line
    fade = 0.04 * ctx.span
    edge = line + fade * (0.5 + 0.5 * n2)
    snow = _smoothstep(0.0, fade, h - edge) * (1.0 - _smoothstep(*rules.snow_max_slope, slope))
    snow = np.where(h > line, snow, 0.0)
    del edge, slope
    # Water: the mask, or at/below the water level.
    water = np.zeros_like(h)
    if "water" in m:
        water = np.clip(m["water"][r0:r1].astype(np.float64), 0.0, 1.0)
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
        wear = np.clip(m["wear"][r0:r1].astype(np.float64), 0.0, 1.0)
        w[_L["scree"]] += rest * wear
        rest = rest * (1.0 - wear)
    meadow = rules.meadow_share * np.clip(1.0 + 1.6 * n2 - 0.4 * curv, 0.0, 2.0)
    meadow = np.clip(np.maximum(meadow, floodplain), 0.0, 1.0)
    w[_L["meadow"]] = rest * meadow
    w[_L["grass"]] = rest * (1.0 - meadow)
    w = np.clip(w, 0.0, None)
    w /= np.maximum(w.sum(axis=0, keepdims=True), 1e-12)
    return w.astype(np.float32)


def _prepare_weights(heightmap: Heightmap | Any, masks: dict[str, Any] | None,
                     rules: MaterialRules | None, seed: int) -> _WeightContext:
    hm = heightmap if isinstance(heightmap, Heightmap) else Heightmap(heightmap)
    rules = MaterialRules() if rules is None else rules
    if not isinstance(rules, MaterialRules):
        raise InvalidParameterError(f"rules must be MaterialRules, got {type(rules).__name__}")
    make_rng(seed)
    return _weight_context(hm, check_masks(hm.shape, masks), rules, int(seed))


def material_weights(
    heightmap: Heightmap | Any,
    *,
    masks: dict[str, Any] | None = None,
    rules: MaterialRules | None = None,
    seed: int = 0,
) -> np.ndarray:
    """Per-vertex weights of the material layers (see the module docstring).

    Computed in blocks of rows (each filter with its halo), so the peak is the weights plus
    a few blocks of float64 temporaries.

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
    ctx = _prepare_weights(heightmap, masks, rules, seed)
    out = np.empty((len(MATERIAL_LAYERS), *ctx.hm.shape), dtype=np.float32)
    for r0, r1 in _row_blocks(ctx.hm.rows, ctx.hm.cols):
        out[:, r0:r1] = _weight_rows(ctx, r0, r1)
    return out


# --- the top-down colour image ----------------------------------------------------------------
@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _material_kernel(weights, w_row0, rows, out_row0, h_out, layers, lightmap, use_light,
                     tex_per_x, tex_per_z, seed, rotation, contrast, sharpness, depth, out):
    # A block of output rows: ``out`` holds rows out_row0 … of the h_out-row image and
    # ``weights`` the map rows w_row0 … of a rows-row map that they interpolate.
    n_layers, _, cols = weights.shape
    w_out = out.shape[1]
    sy = (rows - 1) / max(h_out - 1, 1)
    sx = (cols - 1) / max(w_out - 1, 1)
    ly = (lightmap.shape[0] - 1) / max(h_out - 1, 1)
    lx = (lightmap.shape[1] - 1) / max(w_out - 1, 1)
    for bi in prange(out.shape[0]):
        oi = out_row0 + bi
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
            wi = i0 - w_row0
            for k in range(n_layers):
                a = weights[k, wi, j0] + (weights[k, wi, j0 + 1] - weights[k, wi, j0]) * fx
                b = weights[k, wi + 1, j0] + (weights[k, wi + 1, j0 + 1]
                                              - weights[k, wi + 1, j0]) * fx
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
            out[bi, oj, 0] = np.uint8(min(max(acc0 * scale + 0.5, 0.0), 255.0))
            out[bi, oj, 1] = np.uint8(min(max(acc1 * scale + 0.5, 0.0), 255.0))
            out[bi, oj, 2] = np.uint8(min(max(acc2 * scale + 0.5, 0.0), 255.0))


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
        ctx = _prepare_weights(hm, masks, rules, seed)
        w = None
    else:
        ctx = None
        w = np.asarray(weights, dtype=np.float32)
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
    stack = np.ascontiguousarray(stack)
    out = np.empty((h_out, w_out, 3), dtype=np.uint8)
    # Blocks of output rows, each from the block of weights its rows interpolate (computed
    # for it, or cut from the weights given): never the whole map's weights at once.
    sy = (hm.rows - 1) / max(h_out - 1, 1)

    def weight_row(oi: int) -> int:  # the kernel's upper interpolation row for output row oi
        return min(int(oi * sy), hm.rows - 2)

    step = max(1, min(hm.rows, _BLOCK_SAMPLES // max(1, hm.cols))) * scale
    for o0 in range(0, h_out, step):
        o1 = min(h_out, o0 + step)
        r0, r1 = weight_row(o0), weight_row(o1 - 1) + 2
        block = (_weight_rows(ctx, r0, r1) if w is None
                 else np.ascontiguousarray(w[:, r0:r1]))
        _material_kernel(block, r0, hm.rows, o0, h_out, stack, lm, lightmap is not None,
                         dx / tile, dz / tile, int(seed), rotation, contrast, sharpness,
                         BLEND_DEPTH, out[o0:o1])
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

