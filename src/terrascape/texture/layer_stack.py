""""3D texture" blending: a stack of layer textures addressed by height
(Filipović 2008 §3.1.2, after Doug Sheets' OpenGL 3D texturing tutorial).

The layers are stored one after another (``r = 0`` first), and the hardware's linear
filtering along the depth coordinate ``r`` blends two adjacent layers. With ``L`` layers and
GL's texel-centre convention, layer ``i`` is sampled unblended at ``r = (i + 0.5)/L``;
between two centres the blend is linear. :func:`layer_coordinate` maps heights to ``r`` so
that this blend equals the thesis's region weights: between the peaks ``max_i`` and
``max_{i+1}`` of consecutive regions, ``r`` moves linearly from layer ``i``'s centre to layer
``i+1``'s. Below the lowest / above the highest peak ``r`` is clamped to the first / last
centre (use ``CLAMP_TO_EDGE`` for ``r`` so the top layer never wraps onto the bottom one).
For a texture *array* (``sampler2DArray``, integer layers) use ``r·L - 0.5`` and blend two
fetches.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from terrascape._validate import check_int
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.texture.materials import as_rgb_image, load_texture, resize_rgb
from terrascape.texture.regions import Region, _check_regions, default_regions


def _size_pair(size: Any) -> tuple[int, int]:
    if isinstance(size, (tuple, list)):
        if len(size) != 2:
            raise InvalidParameterError(f"size must be an int or (height, width), got {size!r}")
        return (check_int(size[0], "layer height", minimum=1, maximum=16384),
                check_int(size[1], "layer width", minimum=1, maximum=16384))
    s = check_int(size, "layer size", minimum=1, maximum=16384)
    return s, s


def layer_stack(layers: list[Any], size: int | tuple[int, int] | None = None) -> np.ndarray:
    """Stack layer textures into one ``(L, H, W, 3)`` volume (the 3D texture's data).

    Parameters
    ----------
    layers
        Images, bottom (``r = 0``) first: arrays ``(H, W)``/``(H, W, 1|3|4)`` (uint8, uint16 or
        float in [0, 1]); image file paths and built-in material names are accepted too.
    size
        Output ``(H, W)`` (or a single int for square); default the first layer's size. Other
        layers are resized (Lanczos; exact 2×2 box means for power-of-two reductions). Old GL
        needs powers of two here (Filipović 2008 §3.1.2); current GL does not.

    Returns
    -------
    numpy.ndarray
        ``uint8 (L, H, W, 3)``, C-contiguous — upload as ``GL_TEXTURE_3D`` or a texture array.
    """
    if isinstance(layers, np.ndarray) or layers is None:
        raise InvalidParameterError("layers must be a list of images, got a single array/None")
    layers = list(layers)
    if not layers:
        raise InvalidParameterError("expected at least one layer, got an empty list")
    images = []
    for k, layer in enumerate(layers):
        if isinstance(layer, np.ndarray):
            images.append(as_rgb_image(layer, name=f"layer {k}"))
        else:
            # Paths and built-in names: built-ins need a size; use the requested one or 256.
            side = _size_pair(size)[0] if size is not None else 256
            images.append(load_texture(layer, default_name=f"layer {k}", size=side))
    target = _size_pair(size) if size is not None else images[0].shape[:2]
    out = np.empty((len(images), target[0], target[1], 3), dtype=np.uint8)
    for k, img in enumerate(images):
        out[k] = resize_rgb(img, target)
    return out


def layer_coordinate(
    heightmap: Heightmap | Any, regions: list[Region] | None = None
) -> np.ndarray:
    """Height → 3D-texture depth coordinate ``r`` (Filipović 2008 §3.1.2).

    Layer ``i`` is ``regions[i]`` (default :func:`default_regions`); their ``max`` values must
    increase strictly. ``r`` is piecewise linear in height: ``(i + 0.5 + t)/L`` with
    ``t = (h - max_i)/(max_{i+1} - max_i)`` between consecutive peaks, clamped to
    ``[0.5/L, (L - 0.5)/L]``. A lowest band named ``water`` is all or nothing, as in
    :func:`~terrascape.texture.regions.region_weights`: above its ``max`` the coordinate is at
    least the next layer's centre.

    Returns
    -------
    numpy.ndarray
        ``float32 (rows, cols)`` in ``[0, 1]``.
    """
    hm = heightmap if isinstance(heightmap, Heightmap) else Heightmap(heightmap)
    regions = _check_regions(default_regions(hm) if regions is None else regions)
    peaks = np.array([r.max for r in regions], dtype=np.float64)
    if len(peaks) > 1 and not np.all(np.diff(peaks) > 0):
        raise InvalidParameterError(
            "layer_coordinate needs regions ordered by strictly increasing max (layer order), "
            f"got maxima {peaks.tolist()}"
        )
    n = len(peaks)
    if n == 1:
        return np.full(hm.shape, 0.5, dtype=np.float32)
    # np.interp is exactly the piecewise-linear map between peaks, flat outside them.
    centres = (np.arange(n) + 0.5) / n
    h = hm.heights.astype(np.float64)
    r = np.interp(h, peaks, centres)
    if regions[0].name.lower() == "water":
        # Water is all or nothing (region_weights): above the water line the blend starts
        # at the next layer, so the water layer never climbs the slopes.
        r = np.where(h > peaks[0], np.maximum(r, centres[1]), r)
    return r.astype(np.float32)


__all__ = ["layer_coordinate", "layer_stack"]
