"""Pictures in Jupyter notebooks: heightmaps and rendered images that display inline.

A :class:`~terrascape.heightmap.Heightmap` shows itself as a small shaded, height-coloured
picture (its ``_repr_png_`` calls :func:`heightmap_preview`), and :class:`Image` wraps any
rendered ``uint8``/float array (``render_to_array``'s output, a texture, a lightmap) so that
it displays too; :func:`show` makes either from whatever it is given. Nothing here needs a
notebook: the PNG bytes are what IPython's display machinery asks for.
"""

from __future__ import annotations

import io
import os
from pathlib import Path
from typing import Any

import numpy as np

from terrascape.errors import InvalidParameterError

#: Largest side of a heightmap preview in pixels (notebook output stays small).
PREVIEW_SIDE = 256

# Height colours from the lowest to the highest sample (water, sand, grass, rock, snow), the
# way a map legend reads; shading multiplies them.
_RAMP_STOPS = np.array([0.0, 0.12, 0.2, 0.55, 0.8, 1.0])
_RAMP_COLOURS = np.array([
    [40, 90, 170], [205, 185, 130], [80, 140, 60], [70, 110, 50], [125, 115, 105],
    [245, 245, 250],
], dtype=np.float64)


def heightmap_preview(heightmap, *, max_side: int = PREVIEW_SIDE,
                      sun: tuple[float, float] = (315.0, 45.0)) -> np.ndarray:
    """A shaded preview ``uint8 (rows', cols', 3)`` of at most ``max_side`` pixels a side:
    colour by height (low → high: water, sand, grass, rock, snow) times Lambert shading from
    ``sun`` (azimuth clockwise from north, elevation; default north-west, the cartographers'
    light), computed on the world-unit gradient so the relief looks as steep as it is."""
    from terrascape.heightmap import Heightmap
    from terrascape.lighting.sun import sun_direction

    if int(max_side) < 2:
        raise InvalidParameterError(f"max_side must be >= 2 pixels, got {max_side}")
    step = max(1, -(-max(heightmap.rows, heightmap.cols) // int(max_side)))  # ceil division
    small = Heightmap(heightmap.heights[::step, ::step],
                      (heightmap.spacing[0] * step, heightmap.spacing[1] * step))
    light = np.asarray(sun_direction(*sun), dtype=np.float64)  # (x, y, z), Y up
    lambert = np.clip(small.normals().astype(np.float64) @ light, 0.0, 1.0)
    shade = 0.35 + 0.65 * lambert
    h = small.heights.astype(np.float64)
    span = h.max() - h.min()
    unit = (h - h.min()) / span if span > 0 else np.zeros_like(h)
    colour = np.stack([np.interp(unit, _RAMP_STOPS, _RAMP_COLOURS[:, c]) for c in range(3)],
                      axis=-1)
    return np.clip(colour * shade[..., None] + 0.5, 0, 255).astype(np.uint8)


def _as_uint8(array: Any) -> np.ndarray:
    a = np.asarray(array)
    if a.ndim == 3 and a.shape[-1] == 1:
        a = a[..., 0]
    if a.ndim not in (2, 3) or (a.ndim == 3 and a.shape[-1] not in (3, 4)) or a.size == 0:
        raise InvalidParameterError(
            f"expected an image (rows, cols), (rows, cols, 3) or (rows, cols, 4), got {a.shape}")
    if a.dtype == np.uint8:
        return np.ascontiguousarray(a)
    if a.dtype == np.uint16:
        return np.ascontiguousarray((a >> 8).astype(np.uint8))
    if np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer):
        f = np.nan_to_num(a.astype(np.float64), nan=0.0)
        return np.clip(f * 255.0 + 0.5, 0, 255).astype(np.uint8)  # floats in [0, 1]
    raise InvalidParameterError(f"cannot show an image of dtype {a.dtype}")


class Image:
    """A picture that displays inline in Jupyter (``_repr_png_``) and is still an array.

    ``pixels`` is ``uint8`` grey, RGB or RGBA; floats are taken as ``[0, 1]`` and 16-bit
    values scaled to 8 bits. ``np.asarray(image)`` gives the pixels back.
    """

    def __init__(self, pixels: Any) -> None:
        self.pixels = _as_uint8(pixels)

    @property
    def shape(self) -> tuple[int, ...]:
        return self.pixels.shape

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        return self.pixels if dtype is None else self.pixels.astype(dtype)

    def to_png(self) -> bytes:
        """The picture as PNG file bytes."""
        from PIL import Image as PILImage

        buf = io.BytesIO()
        PILImage.fromarray(self.pixels).save(buf, format="PNG")
        return buf.getvalue()

    def _repr_png_(self) -> bytes:
        return self.to_png()

    def save(self, path: str | os.PathLike, *, force: bool = False) -> Path:
        """Write the PNG atomically (``force`` overwrites)."""
        from terrascape.io.atomic import atomic_output

        with atomic_output(path, force=force) as tmp:
            tmp.write_bytes(self.to_png())
        return Path(path)

    def __repr__(self) -> str:
        rows, cols = self.pixels.shape[:2]
        channels = 1 if self.pixels.ndim == 2 else self.pixels.shape[2]
        return f"Image({cols}×{rows}, {channels} channel{'s' if channels > 1 else ''})"


def as_image(obj: Any, *, max_side: int = PREVIEW_SIDE) -> Image:
    """An :class:`Image` of a heightmap (its shaded preview), an array, or an Image."""
    from terrascape.heightmap import Heightmap

    if isinstance(obj, Image):
        return obj
    if isinstance(obj, Heightmap):
        return Image(heightmap_preview(obj, max_side=max_side))
    return Image(obj)


def show(obj: Any, *, max_side: int = PREVIEW_SIDE) -> Image | None:
    """Display ``obj`` (heightmap, image array) inline when running in IPython/Jupyter;
    elsewhere return the :class:`Image` (which a notebook cell also displays)."""
    image = as_image(obj, max_side=max_side)
    try:
        from IPython import get_ipython
        from IPython.display import display
    except ImportError:
        return image
    if get_ipython() is None:
        return image
    display(image)
    return None


__all__ = ["PREVIEW_SIDE", "Image", "as_image", "heightmap_preview", "show"]
