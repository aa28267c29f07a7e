"""height_from_image works over blocks of rows, blurs in place and high-passes in strips of
rows: the same values as the whole-image formula (also across block and strip edges), float
validation over the whole image, and a bounded peak."""

from __future__ import annotations

import importlib
import tracemalloc

import numpy as np
import pytest
from scipy import ndimage

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


def _whole_image_filters(img: np.ndarray, *, blur_sigma: float = 0.0,
                         highpass_sigma: float | None = None, contrast: float = 1.0,
                         invert: bool = False) -> np.ndarray:
    """The whole-image pipeline with a new array from every filter (the code before the
    in-place blur and the strips of the high-pass)."""
    y = luminance(img.astype(np.float64) / 255.0)
    if invert:
        y = 1.0 - y
    if blur_sigma > 0:
        y = ndimage.gaussian_filter(y, blur_sigma, mode="reflect")
    if highpass_sigma is not None:
        y = y - ndimage.gaussian_filter(y, highpass_sigma, mode="reflect")
    y = (y - y.min()) / (y.max() - y.min())
    return np.clip(y ** contrast, 0.0, 1.0).astype(np.float32)


@pytest.mark.parametrize("options", [
    {"blur_sigma": 2.0},
    {"blur_sigma": 0.7, "invert": True, "contrast": 2.0},
    {"highpass_sigma": 3.0},  # radius 12: strips of 13 rows (the last one 4)
    {"highpass_sigma": 2.0},  # radius 8 = the strip height minus 5
    {"blur_sigma": 1.5, "highpass_sigma": 0.5},  # radius 2
    {"highpass_sigma": 9.0},  # radius 36: wider than a third of the image, filtered whole
])
def test_in_place_blur_and_strips_give_the_same_bytes(options) -> None:
    img = np.random.default_rng(5).integers(0, 256, (100, 37, 3), dtype=np.uint8)
    got = height_from_image(img, **options)
    assert np.array_equal(got, _whole_image_filters(img, **options))


@pytest.mark.parametrize("options", [{}, {"blur_sigma": 2.0}, {"highpass_sigma": 8.0},
                                     {"blur_sigma": 2.0, "highpass_sigma": 8.0}])
def test_peak_memory_is_a_few_times_the_result(options) -> None:
    img = np.random.default_rng(1).integers(0, 256, (1024, 1024, 3), dtype=np.uint8)
    tracemalloc.start()
    try:
        out = height_from_image(img, **options)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    # The float64 luminance (2×) and the float32 result (1×); neither the blur nor the
    # high-pass holds a second whole float64 image (they did: 4×).
    assert peak <= 3.1 * out.nbytes, f"peak {peak / out.nbytes:.2f}× the float32 result"



_PEAK_RSS = """import resource, subprocess, sys
subprocess.run(sys.argv[1:], check=True)
print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)"""


def test_command_estimate_covers_the_resident_growth(tmp_path) -> None:
    """``terrascape.memory``'s estimate for ``heightfromimage --blur 2`` covers the growth of
    the command's peak resident memory from a 65² to a 2049² RGBA photo (what the estimate is
    of: imports and fixed costs are in the small run) and is at most 2× it."""
    import subprocess
    import sys

    from PIL import Image

    from terrascape.memory import estimate_peak

    rng = np.random.default_rng(2)
    peaks = {}
    for n in (65, 2049):
        src = tmp_path / f"p{n}.png"
        Image.fromarray(rng.integers(0, 256, (n, n, 4), dtype=np.uint8), "RGBA").save(
            src, compress_level=1)
        command = [sys.executable, "-m", "terrascape", "heightfromimage", str(src), "-o",
                   str(tmp_path / f"h{n}.png"), "--blur", "2", "-q"]
        # A fresh parent per run: RUSAGE_CHILDREN is the largest child it waited for.
        run = subprocess.run([sys.executable, "-c", _PEAK_RSS, *command], check=True,
                             capture_output=True, text=True)
        peaks[n] = int(run.stdout.split()[-1]) * 1024  # ru_maxrss is in KiB on Linux
    pixels = 2049**2 - 65**2
    measured = peaks[2049] - peaks[65]
    estimate = estimate_peak("heightfromimage", 2049, 2049) - estimate_peak(
        "heightfromimage", 65, 65)
    assert measured <= estimate <= 2.0 * measured, (
        f"estimate {estimate / pixels:.1f} B, measured {measured / pixels:.1f} B a pixel")
