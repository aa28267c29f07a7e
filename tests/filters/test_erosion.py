"""Thermal and hydraulic erosion: conservation, slope limiting, determinism, errors."""

from __future__ import annotations

import importlib
import math

import numpy as np
import pytest

from terrascape.errors import InvalidParameterError
from terrascape.filters import hydraulic_erosion, thermal_erosion
from terrascape.filters.thermal_erosion import _DX8, _DZ8, _thermal_f64
from terrascape.generate import diamond_square
from terrascape.heightmap import Heightmap


@pytest.fixture(scope="module")
def rough() -> Heightmap:
    return diamond_square(65, roughness=40.0, seed=2)


def max_neighbour_slope(h: np.ndarray) -> float:
    return float(max(np.abs(np.diff(h, axis=0)).max(), np.abs(np.diff(h, axis=1)).max()))


def test_thermal_conserves_material(rough: Heightmap) -> None:
    h0 = rough.heights.astype(np.float64)
    thr = math.tan(math.radians(30.0)) * np.hypot(_DX8, _DZ8)
    out = _thermal_f64(h0, 40, thr, 0.5, _DZ8, _DX8)
    # float64 core: the sum is unchanged up to round-off of ~N additions.
    assert abs(out.sum() - h0.sum()) <= 1e-12 * np.abs(h0).sum() * 40
    assert np.abs(out - h0).max() > 1.0  # and it really moved material
    th = thermal_erosion(rough, iterations=40)
    assert abs(th.heights.astype(np.float64).sum() - h0.sum()) <= 1e-6 * np.abs(h0).sum()


def test_thermal_limits_slopes_toward_talus() -> None:
    spike = np.zeros((21, 21), dtype=np.float32)
    spike[10, 10] = 100.0
    out = thermal_erosion(Heightmap(spike), iterations=2000, talus_angle=45.0, rate=0.5).heights
    # The pile relaxes to (nearly) the talus slope: tan 45° = 1 per cell, a bit of tolerance
    # for the not fully converged tail; without erosion the step was 100.
    assert max_neighbour_slope(out) < 1.2
    assert out.sum() == pytest.approx(100.0, rel=1e-5)
    assert out[10, 10] == out.max()
    np.testing.assert_allclose(out, out[::-1, ::-1], atol=1e-3)  # symmetric pile
    # Steeper talus keeps more of the spike; 0 iterations is the identity.
    steep = thermal_erosion(Heightmap(spike), iterations=2000, talus_angle=80.0).heights
    assert steep[10, 10] > out[10, 10]
    assert np.array_equal(thermal_erosion(Heightmap(spike), iterations=0).heights, spike)


def test_thermal_flat_and_below_talus_unchanged() -> None:
    ramp = np.tile(np.arange(16, dtype=np.float32) * 0.5, (16, 1))  # slope 0.5 < tan 30°
    out = thermal_erosion(Heightmap(ramp), iterations=10, talus_angle=30.0).heights
    np.testing.assert_array_equal(out, ramp)
    # The same ramp with a 0.1-unit spacing is steep (slope 5) and erodes.
    steep = thermal_erosion(Heightmap(ramp, spacing=0.1), iterations=10).heights
    assert not np.array_equal(steep, ramp)


def test_thermal_four_neighbourhood(rough: Heightmap) -> None:
    four = thermal_erosion(rough, iterations=20, neighbourhood=4)
    eight = thermal_erosion(rough, iterations=20, neighbourhood=8)
    assert not np.array_equal(four.heights, eight.heights)
    assert max_neighbour_slope(four.heights) < max_neighbour_slope(rough.heights)


def test_hydraulic_conserves_and_is_deterministic(rough: Heightmap) -> None:
    a = hydraulic_erosion(rough, droplets=3000, seed=1)
    b = hydraulic_erosion(rough, droplets=3000, seed=1)
    c = hydraulic_erosion(rough, droplets=3000, seed=2)
    assert a.heights.tobytes() == b.heights.tobytes()
    assert a.heights.tobytes() != c.heights.tobytes()
    h0 = rough.heights.astype(np.float64)
    diff = a.heights.astype(np.float64) - h0
    assert np.abs(diff).max() > 0.1
    # Material moves but is neither created nor destroyed (float32 storage round-off only).
    assert abs(diff.sum()) <= 1e-6 * np.abs(h0).sum()
    assert a.spacing == rough.spacing and a.shape == rough.shape


def test_hydraulic_carves_downhill_on_a_ramp() -> None:
    # A tilted plane with small bumps: droplets run downhill, eroding the upper part and
    # depositing lower down, so mass moves toward low x.
    _z, x = np.mgrid[0:48, 0:48].astype(np.float64)
    bumps = np.random.default_rng(0).random((48, 48)) * 0.2
    ramp = Heightmap((x * 1.0 + bumps).astype(np.float32))
    out = hydraulic_erosion(ramp, droplets=4000, seed=3).heights.astype(np.float64)
    delta = out - ramp.heights.astype(np.float64)
    centre_before = (ramp.heights * x).sum() / ramp.heights.sum()
    centre_after = (out * x).sum() / out.sum()
    assert centre_after < centre_before
    assert delta[:, 24:].sum() < 0 < delta[:, :24].sum()
    assert np.isfinite(out).all()


@pytest.mark.parametrize(
    ("func", "kwargs"),
    [
        (thermal_erosion, {"iterations": -1}),
        (thermal_erosion, {"talus_angle": 95.0}),
        (thermal_erosion, {"rate": 0.0}),
        (thermal_erosion, {"rate": 0.8}),
        (thermal_erosion, {"neighbourhood": 6}),
        (hydraulic_erosion, {"droplets": -5}),
        (hydraulic_erosion, {"inertia": 1.5}),
        (hydraulic_erosion, {"capacity": float("nan")}),
        (hydraulic_erosion, {"max_steps": 0}),
        (hydraulic_erosion, {"seed": -2}),
    ],
)
def test_bad_parameters(rough: Heightmap, func, kwargs: dict) -> None:
    with pytest.raises(InvalidParameterError):
        func(rough, **kwargs)


def test_bad_input_type() -> None:
    with pytest.raises(InvalidParameterError):
        thermal_erosion(np.zeros((4, 4)))
    with pytest.raises(InvalidParameterError):
        hydraulic_erosion(np.zeros((4, 4)))


def test_thermal_talus_map_per_material() -> None:
    # Two materials side by side: the left half (soft, 20°) slumps further than the right
    # (hard, 70°) from the same ridge, and material still balances exactly.
    ridge = np.zeros((24, 40), dtype=np.float32)
    ridge[:, 10] = 30.0
    ridge[:, 30] = 30.0
    talus = np.full(ridge.shape, 70.0, dtype=np.float32)
    talus[:, :20] = 20.0
    out = thermal_erosion(Heightmap(ridge), iterations=400, talus_angle=talus).heights
    assert out[12, 10] < out[12, 30] - 5.0
    assert out.sum() == pytest.approx(ridge.sum(), rel=1e-6)
    same = thermal_erosion(Heightmap(ridge), iterations=50, talus_angle=np.full(ridge.shape, 30.0))
    ref = thermal_erosion(Heightmap(ridge), iterations=50, talus_angle=30.0)
    np.testing.assert_array_equal(same.heights, ref.heights)
    with pytest.raises(InvalidParameterError, match="shape"):
        thermal_erosion(Heightmap(ridge), talus_angle=np.full((3, 3), 30.0))
    bad = talus.copy()
    bad[0, 0] = np.nan
    with pytest.raises(InvalidParameterError, match="NaN"):
        thermal_erosion(Heightmap(ridge), talus_angle=bad)


def test_hydraulic_brush_spreads_wear(rough: Heightmap) -> None:
    # With a brush the same droplets wear more samples, each by less, than Beyer's four
    # bilinear corners; material is still conserved.
    point = hydraulic_erosion(rough, droplets=300, seed=5, radius=0.0).heights
    brush = hydraulic_erosion(rough, droplets=300, seed=5, radius=3.0).heights
    h0 = rough.heights
    worn_point = np.count_nonzero(point < h0 - 1e-4)
    worn_brush = np.count_nonzero(brush < h0 - 1e-4)
    assert worn_brush > 1.3 * worn_point
    assert (h0 - brush).max() < (h0 - point).max()
    assert abs(brush.astype(np.float64).sum() - h0.astype(np.float64).sum()) <= \
        1e-6 * np.abs(h0.astype(np.float64)).sum()
    with pytest.raises(InvalidParameterError):
        hydraulic_erosion(rough, radius=-1.0)


def test_a_thermal_run_told_to_stop_ends_before_its_next_iteration(rough, monkeypatch):
    """The flag an interrupted caller sets (a signal while it waits on the run): no
    iteration after it, so the heights come back as they went in."""
    te = importlib.import_module("terrascape.filters.thermal_erosion")  # the package face
    # names the function

    def stopped(long, kernel, *args):
        return kernel(*args, np.ones(1, np.uint8))

    assert not np.array_equal(thermal_erosion(rough, iterations=3).heights, rough.heights)
    monkeypatch.setattr(te, "run_stoppable", stopped)
    np.testing.assert_array_equal(thermal_erosion(rough, iterations=3).heights, rough.heights)
