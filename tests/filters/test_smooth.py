"""Gaussian and box blur on float heights: equal to scipy on float64, no quantisation."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from terrascape.errors import InvalidParameterError
from terrascape.filters import MODES, box_blur, gaussian_blur
from terrascape.heightmap import Heightmap


@pytest.fixture
def hm(rng: np.random.Generator) -> Heightmap:
    # Sub-millimetre relief: any 8-bit (or 1/255) quantisation would be obvious.
    h = (rng.random((37, 29)) * 1e-3).astype(np.float32)
    return Heightmap(h, spacing=(2.0, 3.0), metadata={"source": "test"})


@pytest.mark.parametrize("mode", MODES)
def test_gaussian_equals_scipy(hm: Heightmap, mode: str) -> None:
    out = gaussian_blur(hm, 1.7, mode=mode, cval=99.0)
    ref = ndimage.gaussian_filter(hm.heights.astype(np.float64), 1.7, mode=mode, cval=99.0)
    assert out.heights.dtype == np.float32
    np.testing.assert_array_equal(out.heights, ref.astype(np.float32))
    assert out.spacing == (2.0, 3.0) and out.metadata == {"source": "test"}


@pytest.mark.parametrize("mode", MODES)
def test_box_equals_scipy(hm: Heightmap, mode: str) -> None:
    out = box_blur(hm, 4, mode=mode, cval=99.0)
    ref = ndimage.uniform_filter(hm.heights.astype(np.float64), 4, mode=mode, cval=99.0)
    np.testing.assert_array_equal(out.heights, ref.astype(np.float32))


def test_no_quantisation(hm: Heightmap) -> None:
    out = gaussian_blur(hm, 1.0).heights.astype(np.float64)
    # Many distinct sub-millimetre values survive; nothing snapped to an 8-bit step grid.
    assert np.unique(out).size > 0.9 * out.size
    assert 0.0 < out.std() < 1e-3


def test_box_blur_values_and_identity() -> None:
    h = np.zeros((9, 9), dtype=np.float32)
    h[4, 4] = 9.0
    out = box_blur(Heightmap(h), 3, mode="constant").heights
    assert np.all(out[3:6, 3:6] == pytest.approx(1.0))
    assert out.sum() == pytest.approx(9.0)
    assert np.count_nonzero(out) == 9
    assert np.array_equal(box_blur(Heightmap(h), 1).heights, h)
    # Wrap mode conserves the total; a constant map is a fixed point of every mode.
    rnd = np.random.default_rng(0).random((16, 12)).astype(np.float32)
    assert gaussian_blur(rnd, 2.0, mode="wrap").heights.sum() == pytest.approx(rnd.sum(), rel=1e-5)
    flat = Heightmap(np.full((8, 8), 5.0, dtype=np.float32))
    for mode in ("reflect", "nearest", "mirror", "wrap"):
        assert np.allclose(gaussian_blur(flat, 3.0, mode=mode).heights, 5.0)


def test_gaussian_smooths() -> None:
    rnd = np.random.default_rng(1).random((64, 64)).astype(np.float32)
    out = gaussian_blur(rnd, 2.0).heights
    assert np.std(np.diff(out, axis=1)) < 0.2 * np.std(np.diff(rnd, axis=1))
    anis = gaussian_blur(rnd, (0.0, 2.0)).heights
    # Sigma 0 along rows: each column of the result only mixes within its own row.
    np.testing.assert_allclose(anis, ndimage.gaussian_filter1d(rnd.astype(np.float64), 2.0,
                                                               axis=1), rtol=1e-6)


@pytest.mark.parametrize(
    ("func", "arg", "kwargs"),
    [
        (gaussian_blur, -1.0, {}),
        (gaussian_blur, float("nan"), {}),
        (gaussian_blur, (1.0, 2.0, 3.0), {}),
        (gaussian_blur, 1.0, {"mode": "clamp"}),
        (gaussian_blur, 1.0, {"truncate": 0.0}),
        (box_blur, 0, {}),
        (box_blur, 2.5, {}),
        (box_blur, 3, {"mode": "edge"}),
        (box_blur, 3, {"cval": float("nan")}),
    ],
)
def test_bad_parameters(hm: Heightmap, func, arg, kwargs: dict) -> None:
    with pytest.raises(InvalidParameterError):
        func(hm, arg, **kwargs)


def test_bad_input_type() -> None:
    with pytest.raises(InvalidParameterError):
        gaussian_blur([[1.0, 2.0], [3.0, 4.0]], 1.0)


@pytest.mark.parametrize("parallel", [False, True])
@pytest.mark.parametrize("mode", MODES)
def test_blurs_in_bands_equal_scipy_bit_for_bit(rng: np.random.Generator, monkeypatch,
                                                mode: str, parallel: bool) -> None:
    """A large map is blurred a band of lines at a time (on two threads when it runs on the
    worker): bands of 16 lines over a 70×53 map give scipy's result exactly, whichever axes
    are blurred, widths wider than a band included."""
    from terrascape.filters import smooth

    monkeypatch.setattr(smooth, "_BAND", 16)
    monkeypatch.setattr(smooth, "_LONG_SAMPLES", 0 if parallel else 1 << 40)
    h = (rng.random((70, 53)) * 100.0).astype(np.float32)
    hm = Heightmap(h)
    for sigma in (2.5, (0.0, 3.0), (7.0, 0.0), (20.0, 1.0)):
        ref = ndimage.gaussian_filter(h.astype(np.float64), sigma, mode=mode, cval=5.0)
        np.testing.assert_array_equal(gaussian_blur(hm, sigma, mode=mode, cval=5.0).heights,
                                      ref.astype(np.float32), err_msg=f"{sigma}")
    for size in (5, (1, 4), (33, 1), (2, 40)):
        ref = ndimage.uniform_filter(h.astype(np.float64), size, mode=mode, cval=5.0)
        np.testing.assert_array_equal(box_blur(hm, size, mode=mode, cval=5.0).heights,
                                      ref.astype(np.float32), err_msg=f"{size}")


def test_a_blur_told_to_stop_begins_no_more_bands(rng: np.random.Generator,
                                                  monkeypatch) -> None:
    """The flag an interrupted caller sets: no band begins once it is set (here after the
    first band of the first pass), and the rest of the output is left as it was."""
    from terrascape.filters import smooth

    monkeypatch.setattr(smooth, "_BAND", 16)
    h = (rng.random((40, 50)) * 100.0).astype(np.float32)
    passes = [(0, {"sigma": 2.0}), (1, {"sigma": 2.0})]
    for parallel in (False, True):
        stop = np.zeros(1, np.uint8)
        calls = []

        def filter1d(src, axis, output, calls=calls, stop=stop, **options):
            calls.append(axis)
            ndimage.gaussian_filter1d(src, axis=axis, output=output, **options)
            stop[0] = 1

        out = np.full(h.shape, -1.0)
        smooth._filter_in_bands(filter1d, h, passes, out, parallel, stop)
        assert len(calls) <= 2 if parallel else calls == [0]
        ref = ndimage.gaussian_filter1d(h[:, :16].astype(np.float64), 2.0, axis=0)
        np.testing.assert_array_equal(out[:, :16], ref)
        assert (out[:, 32:] == -1.0).all()
