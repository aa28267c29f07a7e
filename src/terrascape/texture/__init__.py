"""Terrain texture synthesis (MISSION T1–T3, seed 001 §3.1): height regions, 3D-texture layer
stacks, splat maps, and procedural built-in materials. Pure numpy/numba, no OpenGL."""

from terrascape.texture.layer_stack import layer_coordinate, layer_stack
from terrascape.texture.materials import BUILTIN_MATERIALS, builtin_material, read_image_rgb
from terrascape.texture.regions import (
    Region,
    SlopeRule,
    default_regions,
    region_texture,
    region_weights,
)
from terrascape.texture.splat import (
    block_layers,
    check_material_map,
    material_ids_from_rules,
    pack_splat_maps,
    splat_weights,
    unpack_splat_maps,
)

__all__ = [
    "BUILTIN_MATERIALS",
    "Region",
    "SlopeRule",
    "block_layers",
    "builtin_material",
    "check_material_map",
    "default_regions",
    "layer_coordinate",
    "layer_stack",
    "material_ids_from_rules",
    "pack_splat_maps",
    "read_image_rgb",
    "region_texture",
    "region_weights",
    "splat_weights",
    "unpack_splat_maps",
]
