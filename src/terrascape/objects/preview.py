"""A top-down map of placed objects: the shaded terrain, each object a disc of its model's
footprint in the model's colour (``terrascape objects scatter --preview``)."""

from __future__ import annotations

import numpy as np

from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.objects.model import Instances

__all__ = ["MARK_COLOURS", "objects_preview"]

#: sRGB colours of the built-in models' marks (other models: a neutral violet).
MARK_COLOURS = {
    "conifer": (20, 70, 35), "broadleaf": (95, 170, 45), "bush": (190, 200, 60),
    "rock": (120, 120, 125), "boulder": (60, 60, 66), "house": (220, 60, 40),
    "hall": (200, 40, 160),
}
_OTHER = (120, 80, 200)


def objects_preview(heightmap: Heightmap, instances: Instances, *,
                    max_side: int = 1024) -> np.ndarray:
    """uint8 ``(rows', cols', 3)`` image, north up, at most ``max_side`` pixels a side: the
    terrain (shaded, faded to grey so the marks stand out) with every object drawn as a
    disc as wide as its model's footprint × its scale (at least one pixel)."""
    from PIL import Image, ImageDraw

    from terrascape.notebook import heightmap_preview

    if not isinstance(instances, Instances):
        raise InvalidParameterError("objects_preview needs Instances")
    base = heightmap_preview(heightmap, max_side=max_side).astype(np.float64)
    grey = base.mean(axis=2, keepdims=True)
    img = Image.fromarray(np.clip(0.45 * base + 0.55 * grey, 0, 255).astype(np.uint8))
    # always max_side pixels on the longer side: small maps are enlarged so trees show
    ex, ez = heightmap.extent
    longest = max(ex, ez, 1e-12)
    size = (max(2, round(max_side * ex / longest)), max(2, round(max_side * ez / longest)))
    img = img.resize(size, Image.Resampling.BILINEAR)
    draw = ImageDraw.Draw(img)
    sx = (img.width - 1) / ex if ex > 0 else 1.0
    sz = (img.height - 1) / ez if ez > 0 else 1.0
    radius = []
    for mesh in instances.meshes:
        lo, hi = mesh.bounds
        radius.append(0.5 * float(max(hi[0] - lo[0], hi[2] - lo[2])))
    # big objects first, so trees stay visible next to the buildings they crowd
    order = sorted(range(len(instances)), key=lambda i: -radius[int(instances.kind[i])])
    for i in order:
        k = int(instances.kind[i])
        x, _, z = (float(v) for v in instances.positions[i])
        r = radius[k] * float(instances.scale[i])
        cx, cz = x * sx, z * sz
        rx, rz = max(r * sx, 0.5), max(r * sz, 0.5)
        colour = MARK_COLOURS.get(instances.meshes[k].name, _OTHER)
        draw.ellipse((cx - rx, cz - rz, cx + rx, cz + rz), fill=colour)
    return np.asarray(img)
