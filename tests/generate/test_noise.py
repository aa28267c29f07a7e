"""Gradient noise, fBm and ridged multifractal: lattice zeros, bounds, spectra, determinism."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape.errors import InvalidParameterError
from terrascape.generate import fbm, gradient_noise, ridged


def test_gradient_noise_lattice_zeros_bounds_and_continuity() -> None:
    z, x = np.mgrid[-6:300:7, -5:300:3].astype(np.float64)
    assert np.all(gradient_noise(x, z, seed=4) == 0.0)  # Perlin: 0 at every lattice point
    rng = np.random.default_rng(0)
    px, pz = rng.random(50_000) * 300, rng.random(50_000) * 300
    n = gradient_noise(px, pz, seed=4)
    assert np.abs(n).max() <= 1.0 and np.abs(n).max() > 0.5
    assert abs(n.mean()) < 0.02
    # Continuous: a tiny step changes the value by at most |grad| * step (|grad| <= ~3).
    n2 = gradient_noise(px + 1e-4, pz, seed=4)
    assert np.abs(n2 - n).max() < 5e-4
    # The lattice repeats every 256 cells (permutation table size).
    np.testing.assert_allclose(gradient_noise(px + 256.0, pz, seed=4), n, atol=1e-9)
    assert not np.allclose(gradient_noise(px, pz, seed=5), n)


def test_fbm_bounds_determinism_and_scale() -> None:
    a = fbm(129, scale=32.0, seed=1, amplitude=10.0)
    b = fbm(129, scale=32.0, seed=1, amplitude=10.0)
    c = fbm(129, scale=32.0, seed=2, amplitude=10.0)
    assert a.heights.tobytes() == b.heights.tobytes()
    assert a.heights.tobytes() != c.heights.tobytes()
    assert a.min >= -10.0 and a.max <= 10.0 and a.heights.std() > 0.5
    one = fbm((64, 96), scale=16.0, octaves=1, seed=1).heights
    assert one.shape == (64, 96)
    # Single octave = gradient noise sampled at (x, z)/scale plus the octave's lattice offset:
    # it is smooth, so neighbour differences are far below the value range.
    assert np.abs(np.diff(one, axis=1)).max() < 0.35


def test_fbm_gain_controls_roughness() -> None:
    def fine(gain: float) -> float:
        h = fbm(129, scale=64.0, octaves=7, gain=gain, seed=3).heights.astype(np.float64)
        return float(np.std(np.diff(h, axis=1)) / np.std(h))

    assert fine(0.3) < fine(0.5) < fine(0.7)


def _abs_laplacian(h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    lap = h[1:-1, 2:] + h[1:-1, :-2] + h[2:, 1:-1] + h[:-2, 1:-1] - 4 * h[1:-1, 1:-1]
    return np.abs(lap), h[1:-1, 1:-1]


def test_ridged_range_and_sharp_crests() -> None:
    r = ridged(129, scale=48.0, seed=6, amplitude=2.0)
    assert r.min >= 0.0 and r.max <= 2.0
    assert r.heights.tobytes() == ridged(129, scale=48.0, seed=6, amplitude=2.0).heights.tobytes()

    def crest_to_valley_curvature(h: np.ndarray) -> float:
        lap, c = _abs_laplacian(h.astype(np.float64))
        top, bottom = c >= np.quantile(c, 0.9), c <= np.quantile(c, 0.1)
        return float(lap[top].mean() / lap[bottom].mean())

    # Ridged: sharp crests and smooth valleys (the octave weighting puts detail on the
    # ridges); plain fBm has no such asymmetry.
    assert crest_to_valley_curvature(r.heights) > 1.5
    assert 0.7 < crest_to_valley_curvature(fbm(129, scale=48.0, seed=6).heights) < 1.3


@pytest.mark.parametrize(
    "kwargs",
    [
        {"scale": 0.0},
        {"octaves": 0},
        {"octaves": 30},
        {"lacunarity": 0.5},
        {"gain": 1.5},
        {"amplitude": -1.0},
        {"scale": float("nan")},
    ],
)
def test_bad_parameters(kwargs: dict) -> None:
    with pytest.raises(InvalidParameterError):
        fbm(16, **kwargs)
    with pytest.raises(InvalidParameterError):
        ridged(16, **kwargs)


def test_bad_offset_and_shapes() -> None:
    with pytest.raises(InvalidParameterError):
        ridged(16, offset=3.0)
    with pytest.raises(InvalidParameterError):
        gradient_noise(np.zeros(3), np.zeros(4))
