"""Lighting: normals and normal maps, height from photos, slope shading, shadows, sky view,
and the daylight model (sun + sky + bounce, tone-mapped) that ``lightmap`` uses by default.

Slope shading, shadow maps by ray casting and a fast exact sweep, normal + height textures
and height approximated from a photo. Pure numpy/numba — no OpenGL.

References
----------
- D. Filipović, "Generiranje i prikaz terena" (Terrain generation and display), BSc thesis 221,
  Faculty of Electrical Engineering and Computing, University of Zagreb, 2008, §3.2.2.
- D. Janković, "Reljefne tehnike teksturiranja u prikazu terena" (Relief texturing techniques
  in terrain rendering), MSc thesis 62, Faculty of Electrical Engineering and Computing,
  University of Zagreb, 2010, §2.3.1, §2.7.
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
