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


FRONT = 48  # row of the mountain front


@pytest.fixture(scope="module")
def mountain_front() -> Heightmap:
    """Steep noisy mountains on rows < FRONT over a plain that slopes gently to the far
    border: rivers leave steep ground at the front."""
    n = 129
    z = np.arange(n)[:, None] * np.ones((1, n))
    noise = fbm(n, scale=32.0, octaves=5, seed=4, spacing=4.0).normalised(0, 1).heights
    mountains = np.where(z < FRONT, 60 + (FRONT - z) * 6.0 * (0.6 + 0.8 * noise), 0.0)
    plain = (n - 1 - z) * 0.15 + 3 * noise
    return Heightmap(np.maximum(mountains, plain).astype(np.float32), spacing=(4.0, 4.0))


def test_deposition_builds_fans_at_the_slope_break(mountain_front: Heightmap) -> None:
    drained = stream_power_erosion(mountain_front, iterations=0).heightmap.heights
    kw = {"iterations": 20, "strength": 9e-3, "routing_interval": 4}
    bare = stream_power_erosion(mountain_front, deposition=0.0, **kw).heightmap.heights
    fans = stream_power_erosion(mountain_front, deposition=1.0, **kw)
    h = fans.heightmap.heights
    inner = slice(8, -8)
    mountains, front = (slice(5, FRONT - 4), inner), (slice(FRONT, FRONT + 12), inner)
    # Without deposition nothing rises above the drained input; with it, the ground below
    # the front aggrades while the mountains still erode.
    assert (bare - drained).max() <= 1e-4
    assert ((h - drained)[front] > 0.05).mean() > 0.5
    assert ((h - drained)[mountains] > 0.05).mean() < 0.05
    assert (h - bare)[front].mean() > 0.3
    assert (h - drained)[mountains].mean() < 0
    # Mass budget: every deposit comes from material eroded upstream, and less of it
    # leaves the map than without deposition.
    gained = np.maximum(h - drained, 0).sum()
    lost = np.maximum(drained - h, 0).sum()
    assert 0 < gained < lost
    assert (drained - h).sum() < (drained - bare).sum()
    # the load leaves through the base level: it grows downstream
    assert fans.sediment_flux.max() > 0
    assert depression_share(fans.heightmap) == 0.0
    # deterministic
    again = stream_power_erosion(mountain_front, deposition=1.0, **kw)
    assert again.heightmap.heights.tobytes() == h.tobytes()


def test_default_erosion_deposits_fans_in_its_mask(mountain_front: Heightmap) -> None:
    from terrascape.filters import erode

    with_fans = erode(mountain_front).masks["deposition"]
    without = erode(mountain_front, deposition=0.0).masks["deposition"]
    front = (slice(FRONT, FRONT + 12), slice(8, -8))
    assert with_fans[front].mean() > 0.3
    assert with_fans[front].mean() > 5 * without[front].mean()


@pytest.mark.parametrize("value", [-0.5, 11.0, float("nan")])
def test_deposition_out_of_range_is_refused(hills: Heightmap, value: float) -> None:
    with pytest.raises(InvalidParameterError, match="deposition"):
        stream_power_erosion(hills, deposition=value)
