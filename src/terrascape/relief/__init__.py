"""Relief texturing on the CPU: test height fields, the exact per-pixel
reference tracer, pre-warped relief texture mapping (Oliveira 2000), cone maps and min/max
mip pyramids. No OpenGL here — the GLSL techniques live in ``terrascape.render``
(``relief_quad``, ``relief_techniques``, ``shaders/relief/``).

References
----------
- D. Janković, "Reljefne tehnike teksturiranja u prikazu terena" (Relief texturing techniques
  in terrain rendering), MSc thesis 62, Faculty of Electrical Engineering and Computing,
  University of Zagreb, 2010, §2.3–2.4.
"""

from terrascape.relief.cone_map import cone_map, cone_map_bruteforce, footprint_cone_map
from terrascape.relief.fields import city_field, natural_field
from terrascape.relief.minmax_mip import minmax_mip
from terrascape.relief.prewarp import (
    PrewarpCoefficients,
    prewarp,
    prewarp_coefficients,
    relief_texture_image,
    sample_bilinear,
)
from terrascape.relief.reference import (
    ReferenceImage,
    ReliefQuad,
    heights_to_depth,
    light_slope,
    pixel_rays,
    quad_entry,
    reference_image,
    shadow_exact,
    trace_exact,
)

__all__ = [
    "PrewarpCoefficients",
    "ReferenceImage",
    "ReliefQuad",
    "city_field",
    "cone_map",
    "cone_map_bruteforce",
    "footprint_cone_map",
    "heights_to_depth",
    "light_slope",
    "minmax_mip",
    "natural_field",
    "pixel_rays",
    "prewarp",
    "prewarp_coefficients",
    "quad_entry",
    "reference_image",
    "relief_texture_image",
    "sample_bilinear",
    "shadow_exact",
    "trace_exact",
]
