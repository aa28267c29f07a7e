"""Heightmap._repr_png_ and terrascape.notebook: small shaded previews, inline images."""

from __future__ import annotations

import io

import numpy as np
import pytest
from PIL import Image as PILImage

from terrascape import Heightmap, InvalidParameterError
from terrascape.notebook import Image, as_image, heightmap_preview, show


def _png(data: bytes) -> np.ndarray:
    with PILImage.open(io.BytesIO(data)) as im:
        return np.asarray(im)


def _ramp(rows=300, cols=520) -> Heightmap:
    _, x = np.mgrid[0:rows, 0:cols]
    return Heightmap((x * 0.5).astype(np.float32), (2.0, 2.0))  # rises to the east


def test_preview_is_small_and_shaded():
    hm = _ramp()
    pixels = _png(hm._repr_png_())
    # 520 samples across: every 3rd one, so the preview's longest side is <= 256 pixels.
    assert pixels.shape == (100, 174, 3)


def test_preview_size_colour_and_light():
    hm = _ramp()
    small = heightmap_preview(hm, max_side=64)
    assert max(small.shape[:2]) <= 64 and small.dtype == np.uint8
    # Colour follows height: the low (west) edge is water blue, the high (east) edge snow.
    west, east = small[:, 0].mean(0), small[:, -1].mean(0)
    assert west[2] > west[0] + 40 and east.min() > 150
    # The slope rises to the east, so it faces west: lit from the west it is brighter.
    lit = heightmap_preview(hm, max_side=64, sun=(270, 30)).astype(int).sum()
    dark = heightmap_preview(hm, max_side=64, sun=(90, 30)).astype(int).sum()
    assert lit > dark * 1.2
    flat = heightmap_preview(Heightmap(np.zeros((8, 8), np.float32)))
    assert flat.shape == (8, 8, 3) and len(np.unique(flat.reshape(-1, 3), axis=0)) == 1
    with pytest.raises(InvalidParameterError):
        heightmap_preview(hm, max_side=1)


def test_image_wrapper(tmp_path):
    rgba = np.zeros((4, 6, 4), np.uint8)
    rgba[..., 0] = 200
    img = Image(rgba)
    assert img.shape == (4, 6, 4) and repr(img) == "Image(6×4, 4 channels)"
    np.testing.assert_array_equal(_png(img._repr_png_()), rgba)
    np.testing.assert_array_equal(Image(np.full((3, 3), 0.5)).pixels, np.full((3, 3), 128))
    assert Image(np.full((2, 2), 65535, np.uint16)).pixels.max() == 255
    path = img.save(tmp_path / "x.png")
    np.testing.assert_array_equal(np.asarray(PILImage.open(path)), rgba)
    with pytest.raises(Exception, match="exists"):
        img.save(path)
    with pytest.raises(InvalidParameterError, match="expected an image"):
        Image(np.zeros((2, 2, 5)))
    assert as_image(img) is img
    shown = show(_ramp(20, 20))  # not in IPython: returns the Image
    assert isinstance(shown, Image) and shown.shape == (20, 20, 3)
