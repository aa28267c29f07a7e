"""height_from_image works over blocks of rows: the same values as the whole-image formula
(also across block edges), float validation over the whole image, and a bounded peak."""

from __future__ import annotations

import importlib
import tracemalloc

import numpy as np
import pytest

from terrascape.errors import InvalidParameterError
from terrascape.io.image import luminance
from terrascape.lighting.height_from_image import height_from_image

module = importlib.import_module("terrascape.lighting.height_from_image")  # not the function


def _whole_image(img: np.ndarray, contrast: float = 1.0) -> np.ndarray:
    y = luminance(img.astype(np.float64) / 255.0)
    y = (y - y.min()) / (y.max() - y.min())
    return np.clip(y ** contrast, 0.0, 1.0).astype(np.float32)


@pytest.mark.parametrize("contrast", [1.0, 2.5])
def test_blocks_give_the_whole_image_values(monkeypatch, contrast) -> None:
    monkeypatch.setattr(module, "_BLOCK_PIXELS", 7 * 33)  # 7 rows a block, the last one short
    img = np.random.default_rng(3).integers(0, 256, (40, 33, 3), dtype=np.uint8)
    got = height_from_image(img, contrast=contrast)
    np.testing.assert_allclose(got, _whole_image(img, contrast), rtol=0, atol=2e-7)
    monkeypatch.setattr(module, "_BLOCK_PIXELS", 10**6)
    assert np.array_equal(height_from_image(img, contrast=contrast), got)


def test_float_range_is_checked_over_the_whole_image(monkeypatch) -> None:
    monkeypatch.setattr(module, "_BLOCK_PIXELS", 4 * 5)
    img = np.full((12, 5, 3), 0.5)
    img[10, 2, 1] = 1.5  # in the last block only
    with pytest.raises(InvalidParameterError, match=r"\[0.5, 1.5\]"):
        height_from_image(img)
    img[10, 2, 1] = np.nan
    with pytest.raises(InvalidParameterError, match="NaN"):
        height_from_image(img)


def test_the_callers_image_is_untouched() -> None:
    img = np.linspace(0.0, 1.0, 64).reshape(8, 8)
    before = img.copy()
    height_from_image(img, invert=True, blur_sigma=1.0)
    assert np.array_equal(img, before)


@pytest.mark.parametrize("options", [{}, {"blur_sigma": 2.0}, {"highpass_sigma": 8.0}])
def test_peak_memory_is_a_few_times_the_result(options) -> None:
    img = np.random.default_rng(1).integers(0, 256, (1024, 1024, 3), dtype=np.uint8)
    tracemalloc.start()
    try:
        out = height_from_image(img, **options)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak <= 5.0 * out.nbytes, f"peak {peak / out.nbytes:.1f}× the float32 result"
