"""The ``material`` technique: photo material layers blended by slope, height, curvature and
erosion masks, hex-tiled so no texture period shows, with detail normal maps.

Textures (built from the heightmap and parameters):

* ``u_weights0``/``u_weights1``: :func:`terrascape.texture.material_weights` packed four
  layers per RGBA texture (:func:`terrascape.texture.pack_splat_maps`), one texel per vertex;
* ``u_layers``: the photo albedo layers (RGB + detail height in A) as a texture array;
* ``u_normals``: their detail normal maps (tangent-space x, y).

Parameters: the masks ``flow``, ``deposition``, ``wear``, ``water`` (float arrays of the
heightmap's shape, or ``None``), ``snow_line`` and ``water_level`` (world units, ``None``:
automatic / no water level), ``hex_rotation``, ``hex_contrast``, ``hex_sharpness``,
``hex_seed`` (hex-tiling), ``blend_depth`` (height-blend transition) and
``detail_strength`` (detail normals' tilt), plus every common parameter (``tile_size``,
``material_size``, ``seed``, lighting, fog, …). The program is
``render/shaders/terrain/material.glsl``; :func:`terrascape.texture.material_texture` draws
the same blend as a top-down image.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from typing import Any

import numpy as np

from terrascape.heightmap import Heightmap
from terrascape.render.techniques import (
    LIGHTMAP_SLOT,
    Technique,
    TextureData,
    TextureSlot,
    register_technique,
)
from terrascape.texture.hextile import HEX_CONTRAST, HEX_ROTATION, HEX_SHARPNESS
from terrascape.texture.terrain_material import BLEND_DEPTH, MASK_NAMES

MATERIAL_DEFAULTS: dict[str, Any] = {
    "flow": None,
    "deposition": None,
    "wear": None,
    "water": None,
    "snow_line": None,
    "water_level": None,
    "hex_rotation": HEX_ROTATION,
    "hex_contrast": HEX_CONTRAST,
    "hex_sharpness": HEX_SHARPNESS,
    "hex_seed": 0,
    "blend_depth": BLEND_DEPTH,
    "detail_strength": 1.0,
}
_WEIGHT_DEPS = ("seed", "snow_line", "water_level", *MASK_NAMES)
_cache: dict[str, list[np.ndarray]] = {}


def _digest(*arrays: Any) -> str:
    h = hashlib.sha1()
    for a in arrays:
        if a is None:
            h.update(b"none")
        else:
            arr = np.ascontiguousarray(a)
            h.update(repr((arr.dtype.str, arr.shape)).encode())
            h.update(arr.tobytes())
    return h.hexdigest()


class MaskParam:
    """A mask array with a content-hash ``repr``: the renderer rebuilds a texture when the
    ``repr`` of a parameter it depends on changes, and numpy's ``repr`` of a large array
    shows only its corners (two masks differing inside would look equal)."""

    __slots__ = ("array", "digest")

    def __init__(self, array: Any) -> None:
        self.array = array
        self.digest = _digest(array)

    def __repr__(self) -> str:
        return f"MaskParam(sha1={self.digest})"


def _unwrap(value: Any) -> Any:
    return value.array if isinstance(value, MaskParam) else value


class MaterialTechnique(Technique):
    """:class:`Technique` whose mask parameters are wrapped in :class:`MaskParam`."""

    def resolve(self, params: Mapping[str, Any] | None) -> dict[str, Any]:
        merged = super().resolve(params)
        for name in MASK_NAMES:
            value = merged.get(name)
            if value is not None and not isinstance(value, MaskParam):
                merged[name] = MaskParam(value)
        return merged


def material_weight_maps(hm: Heightmap, params: Mapping[str, Any]) -> list[np.ndarray]:
    """The packed RGBA weight maps of ``params`` (cached on the heights, masks and rules)."""
    from terrascape.texture import pack_splat_maps
    from terrascape.texture.terrain_material import MaterialRules, material_weights

    masks = {name: _unwrap(params.get(name)) for name in MASK_NAMES
             if params.get(name) is not None}
    key = _digest(hm.heights, np.asarray(hm.spacing),
                  *(_unwrap(params.get(n)) for n in MASK_NAMES))
    key += repr((params.get("snow_line"), params.get("water_level"), int(params["seed"])))
    if key not in _cache:
        rules = MaterialRules(snow_line=params.get("snow_line"),
                              water_level=params.get("water_level"))
        weights = material_weights(hm, masks=masks, rules=rules, seed=int(params["seed"]))
        if len(_cache) > 4:
            _cache.clear()
        _cache[key] = pack_splat_maps(weights)
    return _cache[key]


def build_weights0(hm: Heightmap, params: Mapping[str, Any]) -> TextureData:
    """Layers 0-3 (grass, meadow, rock, scree) of the material weights, RGBA per vertex."""
    return TextureData(material_weight_maps(hm, params)[0], repeat=False)


def build_weights1(hm: Heightmap, params: Mapping[str, Any]) -> TextureData:
    """Layers 4-6 (sediment, snow, water) of the material weights, RGB(A) per vertex."""
    return TextureData(material_weight_maps(hm, params)[1], repeat=False)


def build_layer_albedo(hm: Heightmap, params: Mapping[str, Any]) -> TextureData:
    """Photo albedo layers (RGB) with their detail height (A), a tiled texture array."""
    from terrascape.texture.photo_materials import photo_material_layers

    layers = photo_material_layers(int(params["material_size"]), seed=int(params["seed"]))
    # Nearest mip level: each pixel reads the layers 18 times (3 layers × 3 hex lookups ×
    # albedo and normal), and the hex blend hides the level steps.
    return TextureData(np.ascontiguousarray(layers.albedo), kind="array", repeat=True,
                       mip_blend=False)


def build_layer_normals(hm: Heightmap, params: Mapping[str, Any]) -> TextureData:
    """Detail normal maps of the photo layers (tangent space x, y as RG), a tiled texture
    array. The shader needs only x and y (it rebuilds z after the blend), so two channels:
    half the texel bytes each of its nine lookups per pixel reads."""
    from terrascape.texture.photo_materials import photo_material_layers

    layers = photo_material_layers(int(params["material_size"]), seed=int(params["seed"]))
    return TextureData(np.ascontiguousarray(layers.normals[..., :2]), kind="array",
                       repeat=True, mip_blend=False)


MATERIAL_TECHNIQUE = register_technique(
    MaterialTechnique(
        "material",
        "terrain/material",
        deferred=True,
        textures=(
            TextureSlot("u_weights0", build_weights0, depends=_WEIGHT_DEPS,
                        description="material weights of grass, meadow, rock, scree"),
            TextureSlot("u_weights1", build_weights1, depends=_WEIGHT_DEPS,
                        description="material weights of sediment, snow, water"),
            TextureSlot("u_layers", build_layer_albedo, depends=("seed", "material_size"),
                        description="photo albedo + detail height layers (texture array)"),
            TextureSlot("u_normals", build_layer_normals, depends=("seed", "material_size"),
                        description="photo detail normal maps (texture array)"),
            LIGHTMAP_SLOT,
        ),
        defaults=MATERIAL_DEFAULTS,
        # the masks and rules are baked into the weight textures
        cpu_params=frozenset({*MASK_NAMES, "snow_line", "water_level"}),
        description="photo materials by slope, height, curvature and erosion masks, "
                    "hex-tiled, with detail normals",
    ),
    replace=True,
)

__all__ = ["MATERIAL_DEFAULTS", "MATERIAL_TECHNIQUE", "MaskParam", "MaterialTechnique",
           "material_weight_maps"]
