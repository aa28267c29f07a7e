from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from terrascape.errors import InvalidParameterError
from terrascape.lighting import height_from_image, luminance


def test_grey_ramp_is_linear_and_normalised():
    ramp = np.tile(np.linspace(0.2, 0.7, 11), (4, 1))
    h = height_from_image(ramp)
    assert h.dtype == np.float32 and h.shape == (4, 11)
    np.testing.assert_allclose(h[0], np.linspace(0, 1, 11), atol=1e-6)
    np.testing.assert_allclose(height_from_image(ramp, invert=True), 1.0 - h, atol=1e-6)
    np.testing.assert_allclose(height_from_image(ramp, contrast=2.0), h**2, atol=1e-6)


def test_luminance_weights_and_dtypes():
    rgb = np.zeros((2, 3, 3), np.uint8)
    rgb[:, 0, 0] = 255  # red
    rgb[:, 1, 1] = 255  # green
    rgb[:, 2, 2] = 255  # blue
    y = luminance(rgb)  # the one luma of terrascape (io.image): Rec. 601, stored values
    np.testing.assert_allclose(y[0], np.multiply([0.299, 0.587, 0.114], 255), atol=1e-9)
    h = height_from_image(rgb)
    assert h[0, 1] == 1.0 and h[0, 2] == 0.0 and 0 < h[0, 0] < 1
    rgb16 = rgb.astype(np.uint16) * 257
    np.testing.assert_allclose(height_from_image(rgb16), h, atol=1e-6)
    rgba = np.concatenate([rgb, np.full((2, 3, 1), 7, np.uint8)], axis=2)
    np.testing.assert_allclose(height_from_image(rgba), h, atol=1e-6)  # alpha ignored


def test_blur_removes_pixel_noise(rng):
    img = rng.random((64, 64))
    raw = height_from_image(img)
    smooth = height_from_image(img, blur_sigma=2.0)
    # Neighbour differences measure pixel-scale noise: blurring must cut them several-fold.
    def roughness(a):
        return np.abs(np.diff(a, axis=1)).mean() / (a.max() - a.min())

    assert roughness(smooth) < roughness(raw) / 3


def test_highpass_removes_illumination_gradient():
    z, x = np.mgrid[0:96, 0:96].astype(np.float64)
    bumps = 0.5 + 0.5 * np.sin(x / 3.0) * np.sin(z / 3.0)  # "buildings", ~19 px period
    light = x / 95.0  # the photo is lit from the right
    img = 0.15 * bumps + 0.8 * light
    plain = height_from_image(img / img.max())
    hp = height_from_image(img / img.max(), highpass_sigma=10.0)
    inner = (slice(16, -16), slice(16, -16))  # away from the filter's border
    c_plain = np.corrcoef(plain[inner].ravel(), bumps[inner].ravel())[0, 1]
    c_hp = np.corrcoef(hp[inner].ravel(), bumps[inner].ravel())[0, 1]
    assert c_plain < 0.5 < 0.95 < c_hp


def test_uniform_image_is_flat_zero():
    np.testing.assert_array_equal(height_from_image(np.full((5, 5, 3), 99, np.uint8)), 0.0)
    flat = height_from_image(np.full((9, 9), 0.5), blur_sigma=1.0, highpass_sigma=2.0)
    np.testing.assert_array_equal(flat, 0.0)


@pytest.mark.parametrize(
    ("img", "kwargs", "match"),
    [
        (np.zeros((4, 4, 2)), {}, "channels"),
        (np.zeros(5), {}, "shape"),
        (np.zeros((1, 4)), {}, "2×2"),
        (np.full((4, 4), np.nan), {}, "NaN"),
        (np.full((4, 4), 2.0), {}, r"\[0, 1\]"),
        (np.zeros((4, 4), np.int32), {}, "dtype"),
        (np.zeros((4, 4)), {"blur_sigma": -1}, "blur_sigma"),
        (np.zeros((4, 4)), {"contrast": 0}, "contrast"),
        (np.zeros((4, 4)), {"highpass_sigma": 0}, "highpass_sigma"),
    ],
)
def test_bad_input_raises(img, kwargs, match):
    with pytest.raises(InvalidParameterError, match=match):
        height_from_image(img, **kwargs)


def test_blur_is_gaussian_of_luminance(rng):
    img = rng.random((20, 30, 3))
    y = img @ np.array([0.299, 0.587, 0.114])  # Rec. 601 luma (io.image.luminance)
    g = ndimage.gaussian_filter(y, 1.5, mode="reflect")
    expect = (g - g.min()) / (g.max() - g.min())
    np.testing.assert_allclose(height_from_image(img, blur_sigma=1.5), expect, atol=1e-6)
