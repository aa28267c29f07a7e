"""Procedural terrain texture from height regions (Filipović 2008 §3.1.1).

The thesis's pseudocode blends, for every heightmap sample, the colours of all region
textures with the weight

    tezina(h, r) = max(0, (r.domet - |h - r.max|) / r.domet)

(``domet`` = ``range``: the band half-width; ``max``: the height where the band peaks).
With bands spaced exactly ``range`` apart the weights are linear "hat" functions that already
sum to one; terrascape normalises per texel anyway so arbitrary region lists work, and
falls back to the nearest band where every weight is zero (below the lowest or above the
highest band).

Beyond the pseudocode, as the seed suggests: random jitter of the band limits (smooth
per-texel noise; never for water — water on a hillside would look wrong), a slope rule
(rock on steep slopes, the weight ramping between two angles), a lightmap multiplied in,
and output at an integer multiple of the heightmap resolution.

Sample grid: output texel ``(i, j)`` of an ``(H, W)`` texture sits at heightmap coordinate
``(i·(rows-1)/(H-1), j·(cols-1)/(W-1))`` — corners aligned, so at ``scale=1`` texel ``(i, j)``
is exactly vertex ``(i, j)`` (the seed: one texel per vertex). A renderer mapping vertex
``(r, c)`` to this texture uses ``u = (c·(W-1)/(cols-1) + 0.5)/W`` (texel centres).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, prange, stop_requested
from terrascape._stoppable import run_stoppable
from terrascape._validate import (
    as_height_array,
    check_finite,
    check_int,
    check_positive,
    check_range,
    make_rng,
)
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.texture._noise import _jitter_noise, jitter_lattices
from terrascape.texture.hextile import (
    HEX_CONTRAST,
    HEX_ROTATION,
    HEX_SHARPNESS,
    _bilinear_wrap_all,
    _hex_grid,
    _hex_weights,
    _vertex_uv,
)
from terrascape.texture.materials import TextureSpec, load_texture, resize_rgb


@dataclass(frozen=True)
class Region:
    """One height band of the thesis's ``region`` structure.

    Parameters
    ----------
    name
        Band name; also the default built-in material (``water``, ``sand``, ...).
    max
        Height (world units) where the band's weight peaks (the thesis's ``max``).
    range
        Band half-width ``domet`` (world units, > 0): the weight falls linearly to 0 at
        ``max ± range``.
    texture
        Image array, image file path, built-in material name, or ``None`` (built-in ``name``).
    jitter
        Whether random jitter may move this band's ``max``. Ignored (always off) for a band
        named ``water``: the seed forbids water texture on hillsides.
    """

    name: str
    max: float
    range: float
    texture: TextureSpec = None
    jitter: bool = True

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise InvalidParameterError(
                f"region name must be a non-empty string, got {self.name!r}"
            )
        object.__setattr__(self, "max", check_finite(self.max, f"region {self.name!r} max"))
        object.__setattr__(
            self, "range", check_positive(self.range, f"region {self.name!r} range")
        )

    @property
    def jitters(self) -> bool:
        """True when jitter applies to this band (never for water)."""
        return bool(self.jitter) and self.name.lower() != "water"


@dataclass(frozen=True)
class SlopeRule:
    """Rock on steep slopes: the named region's weight ramps linearly from 0 at ``start_deg``
    to 1 at ``end_deg`` (slope angle from horizontal).

    With ramp value ``t``, every non-water weight is scaled by ``1 - t`` and the freed mass
    ``t·(1 - w_water)`` goes to the rule's region; a ``water`` band keeps its weight (no rock
    under the water plane, matching the thesis's "no water on hillsides" in reverse).
    """

    region: str = "rock"
    start_deg: float = 30.0
    end_deg: float = 45.0

    def __post_init__(self) -> None:
        s0 = check_range(self.start_deg, "slope rule start_deg", 0.0, 90.0)
        s1 = check_range(self.end_deg, "slope rule end_deg", 0.0, 90.0)
        if s1 < s0:
            raise InvalidParameterError(
                f"slope rule needs start_deg <= end_deg, got {s0} > {s1}"
            )


def default_regions(heightmap: Heightmap | Any) -> list[Region]:
    """Water/sand/grass/rock/snow bands spread over the height range (Filipović 2008 Table 1).

    The thesis's table splits 0–255 into five equal bands (water 0–50, sand 51–101, …). Here
    band ``i`` of the span ``[lo, hi]`` peaks at its upper limit ``lo + (i+1)·s/5`` with
    ``range = s/5``, so adjacent weights are complementary hats: water is pure up to
    ``lo + s/5`` and blends into sand up to ``lo + 2s/5``, …, snow is pure at the top.
    A flat map gets a unit span (all water).
    """
    h = heightmap.heights if isinstance(heightmap, Heightmap) else as_height_array(heightmap)
    lo, hi = float(h.min()), float(h.max())
    span = hi - lo
    if not span > 0:
        span = 1.0
    width = span / 5.0
    return [
        Region(name, lo + (i + 1) * width, width, jitter=(name != "water"))
        for i, name in enumerate(("water", "sand", "grass", "rock", "snow"))
    ]


def _check_regions(regions: Any) -> list[Region]:
    if regions is None:
        raise InvalidParameterError("regions must be a non-empty list of Region, got None")
    regions = list(regions)
    if not regions:
        raise InvalidParameterError("expected at least one Region, got an empty list")
    seen: dict[tuple[float, float], str] = {}
    for r in regions:
        if not isinstance(r, Region):
            raise InvalidParameterError(f"expected Region objects, got {type(r).__name__}")
        key = (r.max, r.range)
        if key in seen:
            raise InvalidParameterError(
                f"regions {seen[key]!r} and {r.name!r} are identical bands "
                f"(max={r.max:g}, range={r.range:g}); give each band its own max or range"
            )
        seen[key] = r.name
    if len(regions) > 255:
        raise InvalidParameterError(f"at most 255 regions are supported, got {len(regions)}")
    return regions


def _resolve_slope_rule(slope_rule: Any, regions: list[Region]) -> tuple:
    """``(index, start_rad, end_rad)``; index -1 means the rule is off."""
    if slope_rule is None or slope_rule is False:
        return -1, 0.0, 0.0
    if slope_rule is True:
        rule = SlopeRule()
        # True = "the default rule where it makes sense": silently off without a rock band.
        explicit = False
    elif isinstance(slope_rule, SlopeRule):
        rule = slope_rule
        explicit = True
    else:
        raise InvalidParameterError(
            f"slope_rule must be None, a bool or a SlopeRule, got {type(slope_rule).__name__}"
        )
    names = [r.name for r in regions]
    if rule.region not in names:
        if not explicit:
            return -1, 0.0, 0.0
        raise InvalidParameterError(
            f"slope rule targets region {rule.region!r}, but regions are {names}"
        )
    return names.index(rule.region), math.radians(rule.start_deg), math.radians(rule.end_deg)


def _water_index(regions: list[Region]) -> int:
    """Index of the first band named ``water`` (case-insensitive), or -1."""
    for k, r in enumerate(regions):
        if r.name.lower() == "water":
            return k
    return -1


def _region_arrays(regions: list[Region], jitter: float, seed: int) -> tuple:
    maxs = np.array([r.max for r in regions], dtype=np.float64)
    ranges = np.array([r.range for r in regions], dtype=np.float64)
    amps = np.array([jitter if r.jitters else 0.0 for r in regions], dtype=np.float64)
    lat1, lat2 = jitter_lattices(len(regions), make_rng(seed))
    return maxs, ranges, amps, lat1, lat2


@njit(cache=CACHE, fastmath=FASTMATH)
def _texel_weights(h, slope, u, v, maxs, ranges, amps, lat1, lat2, rule, water, s0, s1, w,
                   water_level):
    """Normalised region weights of one texel into ``w`` (float64, R).

    Water is all or nothing: weight 1 at or below ``water_level``, 0 above it (no water
    colour on a slope above the water line), the other bands share the rest.
    """
    n = maxs.shape[0]
    if water >= 0 and (h <= water_level or n == 1):
        for r in range(n):
            w[r] = 0.0
        w[water] = 1.0
        return
    total = 0.0
    best = np.inf
    best_i = 0
    for r in range(n):
        if r == water:
            w[r] = 0.0
            continue
        peak = maxs[r]
        # A band whose jittered peak cannot come within ``range`` of h has weight 0 anyway:
        # skip the noise evaluation (most bands at most texels; the dominant cost otherwise).
        if amps[r] > 0.0 and abs(h - peak) < ranges[r] * (1.0 + amps[r]):
            # Jitter moves the band peak by up to ±amp·range, smoothly across the map.
            peak += amps[r] * ranges[r] * _jitter_noise(lat1, lat2, r, u, v)
        dist = abs(h - peak)
        raw = (ranges[r] - dist) / ranges[r]
        # Distance from h to the band's support [peak - range, peak + range], for the fallback.
        if dist - ranges[r] < best:
            best = dist - ranges[r]
            best_i = r
        if raw < 0.0:
            raw = 0.0
        w[r] = raw
        total += raw
    if total > 0.0:
        for r in range(n):
            w[r] /= total
    else:
        # Outside every band: the nearest band (smallest gap to its support) takes it all.
        for r in range(n):
            w[r] = 0.0
        w[best_i] = 1.0
    if rule >= 0:
        if s1 > s0:
            t = (slope - s0) / (s1 - s0)
        else:
            t = 1.0 if slope >= s0 else 0.0
        t = min(max(t, 0.0), 1.0)
        if t > 0.0:
            # Above the water line water's weight is 0 (below it the texel returned early), so
            # all the mass moves toward the rule's region.
            keep = w[water] if water >= 0 else 0.0
            for r in range(n):
                if r != water:
                    w[r] *= 1.0 - t
            w[rule] += t * (1.0 - keep)


# Maps of more samples are weighted on the worker thread of long calls, so that Ctrl-C
# stops them between two rows (an 8193² map takes seconds; in an 8129² Unreal export a
# signal landing here took 0.35 s to stop it, docs/reliability.md §3)
_LONG_SAMPLES = 1 << 20


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _weights_kernel(heights, slope, use_slope, maxs, ranges, amps, lat1, lat2, rule, water, s0,
                    s1, water_level, out, stop):
    """Every sample's region weights into ``out`` (regions, rows, cols); rows not yet begun
    are left unwritten once ``stop[0]`` is set (:func:`run_stoppable`)."""
    rows, cols = heights.shape
    n = maxs.shape[0]
    for i in prange(rows):
        if stop_requested(stop):
            continue
        w = np.empty(n)
        v = i / (rows - 1)
        for j in range(cols):
            s = slope[i, j] if use_slope else 0.0
            _texel_weights(heights[i, j], s, j / (cols - 1), v, maxs, ranges, amps, lat1,
                           lat2, rule, water, s0, s1, w, water_level)
            for r in range(n):
                out[r, i, j] = w[r]


def region_weights(
    heights: Any,
    regions: list[Region],
    *,
    jitter: float = 0.0,
    seed: int = 0,
    slope: Any = None,
    slope_rule: SlopeRule | bool | None = None,
    water_level: float | None = None,
) -> np.ndarray:
    """Per-sample region weights, Filipović 2008 §3.1.1 ``tezina``, normalised to sum to 1.

    ``w_k = max(0, (range_k - |h - max_k|)/range_k)``, then divided by ``Σ w``. Where every
    band's weight is 0 the nearest band (smallest ``|h - max_k| - range_k``; unjittered for
    bands the jitter cannot bring within reach) gets weight 1. The slope rule is applied last.

    Parameters
    ----------
    heights
        ``(rows, cols)`` heights (world units); NaN is rejected.
    regions
        Non-empty list of :class:`Region`; output layer ``k`` belongs to ``regions[k]``.
    jitter
        Band-limit jitter in ``[0, 1]``, as a fraction of each band's ``range``: band peaks move
        by ``jitter·range·n(x, z)`` with smooth seeded noise ``n ∈ [-1, 1]`` (one independent
        field per band, a function of the map fraction so every output scale agrees). Never
        applied to water.
    seed
        Seed of the jitter noise.
    slope
        Slope angles in radians, same shape as ``heights`` (e.g. ``Heightmap.slope()``);
        needed when a slope rule is on.
    slope_rule
        ``None``/``False``: off. ``True``: :class:`SlopeRule` defaults if a ``rock`` region
        exists (else off). A :class:`SlopeRule`: applied, its region must exist.
    water_level
        Heights at or below it are water (weight 1), heights above it never are: the water
        band does not blend up the slopes. Default: the water band's ``max`` (where it is
        pure). Ignored without a band named ``water``.

    Returns
    -------
    numpy.ndarray
        ``float32 (R, rows, cols)``; weights are >= 0 and sum to 1 over ``R``.
    """
    h = as_height_array(heights)
    regions = _check_regions(regions)
    jitter = check_range(jitter, "jitter", 0.0, 1.0)
    rule, s0, s1 = _resolve_slope_rule(slope_rule, regions)
    if rule >= 0:
        if slope is None:
            raise InvalidParameterError(
                "the slope rule needs slope angles (radians), e.g. Heightmap.slope(); got None"
            )
        slope_arr = _check_same_shape(slope, h.shape, "slope")
    else:
        slope_arr = np.zeros((1, 1), dtype=np.float32)
    maxs, ranges, amps, lat1, lat2 = _region_arrays(regions, jitter, seed)
    out = np.empty((len(regions), *h.shape), dtype=np.float32)
    run_stoppable(h.size > _LONG_SAMPLES, _weights_kernel, h, slope_arr, rule >= 0, maxs,
                  ranges, amps, lat1, lat2, rule, _water_index(regions), s0, s1,
                  _water_level(regions, water_level), out)
    return out


def _water_level(regions: list[Region], water_level: float | None) -> float:
    """The water line: ``water_level`` or the water band's ``max``; -inf without water."""
    k = _water_index(regions)
    if k < 0:
        return -math.inf
    if water_level is None:
        return float(regions[k].max)
    return check_finite(water_level, "water_level")


def _check_same_shape(array: Any, shape: tuple[int, int], name: str) -> np.ndarray:
    a = np.asarray(array)
    if a.shape != tuple(shape):
        raise InvalidParameterError(
            f"{name} must have the heights' shape {tuple(shape)} (rows, cols), got {a.shape}"
        )
    a = np.ascontiguousarray(a, dtype=np.float32)
    if not np.isfinite(a).all():
        raise InvalidParameterError(f"{name} contains NaN/infinite values")
    return a


# --- the texture ------------------------------------------------------------------------------
@njit(cache=CACHE, fastmath=FASTMATH)
def _bilinear(a, y, x):
    """Clamped bilinear sample of 2-D ``a`` at fractional ``(y, x)`` inside the grid."""
    rows, cols = a.shape
    i = min(int(y), rows - 2)
    j = min(int(x), cols - 2)
    fy = y - i
    fx = x - j
    top = a[i, j] + (a[i, j + 1] - a[i, j]) * fx
    bottom = a[i + 1, j] + (a[i + 1, j + 1] - a[i + 1, j]) * fx
    return top + (bottom - top) * fy


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _texture_kernel(heights, slope, use_slope, lightmap, use_light, maxs, ranges, amps, lat1,
                    lat2, rule, water, s0, s1, water_level, textures, tex_per_x, tex_per_z,
                    hex_seed, out):
    rows, cols = heights.shape
    h_out, w_out = out.shape[0], out.shape[1]
    n = maxs.shape[0]
    sy = (rows - 1) / (h_out - 1)
    sx = (cols - 1) / (w_out - 1)
    same_grid = h_out == rows and w_out == cols
    if use_light:
        ly_scale = (lightmap.shape[0] - 1) / (h_out - 1)
        lx_scale = (lightmap.shape[1] - 1) / (w_out - 1)
    else:
        ly_scale = 0.0
        lx_scale = 0.0
    for oi in prange(h_out):
        w = np.empty(n)
        c1 = np.empty(3)
        c2 = np.empty(3)
        c3 = np.empty(3)
        y = oi * sy
        v = oi / (h_out - 1)
        tv = y * tex_per_z  # texture repeats along z
        for oj in range(w_out):
            x = oj * sx
            if same_grid:  # scale 1: texel = vertex, no interpolation needed
                h = heights[oi, oj]
                s = slope[oi, oj] if use_slope else 0.0
            else:
                h = _bilinear(heights, y, x)
                s = _bilinear(slope, y, x) if use_slope else 0.0
            _texel_weights(h, s, oj / (w_out - 1), v, maxs, ranges, amps, lat1, lat2, rule,
                           water, s0, s1, w, water_level)
            # Hex-tiling instead of wrap sampling: no texture period (Mikkelsen 2022).
            tu = x * tex_per_x
            g = _hex_grid(tu, tv)
            u1, v1, _, _ = _vertex_uv(g[0], g[1], tu, tv, hex_seed, HEX_ROTATION)
            u2, v2, _, _ = _vertex_uv(g[2], g[3], tu, tv, hex_seed, HEX_ROTATION)
            u3, v3, _, _ = _vertex_uv(g[4], g[5], tu, tv, hex_seed, HEX_ROTATION)
            light = 1.0
            if use_light:
                light = _bilinear(lightmap, oi * ly_scale, oj * lx_scale)
            acc0 = 0.0
            acc1 = 0.0
            acc2 = 0.0
            for r in range(n):
                wr = w[r]
                if wr > 0.0:
                    tex = textures[r]
                    _bilinear_wrap_all(tex, u1, v1, c1)
                    _bilinear_wrap_all(tex, u2, v2, c2)
                    _bilinear_wrap_all(tex, u3, v3, c3)
                    # Luminance in [0, 1] weights the transitions (Mikkelsen's contrast term).
                    p, q, t = _hex_weights(g[6], g[7], g[8],
                                           (c1[0] + c1[1] + c1[2]) * (1.0 / 765.0),
                                           (c2[0] + c2[1] + c2[2]) * (1.0 / 765.0),
                                           (c3[0] + c3[1] + c3[2]) * (1.0 / 765.0),
                                           HEX_CONTRAST, HEX_SHARPNESS)
                    acc0 += wr * (p * c1[0] + q * c2[0] + t * c3[0])
                    acc1 += wr * (p * c1[1] + q * c2[1] + t * c3[1])
                    acc2 += wr * (p * c1[2] + q * c2[2] + t * c3[2])
            out[oi, oj, 0] = np.uint8(min(max(acc0 * light + 0.5, 0.0), 255.0))
            out[oi, oj, 1] = np.uint8(min(max(acc1 * light + 0.5, 0.0), 255.0))
            out[oi, oj, 2] = np.uint8(min(max(acc2 * light + 0.5, 0.0), 255.0))


def _check_lightmap(lightmap: Any) -> np.ndarray:
    lm = np.asarray(lightmap)
    if lm.ndim != 2 or lm.shape[0] < 2 or lm.shape[1] < 2:
        raise InvalidParameterError(
            f"lightmap must be a 2-D float array of at least 2×2, got shape {lm.shape}"
        )
    lm = np.ascontiguousarray(lm, dtype=np.float32)
    if not np.isfinite(lm).all():
        raise InvalidParameterError("lightmap contains NaN/infinite values")
    lo, hi = float(lm.min()), float(lm.max())
    if lo < 0.0 or hi > 1.0:
        raise InvalidParameterError(f"lightmap values must be in [0, 1], got [{lo:.4g}, {hi:.4g}]")
    return lm


def _mip_size(texture_size: int, texels_per_output: float) -> int:
    """Texture side after pre-filtering so one output texel covers about one texture texel.

    Without this, a 256-px texture tiled every 32 cells and sampled once per cell would skip
    8 texels per sample (aliasing); a 2×2 box-mip chain removes it cheaply.
    """
    size = texture_size
    while texels_per_output >= 2.0 and size % 2 == 0 and size > 4:
        size //= 2
        texels_per_output /= 2.0
    return size


def region_texture(
    heightmap: Heightmap | Any,
    regions: list[Region] | None = None,
    *,
    scale: int = 1,
    jitter: float = 0.0,
    seed: int = 0,
    slope_rule: SlopeRule | bool | None = True,
    lightmap: Any = None,
    texture_size: int = 256,
    tile_size: float | None = None,
    water_level: float | None = None,
) -> np.ndarray:
    """Procedural terrain colour texture from height regions (``stvori_teksturu`` of
    Filipović 2008 §3.1.1).

    Parameters
    ----------
    heightmap
        A :class:`~terrascape.heightmap.Heightmap` (or a 2-D array, unit spacing).
    regions
        Bands; default :func:`default_regions` of the map.
    scale
        Integer output multiple: the texture is ``(rows·scale, cols·scale)``; heights, slopes
        and the lightmap are bilinearly interpolated (corner-aligned grid, see module doc).
    jitter, seed
        Band jitter (fraction of ``range``, never water) and seed, as in :func:`region_weights`;
        the seed also seeds the built-in materials.
    slope_rule
        As in :func:`region_weights` (default ``True``: rock from 30° to 45° if a rock band
        exists). Slopes come from :meth:`Heightmap.slope` (world units, spacing included).
    lightmap
        Optional float ``(r, c)`` array in ``[0, 1]`` of any size ≥ 2×2, resampled bilinearly to
        the output and multiplied in (e.g. slope shading / shadows,).
    texture_size
        Side of built-in textures; user images are resized to it.
    tile_size
        World units covered by one repeat of each material texture; default
        ``32 × max(spacing)``. Textures are hex-tiled (:mod:`terrascape.texture.hextile`:
        random offsets and rotations per hexagon, so no period shows) and box-pre-filtered
        to the output footprint.
    water_level
        Water colour only at or below this height (default: the water band's ``max``), as
        in :func:`region_weights`.

    Returns
    -------
    numpy.ndarray
        ``uint8 (rows·scale, cols·scale, 3)`` RGB.
    """
    hm = heightmap if isinstance(heightmap, Heightmap) else Heightmap(heightmap)
    regions = _check_regions(default_regions(hm) if regions is None else regions)
    scale = check_int(scale, "scale", minimum=1, maximum=64)
    jitter = check_range(jitter, "jitter", 0.0, 1.0)
    texture_size = check_int(texture_size, "texture_size", minimum=4, maximum=8192)
    dx, dz = hm.spacing
    tile = 32.0 * max(dx, dz) if tile_size is None else check_positive(tile_size, "tile_size")
    rule, s0, s1 = _resolve_slope_rule(slope_rule, regions)
    lm = _check_lightmap(lightmap) if lightmap is not None else np.ones((2, 2), np.float32)

    h_out, w_out = hm.rows * scale, hm.cols * scale
    world_per_texel = min(dx * (hm.cols - 1) / (w_out - 1), dz * (hm.rows - 1) / (h_out - 1))
    size = _mip_size(texture_size, texture_size / tile * world_per_texel)
    textures = np.empty((len(regions), size, size, 3), dtype=np.float32)
    for k, reg in enumerate(regions):
        tex = load_texture(reg.texture, default_name=reg.name, size=texture_size, seed=seed)
        textures[k] = resize_rgb(tex, (size, size))

    slope = hm.slope() if rule >= 0 else np.zeros((2, 2), np.float32)
    maxs, ranges, amps, lat1, lat2 = _region_arrays(regions, jitter, seed)
    out = np.empty((h_out, w_out, 3), dtype=np.uint8)
    # Texels per heightmap sample step along x / z: world step × texture texels per world unit.
    # Texture repeats per heightmap sample step along x / z.
    _texture_kernel(hm.heights, slope, rule >= 0, lm, lightmap is not None, maxs, ranges, amps,
                    lat1, lat2, rule, _water_index(regions), s0, s1,
                    _water_level(regions, water_level), textures, dx / tile, dz / tile,
                    int(seed) & 0xFFFFFFFF, out)
    return out


__all__ = ["Region", "SlopeRule", "default_regions", "region_texture", "region_weights"]
