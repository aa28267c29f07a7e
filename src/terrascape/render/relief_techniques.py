"""Relief techniques registered into the terrain renderer's technique registry.

Each is the program ``relief/terrain.glsl`` compiled with its ``TECHNIQUE`` define, sampling
a tiled RGBA normal+height texture (``u_relief``; Janković 2010 §2.3.1) planar-mapped over the
terrain (``uv_scale`` repeats: tiled; ``uv_scale = 1``: stretched) and the terrain's colour
texture. Parameters (uniforms ``u_<name>``) can change every frame: ``depth`` (UV units),
``linear_steps``, ``binary_steps``, ``adaptive``/``step_texels``/``max_steps``,
``shadow_steps``, ``self_shadow``, ``parallax_scale``/``parallax_bias``, the distance
bands of ``relief_by_distance`` and the screen-space level of detail of ``relief``
and ``parallax`` (``relief_lod``, on by default, with ``lod_step``, ``lod_precision``,
``lod_min_span``, ``lod_nearest_from``): where the relief texture is minified the march
takes as many steps as the ray is long in texels of the sampled mip level, with
``linear_steps``/``binary_steps`` as the upper bounds; where it is magnified it is the
fixed relief 16+8. Their march reads ``u_relief_height``, the height channel alone.

Registered: ``parallax``, ``parallax_limited``, ``steep_parallax`` and ``pom``,
``relief`` (with self-shadowing), ``interval``, ``relief_by_distance``, ``cone`` (cone step
mapping; its cone map is sampled NEAREST) and ``minmax`` (the
exact min/max-mip tracer, whose depth pyramid is uploaded as an explicit mip chain).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.render.relief_quad import TECHNIQUES, relief_texture_data
from terrascape.render.techniques import (
    Technique,
    TextureData,
    TextureSlot,
    build_region_texture,
    register_technique,
)

FIELDS = ("city", "natural", "photo")
#: The terrain's default relief texture: a natural field (smooth fBm hills and crevices)
#: instead of the thesis's city blocks, which tile the whole terrain with glossy slabs; the
#: urban fields stay selectable (``relief_field="city"``) for the measurements.
TERRAIN_RELIEF_FIELD = "natural"


def _relief_heights(params: Mapping[str, Any]) -> np.ndarray:
    from terrascape.relief.fields import city_field, natural_field

    name = params["relief_field"]
    if isinstance(name, np.ndarray):
        return name
    if name == "photo":
        from terrascape.texture.photo_materials import photo_material_layers

        size = int(params["relief_size"])
        size = 1 << max(4, min(11, size.bit_length() - 1))
        rock = photo_material_layers(size, seed=int(params["seed"])).albedo[2, ..., 3]
        return rock.astype(np.float32) / np.float32(255.0)
    if name in FIELDS:
        maker = city_field if name == "city" else natural_field
        return maker(int(params["relief_size"]), seed=int(params["seed"]))
    raise InvalidParameterError(
        f"relief_field must be one of {FIELDS} or a (rows, cols) array of heights in "
        f"[0, 1], got {name!r}"
    )


# The terrain's relief texture precision: 16-bit codes (relief_texture_data(bits=16)).
TERRAIN_RELIEF_BITS = 16


def _sampled_relief_heights(params: Mapping[str, Any]) -> np.ndarray:
    """The relief field's heights as the 16-bit texture samples them: what the min/max
    pyramid and the cone map must be built from so the tracers trace the drawn surface."""
    from terrascape.relief.fields import sampled_heights

    return sampled_heights(_relief_heights(params), TERRAIN_RELIEF_BITS)


def build_relief_texture(hm: Heightmap, params: Mapping[str, Any]) -> TextureData:
    """Tiled RGBA (normal, height) texture of the ``relief_field`` test field (16-bit)."""
    data = relief_texture_data(_relief_heights(params), depth=float(params["depth"]),
                               bits=TERRAIN_RELIEF_BITS)
    return TextureData(data, repeat=True, mipmaps=True)


def build_relief_height(hm: Heightmap, params: Mapping[str, Any]) -> TextureData:
    """The height (A) channel of :func:`build_relief_texture` alone, one channel, same values
    and mipmaps: the terrain program's ray march reads only heights, and on llvmpipe a
    one-channel float texel costs a fraction of the RGBA one."""
    data = relief_texture_data(_relief_heights(params), depth=float(params["depth"]),
                               bits=TERRAIN_RELIEF_BITS)
    return TextureData(np.ascontiguousarray(data[..., 3]), repeat=True, mipmaps=True)


def build_cone_map(hm: Heightmap, params: Mapping[str, Any]) -> TextureData:
    """Cone map of the same relief field (apex depth, cone ratio), sampled NEAREST
    (Dummer 2006 cone step mapping; :func:`terrascape.relief.cone_map.footprint_cone_map`)."""
    from terrascape.relief.cone_map import footprint_cone_map

    cone = footprint_cone_map(_sampled_relief_heights(params))
    return TextureData(np.ascontiguousarray(cone, dtype=np.float32), repeat=True,
                       mipmaps=False, nearest=True)


RELIEF_DEFAULTS: dict[str, Any] = {
    "depth": 0.05,
    "linear_steps": 16,
    "binary_steps": 8,
    "adaptive": False,
    "step_texels": 2.0,
    "max_steps": 96,
    "shadow_steps": 16,
    "self_shadow": True,
    "parallax_scale": 0.05,
    "parallax_bias": -0.05,
    "cone_steps": 32,
    "max_iterations": 1024,
    "dist_relief": 200.0,
    "dist_parallax": 600.0,
    "dist_band": 100.0,
    "relief_field": TERRAIN_RELIEF_FIELD,
    "relief_size": 256,
    "relief_tint": 0.5,
    "ks": 0.15,
    # Screen-space LOD of the terrain relief march (relief/terrain.glsl), on by default (its
    # image error against relief 16+8 is measured in bench relief's seed table): linear
    # steps of lod_step texels of the sampled mip level (longer by clearance for a surface
    # slope lod_clearance > 0), binary steps down to lod_precision pixels and the secant
    # hit (lod_secant), one parallax step (parallax: none) where the whole ray spans less
    # than lod_min_span pixels, the full counts where the texture is magnified; from mip
    # level lod_nearest_from on (< 0: never) the height fetches read the nearest mip level.
    "relief_lod": True,
    "lod_step": 1.0,
    "lod_precision": 0.25,
    "lod_secant": True,
    "lod_clearance": 0.0,
    "lod_min_span": 0.5,
    "lod_nearest_from": 3.0,
}

# The relief field's parameters are baked into its textures.
RELIEF_CPU_PARAMS = frozenset({"relief_field", "relief_size"})

_SLOTS = (
    TextureSlot("u_color_tex", build_region_texture, depends=("seed", "regions"),
                description="colour texture, one texel per vertex (region_texture)"),
    TextureSlot("u_relief", build_relief_texture,
                depends=("relief_field", "relief_size", "seed", "depth"),
                description="tiled RGBA normal + height (16-bit) of the relief field"),
    TextureSlot("u_relief_height", build_relief_height,
                depends=("relief_field", "relief_size", "seed", "depth"),
                description="the height channel of u_relief alone (the march's texture)"),
)

def build_minmax_pyramid(hm: Heightmap, params: Mapping[str, Any]) -> TextureData:
    """Min/max depth pyramid of the relief field as one explicit NEAREST RGBA mip chain
    (maximum mipmaps / quadtree displacement mapping): level 0 holds each cell's four corner
    depths, level k ``(min, max, min, max)`` of its 2^k × 2^k cells, so the exact tracer reads
    one texel per node (:func:`terrascape.relief.minmax_mip.packed_minmax_mip`)."""
    from terrascape.relief.minmax_mip import packed_minmax_mip

    levels = [np.ascontiguousarray(lv, dtype=np.float32) for lv in
              packed_minmax_mip(_sampled_relief_heights(params))]
    return TextureData(levels[0], repeat=True, mipmaps=False, nearest=True,
                       levels=tuple(levels[1:]))


_MINMAX_SLOTS = (
    *_SLOTS,
    TextureSlot("u_minmax", build_minmax_pyramid, depends=("relief_field", "relief_size", "seed"),
                description="min/max depth pyramid of the relief field (explicit RGBA mip "
                            "chain, level 0 = cell corners)"),
)

_CONE_SLOTS = (
    *_SLOTS,
    TextureSlot("u_cone", build_cone_map, depends=("relief_field", "relief_size", "seed"),
                description="cone map (apex depth, cone ratio) of the relief field, NEAREST"),
)

_TERRAIN_NAMES = {
    "parallax": ("parallax", "Janković 2010: Tn = Tv + h'·V.xy/V.z"),
    "parallax_limited": ("offset_limiting", "Janković 2010: offset limiting Tn = Tv + h'·V.xy"),
    "steep_parallax": ("steep", "steep parallax (linear search)"),
    "pom": ("pom", "parallax occlusion mapping"),
    "relief": ("relief", "relief mapping, linear + binary search, self-shadowing"),
    "interval": ("interval", "interval mapping, linear + secant search"),
    "relief_by_distance": ("by_distance", "relief near, parallax farther, plain far"),
    "cone": ("cone", "cone step mapping (Dummer 2006) with a CPU-built cone map"),
    "minmax": ("minmax", "exact hierarchical min/max-mip tracer (maximum mipmaps)"),
}


def register_relief_techniques(*, replace: bool = True) -> list[str]:
    """Register the terrain relief techniques (idempotent); returns their names."""
    for name, (tech, text) in _TERRAIN_NAMES.items():
        register_technique(
            Technique(
                name,
                "relief/terrain",
                textures={"cone": _CONE_SLOTS, "minmax": _MINMAX_SLOTS}.get(tech, _SLOTS),
                defaults=RELIEF_DEFAULTS,
                defines={"TECHNIQUE": TECHNIQUES[tech]},
                description=text,
                deferred=True,
                cpu_params=RELIEF_CPU_PARAMS,
            ),
            replace=replace,
        )
    return list(_TERRAIN_NAMES)


register_relief_techniques()

#: Registered terrain relief technique → the relief quad's (:mod:`relief_quad`) name for the
#: same method, so ``terrascape relief`` takes the same names as ``render`` and ``view``.
QUAD_TECHNIQUE: dict[str, str] = {"plain": "plain",
                                  **{name: tech for name, (tech, _) in _TERRAIN_NAMES.items()}}


def quad_technique(name: str) -> str:
    """The relief quad's technique for a registered name or any alias of one (old relief
    quad spellings such as ``steep`` included, with a deprecation note)."""
    from terrascape.errors import InvalidParameterError
    from terrascape.render.techniques import canonical_technique_name

    canonical = canonical_technique_name(name)
    if canonical not in QUAD_TECHNIQUE:
        raise InvalidParameterError(
            f"unknown relief technique {name!r}; available: {', '.join(QUAD_TECHNIQUE)}")
    return QUAD_TECHNIQUE[canonical]


def relief_variant(name: str, label: str | None = None, **defines: Any) -> Technique:
    """An unregistered copy of the relief technique ``name`` with extra or replaced
    ``#define``s, for benchmarks and tests (pass it to ``TerrainRenderer.render``):
    ``TECHNIQUE=0`` maps the relief texture without displacement (the same textures,
    normal mapping and lighting: the like-for-like "texture mapping" of Janković 2010 §2.7);
    ``TERRAIN_OUTPUT_FETCHES=1`` draws each fragment's height fetches (R, count / 255) and
    mip level (G, level / 16, 0 where magnified) instead of its colour."""
    import dataclasses

    from terrascape.render.techniques import get_technique

    base = get_technique(name)
    merged = {**base.defines, **defines}
    tag = label or name + "".join(f"+{k}={v}" for k, v in sorted(defines.items()))
    return dataclasses.replace(base, name=tag, defines=merged)


__all__ = ["QUAD_TECHNIQUE", "RELIEF_DEFAULTS", "build_relief_height", "build_relief_texture",
           "quad_technique", "register_relief_techniques", "relief_variant"]
