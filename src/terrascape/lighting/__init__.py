"""Lighting: normals and normal maps, height from photos, slope shading, shadows, sky view,
and the daylight model (sun + sky + bounce, tone-mapped) that ``lightmap`` uses by default.

MISSION T4 (slope shading, shadow maps by ray casting and a fast exact sweep; seed 001
§3.2.2) and T6 (normal + height textures, height approximated from a photo; seed 000 §2.3.1,
§2.7). Pure numpy/numba — no OpenGL.
"""

from terrascape.lighting.ambient_occlusion import sky_view_factor
from terrascape.lighting.daylight import Daylight, daylight, daylight_lightmap, lightmap
from terrascape.lighting.height_from_image import height_from_image, luminance
from terrascape.lighting.normals import (
    normal_map,
    pack_normal_height,
    tangent_space_normals,
    unpack_normals,
)
from terrascape.lighting.shadows import (
    shadow_mask,
    shadow_mask_reference,
    soft_shadow,
)
from terrascape.lighting.slope_shading import lambert
from terrascape.lighting.sun import sun_direction

__all__ = [
    "Daylight",
    "daylight",
    "daylight_lightmap",
    "height_from_image",
    "lambert",
    "lightmap",
    "luminance",
    "normal_map",
    "pack_normal_height",
    "shadow_mask",
    "shadow_mask_reference",
    "sky_view_factor",
    "soft_shadow",
    "sun_direction",
    "tangent_space_normals",
    "unpack_normals",
]
