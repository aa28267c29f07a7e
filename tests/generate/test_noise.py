"""Gradient noise, fBm and ridged multifractal: lattice zeros, bounds, spectra, determinism,
tiles equal to one big run, and the numba kernel equal to the plain-numpy reference."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape.errors import InvalidParameterError
from terrascape.generate import fbm, gradient_noise, ridged
from terrascape.generate.noise import reference_fbm


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
    # A hash lattice, not a 256-entry permutation table: no period of 256 (or 2**k) cells.
    for period in (256.0, 512.0, 4096.0):
        assert np.abs(gradient_noise(px + period, pz, seed=4) - n).mean() > 0.1
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


@pytest.mark.parametrize("make", [fbm, ridged])
@pytest.mark.parametrize(
    ("x0", "z0", "cols", "rows"),
    [(0, 0, 100, 50), (123, 77, 91, 64), (301, 211, 99, 89), (17, 290, 383, 10)],
)
def test_tile_equals_the_window_of_one_run(make, x0: int, z0: int, cols: int, rows: int) -> None:
    kw = {"scale": 37.0, "octaves": 9, "seed": 5, "amplitude": 3.0}  # fine octaves: < 1 cell
    full = make((300, 400), **kw).heights
    tile = make((rows, cols), origin=(x0, z0), **kw).heights
    assert tile.tobytes() == full[z0:z0 + rows, x0:x0 + cols].tobytes()


def test_negative_and_far_origins_tile_too() -> None:
    big = fbm((64, 96), scale=20.0, seed=2, origin=(-48, -1_000_000_000)).heights
    part = fbm((30, 40), scale=20.0, seed=2, origin=(-10, -1_000_000_000 + 17)).heights
    assert part.tobytes() == big[17:47, 38:78].tobytes()
    assert big.std() > 0.05  # far from the origin the noise is still noise


def test_kernel_matches_numpy_reference() -> None:
    for kw in ({"scale": 29.0, "octaves": 8}, {"scale": 5.0, "octaves": 3, "lacunarity": 3.0},
               {"scale": 64.0, "octaves": 1, "origin": (1000, -300)}):
        ref = reference_fbm((70, 90), seed=11, **kw)
        got = fbm((70, 90), seed=11, **kw).heights
        np.testing.assert_allclose(got, ref, rtol=0, atol=2e-6)


def test_bad_origin() -> None:
    for origin in ((0.5, 0), (1, 2, 3), "ab", (2**41, 0), (True, 0)):
        with pytest.raises(InvalidParameterError):
            fbm(16, origin=origin)


@pytest.mark.parametrize("make", [fbm, ridged])
def test_run_and_lookup_passes_give_the_same_bits(make, monkeypatch) -> None:
    # Which pass an octave takes depends on the tile's width; both must agree exactly.
    from terrascape.generate import noise

    kw = {"scale": 40.0, "octaves": 8, "seed": 3}
    monkeypatch.setattr(noise, "_RUN_MIN", 1)
    by_run = make((20, 150), **kw).heights
    monkeypatch.setattr(noise, "_RUN_MIN", 10**9)
    by_lookup = make((20, 150), **kw).heights
    assert by_run.tobytes() == by_lookup.tobytes()


def test_same_bits_on_one_and_two_threads() -> None:
    import numba

    from terrascape.generate import square_square

    saved = numba.get_num_threads()
    try:
        runs = []
        for threads in (1, min(2, numba.config.NUMBA_NUM_THREADS)):
            numba.set_num_threads(threads)
            runs.append((fbm(97, scale=20.0, seed=4).heights.tobytes(),
                         ridged(97, scale=20.0, seed=4).heights.tobytes(),
                         square_square(129, seed=4).heights.tobytes()))
    finally:
        numba.set_num_threads(saved)
    assert runs[0] == runs[1]
