"""Stream-power erosion: drained after every step, deeper with strength, uplift maps, errors."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape.analysis.drainage import breach_depressions, depression_share, drainage_area
from terrascape.errors import InvalidParameterError
from terrascape.filters import stream_power_erosion
from terrascape.generate import fbm
from terrascape.heightmap import Heightmap


@pytest.fixture(scope="module")
def hills() -> Heightmap:
    return fbm(97, scale=24.0, octaves=5, seed=8, spacing=4.0).normalised(0, 40)


def test_zero_steps_is_the_breached_input(hills: Heightmap) -> None:
    res = stream_power_erosion(hills, iterations=0)
    expected = breach_depressions(hills.heights.astype(np.float64))
    np.testing.assert_array_equal(res.heightmap.heights, expected.astype(np.float32))
    np.testing.assert_array_equal(res.flow, drainage_area(hills).astype(np.float32))


def test_incises_channels_and_stays_drained(hills: Heightmap) -> None:
    weak = stream_power_erosion(hills, iterations=15, strength=1e-3)
    strong = stream_power_erosion(hills, iterations=15, strength=1e-2)
    for res in (weak, strong):
        assert depression_share(res.heightmap) == 0.0
    h0 = breach_depressions(hills.heights.astype(np.float64))
    cut_weak = h0 - weak.heightmap.heights
    cut_strong = h0 - strong.heightmap.heights
    assert cut_strong.mean() > 2 * cut_weak.mean() > 0
    # Erosion goes with drainage area: away from the base level at the border, rivers cut
    # more than hillslopes.
    inner = (slice(12, -12), slice(12, -12))
    flow, cut = strong.flow[inner], cut_strong[inner]
    big = flow > np.percentile(flow, 95)
    small = flow <= 2
    assert cut[big].mean() > 1.2 * cut[small].mean()
    # The border is the fixed base level.
    np.testing.assert_array_equal(strong.heightmap.heights[0], h0[0].astype(np.float32))


def test_uplift_raises_the_interior(hills: Heightmap) -> None:
    flat = stream_power_erosion(hills, iterations=10)
    up = stream_power_erosion(hills, iterations=10, uplift=0.5)
    assert up.heightmap.heights[1:-1, 1:-1].mean() > flat.heightmap.heights[1:-1, 1:-1].mean()
    # An uplift map (a ridge in the middle): loops of receivers are caught by a new flood.
    ramp = np.zeros(hills.shape)
    ramp[:, 40:60] = 2.0
    mapped = stream_power_erosion(hills, iterations=10, uplift=ramp)
    assert np.isfinite(mapped.heightmap.heights).all()
    assert mapped.heightmap.heights[:, 40:60].mean() > flat.heightmap.heights[:, 40:60].mean()


@pytest.mark.parametrize(
    "kwargs",
    [{"strength": 0.0}, {"m": 2.0}, {"iterations": -1}, {"uplift": -1.0},
     {"uplift": np.zeros((3, 3))}, {"fill": 2.0}],
)
def test_bad_parameters(hills: Heightmap, kwargs: dict) -> None:
    with pytest.raises(InvalidParameterError):
        stream_power_erosion(hills, **kwargs)


def test_routing_interval_keeps_the_surface_drained(hills: Heightmap) -> None:
    every = stream_power_erosion(hills, iterations=12, strength=5e-3)
    fourth = stream_power_erosion(hills, iterations=12, strength=5e-3, routing_interval=4)
    assert depression_share(fourth.heightmap) == 0.0
    assert not np.array_equal(every.heightmap.heights, fourth.heightmap.heights)
    cut_every = hills.heights - every.heightmap.heights
    cut_fourth = hills.heights - fourth.heightmap.heights
    assert cut_fourth.mean() == pytest.approx(cut_every.mean(), rel=0.1)
    with pytest.raises(InvalidParameterError):
        stream_power_erosion(hills, routing_interval=0)
