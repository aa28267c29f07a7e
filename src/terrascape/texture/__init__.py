"""Terrain texture synthesis (Filipović 2008 §3.1): height regions, 3D-texture layer stacks, splat
maps, procedural built-in materials, photo material layers, hex-tiling and the default
terrain material blend. Pure numpy/numba, no OpenGL."""

from terrascape.texture.hextile import hex_tile
from terrascape.texture.layer_stack import layer_coordinate, layer_stack
from terrascape.texture.materials import BUILTIN_MATERIALS, builtin_material, read_image_rgb
from terrascape.texture.photo_materials import (
    MATERIAL_LAYERS,
    MaterialLayers,
    detail_normal_height,
    photo_material,
    photo_material_layers,
)
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
from terrascape.texture.terrain_material import (
    MASK_NAMES,
    MaterialRules,
    material_texture,
    material_weights,
)

__all__ = [
    "BUILTIN_MATERIALS",
    "MASK_NAMES",
    "MATERIAL_LAYERS",
    "MaterialLayers",
    "MaterialRules",
    "Region",
    "SlopeRule",
    "block_layers",
    "builtin_material",
    "check_material_map",
    "default_regions",
    "detail_normal_height",
    "hex_tile",
    "layer_coordinate",
    "layer_stack",
    "material_ids_from_rules",
    "material_texture",
    "material_weights",
    "pack_splat_maps",
    "photo_material",
    "photo_material_layers",
    "read_image_rgb",
    "region_texture",
    "region_weights",
    "splat_weights",
    "unpack_splat_maps",
]
