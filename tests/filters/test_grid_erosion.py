"""Virtual-pipe grid erosion: locality (tiles with a halo are exact), determinism across
thread counts, mass balance, channels where water gathers, and parameter errors."""

from __future__ import annotations

import importlib

import numba
import numpy as np
import pytest

from terrascape.errors import InvalidParameterError
from terrascape.filters.virtual_pipe_erosion import (
    HALO_PER_ITERATION,
    stable_time_step,
    virtual_pipe_erosion,
)
from terrascape.generate import fbm
from terrascape.heightmap import Heightmap


@pytest.fixture(scope="module")
def terrain() -> Heightmap:
    return fbm(96, scale=32.0, octaves=5, seed=4, spacing=4.0).normalised(0, 60)


def test_window_with_halo_equals_the_full_run(terrain: Heightmap) -> None:
    iterations = 6
    halo = HALO_PER_ITERATION * iterations
    full = virtual_pipe_erosion(terrain, iterations=iterations, dt=0.2)
    z0, z1, x0, x1 = 30, 60, 25, 70  # an interior window
    sub = Heightmap(terrain.heights[z0 - halo:z1 + halo, x0 - halo:x1 + halo], terrain.spacing)
    part = virtual_pipe_erosion(sub, iterations=iterations, dt=0.2)
    inner = (slice(halo, -halo), slice(halo, -halo))
    np.testing.assert_array_equal(part.heightmap.heights[inner],
                                  full.heightmap.heights[z0:z1, x0:x1])
    np.testing.assert_array_equal(part.water[inner], full.water[z0:z1, x0:x1])
    np.testing.assert_array_equal(part.flow[inner], full.flow[z0:z1, x0:x1])
    # Without a halo the window's own border (open, dry outside) changes the result.
    alone = virtual_pipe_erosion(Heightmap(terrain.heights[z0:z1, x0:x1], terrain.spacing),
                                 iterations=iterations, dt=0.2)
    assert not np.array_equal(alone.heightmap.heights, full.heightmap.heights[z0:z1, x0:x1])


def test_same_bytes_on_one_and_two_threads(terrain: Heightmap) -> None:
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = virtual_pipe_erosion(terrain, iterations=30)
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        two = virtual_pipe_erosion(terrain, iterations=30)
    finally:
        numba.set_num_threads(before)
    assert one.heightmap.heights.tobytes() == two.heightmap.heights.tobytes()
    assert one.flow.tobytes() == two.flow.tobytes()


def test_erodes_where_water_gathers_and_roughly_conserves(terrain: Heightmap) -> None:
    res = virtual_pipe_erosion(terrain, iterations=200, capacity=0.1)
    h0 = terrain.heights.astype(np.float64)
    dh = res.heightmap.heights.astype(np.float64) - h0
    assert np.abs(dh).max() > 0.2  # it does something
    # Sediment is conserved inside; it only leaves with the water through the open border.
    assert abs(dh.sum()) < 0.2 * np.abs(dh).sum()
    assert (res.water >= 0).all() and res.water.max() > 0
    # The top 1 % of samples carry far more than 1 % of the discharge.
    flow = np.sort(res.flow.ravel())[::-1]
    assert flow[: flow.size // 100].sum() > 0.1 * flow.sum()
    # Wear is where discharge is high: mean flow on the most eroded samples beats the rest.
    worn = dh < np.percentile(dh, 5)
    assert res.flow[worn].mean() > res.flow[~worn].mean()


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"rain": -0.1}, "rain"),
        ({"dt": 5.0}, "stable limit"),
        ({"evaporation": 10.0, "dt": 0.2}, "evaporation"),
        ({"dissolving": 1.5}, "dissolving"),
        ({"iterations": -1}, "iterations"),
        ({"rain": np.full((3, 3), 0.1)}, "shape"),
    ],
)
def test_bad_parameters(terrain: Heightmap, kwargs: dict, message: str) -> None:
    with pytest.raises(InvalidParameterError, match=message):
        virtual_pipe_erosion(terrain, **kwargs)


def test_nan_rain_and_stable_limit(terrain: Heightmap) -> None:
    rain = np.full(terrain.shape, 0.01)
    rain[3, 3] = np.nan
    with pytest.raises(InvalidParameterError, match="NaN"):
        virtual_pipe_erosion(terrain, rain=rain)
    assert stable_time_step((4.0, 4.0)) == pytest.approx((4.0 / (2 * 9.81)) ** 0.5)


def test_a_run_told_to_stop_ends_before_its_next_step(terrain: Heightmap, monkeypatch) -> None:
    """The flag an interrupted caller sets: no step after it (no rain fell, nothing
    moved)."""
    vp = importlib.import_module("terrascape.filters.virtual_pipe_erosion")  # the package
    # face names the function

    def stopped(long, kernel, *args):
        return kernel(*args, np.ones(1, np.uint8))

    assert virtual_pipe_erosion(terrain, iterations=3, dt=0.2).water.max() > 0.0
    monkeypatch.setattr(vp, "run_stoppable", stopped)
    out = virtual_pipe_erosion(terrain, iterations=3, dt=0.2)
    np.testing.assert_array_equal(out.heightmap.heights, terrain.heights)
    assert out.water.max() == 0.0 and out.flow.max() == 0.0
