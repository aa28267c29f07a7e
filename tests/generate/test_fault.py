"""Fault formation: single-fault profiles per falloff, brute-force agreement, errors."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape.errors import HeightmapSizeError, InvalidParameterError
from terrascape.generate import fault_formation
from terrascape.generate.fault import displacement_schedule, draw_faults


def signed_distances(shape: tuple[int, int], iterations: int, seed: int) -> tuple:
    rows, cols = shape
    px, pz, c, s, sign = draw_faults(np.random.default_rng(seed), iterations, rows, cols)
    z, x = np.mgrid[0:rows, 0:cols].astype(np.float64)
    d = [(x - px[k]) * c[k] + (z - pz[k]) * s[k] for k in range(iterations)]
    return d, sign


def profile(falloff: str, d: np.ndarray, width: float, sign: float) -> np.ndarray:
    """The documented falloff shapes, written independently of the kernel."""
    hw = width / 2
    if falloff == "step":
        return np.where(d >= 0, 1.0, -1.0)
    if falloff == "sine":
        return np.sin(np.pi / 2 * np.clip(d / hw, -1.0, 1.0))
    return sign * np.where(np.abs(d) < hw, 0.5 * (1 + np.cos(np.pi * d / hw)), 0.0)


@pytest.mark.parametrize("falloff", ["step", "sine", "cosine"])
def test_single_fault_profile(falloff: str) -> None:
    shape, width, disp = (48, 64), 10.0, 2.5
    hm = fault_formation(shape, iterations=1, start_displacement=disp, falloff=falloff,
                         width=width, seed=4)
    (d,), sign = signed_distances(shape, 1, 4)
    h = hm.heights.astype(np.float64)
    np.testing.assert_allclose(h, disp * profile(falloff, d, width, sign[0]), atol=2e-6)
    far = np.abs(d) >= width / 2
    band = ~far
    assert band.sum() > 50 and far.sum() > 50  # the line crosses the grid
    if falloff == "step":
        assert set(np.unique(h)) == {-disp, disp}
        assert np.all(h[d >= 0] == disp) and np.all(h[d < 0] == -disp)
    elif falloff == "sine":
        # Plateaus at +-D beyond the band; strictly between inside it; 0 on the line.
        assert np.all(np.abs(np.abs(h[far]) - disp) < 1e-6)
        assert np.all(np.abs(h[band]) < disp + 1e-6)
        order = np.argsort(d.ravel())
        assert np.all(np.diff(h.ravel()[order]) >= -1e-6)  # monotone across the line
    else:
        assert np.all(h[far] == 0.0)
        assert np.abs(h).max() <= disp
        near = np.abs(d) < 0.25
        if near.any():
            assert np.all(np.abs(h[near]) > 0.9 * disp)  # ridge (or trench) crest on the line


@pytest.mark.parametrize("falloff", ["step", "sine", "cosine"])
def test_many_faults_match_brute_force(falloff: str) -> None:
    shape, n = (33, 47), 120
    hm = fault_formation(shape, iterations=n, start_displacement=1.0, end_displacement=0.2,
                         falloff=falloff, width=5.0, seed=9)
    ds, sign = signed_distances(shape, n, 9)
    disp = displacement_schedule(1.0, 0.2, n)
    ref = sum(disp[k] * profile(falloff, ds[k], 5.0, sign[k]) for k in range(n))
    np.testing.assert_allclose(hm.heights, ref, atol=1e-5 * np.abs(ref).max() + 1e-6)


def test_displacement_schedule_and_determinism() -> None:
    np.testing.assert_allclose(displacement_schedule(1.0, 0.1, 4), [1.0, 0.7, 0.4, 0.1])
    assert displacement_schedule(2.0, 0.0, 1).tolist() == [2.0]
    a = fault_formation(40, iterations=50, seed=1, falloff="sine")
    b = fault_formation(40, iterations=50, seed=1, falloff="sine")
    c = fault_formation(40, iterations=50, seed=2, falloff="sine")
    assert a.heights.tobytes() == b.heights.tobytes()
    assert a.heights.tobytes() != c.heights.tobytes()
    assert a.shape == (40, 40) and a.heights.dtype == np.float32


def test_progress_callback_and_spacing() -> None:
    calls = []
    hm = fault_formation((20, 30), iterations=150, seed=0, spacing=(2.0, 0.5),
                         progress=lambda done, total: calls.append((done, total)))
    assert calls[-1] == (150, 150)
    assert [c[0] for c in calls] == sorted(c[0] for c in calls)
    assert hm.spacing == (2.0, 0.5) and hm.shape == (20, 30)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"falloff": "tanh"},
        {"falloff": "sine", "width": 0.0},
        {"width": -3.0},
        {"iterations": 0},
        {"iterations": 2.5},
        {"start_displacement": -1.0},
        {"end_displacement": float("nan")},
        {"seed": "abc"},
    ],
)
def test_bad_parameters(kwargs: dict) -> None:
    with pytest.raises(InvalidParameterError):
        fault_formation(16, **kwargs)


@pytest.mark.parametrize("shape", [1, (1, 5), (5, 0), (3, 4, 5), "big"])
def test_bad_shapes(shape) -> None:
    with pytest.raises((HeightmapSizeError, InvalidParameterError)):
        fault_formation(shape)
