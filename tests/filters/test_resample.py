"""Cubic resampling corner to corner: scipy's spline, the size asked for, the input's
samples where the grids line up, the same values in bands, serial or parallel, and Ctrl-C
between two bands."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from terrascape.errors import HeightmapSizeError, InvalidParameterError
from terrascape.filters import resample
from terrascape.filters.resample import resample_cubic
from terrascape.heightmap import Heightmap


def _smooth_map(rows: int, cols: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return (ndimage.gaussian_filter(rng.random((rows, cols)), 2.0) * 500.0).astype(np.float32)


def test_equals_scipy_zoom_where_zoom_gives_the_size_asked_for():
    h = _smooth_map(301, 257, 1)
    out = resample_cubic(h, (401, 200))
    zoomed = ndimage.zoom(h.astype(np.float64), (400 / 300, 199 / 256), order=3,
                          mode="nearest", grid_mode=False)
    assert out.shape == zoomed.shape == (401, 200) and out.dtype == np.float32
    np.testing.assert_allclose(out, zoomed, rtol=0, atol=1e-4)


@pytest.mark.parametrize(("shape", "samples"), [
    ((601, 513), (slice(None, None, 2), slice(None, None, 2))),  # enlarged twice
    ((151, 129), None),  # halved: the output is every second input sample
])
def test_aligned_grids_repeat_the_input_samples(shape, samples):
    """Twice the size: every second output sample is an input sample; half the size: every
    output sample is. ``ndimage.zoom`` returns 602 × 514 and 150 × 128 here (its size is
    rounded from the factor), stretching the grid by a sample."""
    h = _smooth_map(301, 257, 2)
    out = resample_cubic(h, shape)
    assert out.shape == shape
    if samples is None:
        np.testing.assert_allclose(out, h[::2, ::2], rtol=0, atol=1e-4)
    else:
        np.testing.assert_allclose(out[samples], h, rtol=0, atol=1e-4)
    factor = ((shape[0] - 1) / 300, (shape[1] - 1) / 256)
    assert ndimage.zoom(h, factor, order=3, grid_mode=False).shape != shape


def test_corners_stay_and_a_plane_stays_a_plane_inside():
    rr, cc = np.mgrid[0:200, 0:150].astype(np.float64)
    plane = (3.0 * rr - 2.0 * cc + 7.0).astype(np.float32)
    out = resample_cubic(plane, (333, 97))
    for corner in ((0, 0), (0, -1), (-1, 0), (-1, -1)):
        assert out[corner] == pytest.approx(plane[corner], abs=1e-3)
    r2, c2 = np.mgrid[0:333, 0:97]
    exact = 3.0 * r2 * 199 / 332 - 2.0 * c2 * 149 / 96 + 7.0
    # the edge continued flat bends the spline within a few samples of the border only
    inner = (slice(20, -20), slice(10, -10))
    np.testing.assert_allclose(out[inner], exact[inner], rtol=0, atol=2e-3)


@pytest.mark.parametrize("parallel", [False, True])
def test_bands_give_the_values_of_one_band(monkeypatch, parallel):
    h = _smooth_map(150, 133, 3)
    whole = resample_cubic(h, (187, 61))
    monkeypatch.setattr(resample, "_BAND", 16)
    monkeypatch.setattr(resample, "_LONG_SAMPLES", 0 if parallel else 1 << 40)
    assert resample_cubic(h, (187, 61)).tobytes() == whole.tobytes()


def test_bands_do_not_begin_once_told_to_stop():
    h = _smooth_map(40, 30, 4)
    coefficients = np.full((40 + 2 * resample._PAD, 30 + 2 * resample._PAD), np.nan)
    out = np.full((50, 20), np.nan, np.float32)
    resample._resample_in_bands(h, coefficients, out, False, np.ones(1, np.uint8))
    assert np.isnan(out).all() and np.isnan(coefficients[resample._PAD:-resample._PAD]).all()
    resample._resample_in_bands(h, coefficients, out, False, np.zeros(1, np.uint8))
    assert np.isfinite(out).all()
    # the padding is np.pad's "edge" before the prefilter turned it into coefficients
    expected = np.pad(h.astype(np.float64), resample._PAD, "edge")
    ndimage.spline_filter(expected, 3, output=expected, mode="nearest")
    assert np.array_equal(coefficients, expected)


def test_bad_input_is_refused():
    h = _smooth_map(20, 20, 5)
    with pytest.raises(InvalidParameterError, match="columns of the resampled map"):
        resample_cubic(h, (10, 1))
    with pytest.raises(HeightmapSizeError):
        resample_cubic(h[:1], (10, 10))
    bad = h.copy()
    bad[3, 4] = np.nan
    with pytest.raises(InvalidParameterError, match="NaN"):
        resample_cubic(bad, (10, 10))
    with pytest.raises(TypeError):
        resample_cubic(h, 10)
    assert np.array_equal(resample_cubic(Heightmap(h), (7, 9)), resample_cubic(h, (7, 9)))
