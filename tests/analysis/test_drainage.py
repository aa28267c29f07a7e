"""Drainage analysis on surfaces with known answers: planes, cones, bowls, Pareto samples."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape.analysis.drainage import (
    breach_depressions,
    depression_share,
    drainage_area,
    drainage_statistics,
    exceedance,
    exceedance_exponent,
    fill_depressions,
    flow_routing,
)
from terrascape.errors import InvalidParameterError
from terrascape.generate import fbm
from terrascape.heightmap import Heightmap


def test_tilted_plane_areas_are_column_lengths() -> None:
    # Falls towards row 0: every interior sample drains straight down its column (D8 picks
    # the axis step, slope 1, over the diagonal, 1/sqrt 2), so the area at row r is the
    # number of interior samples above it plus itself.
    rows, cols = 20, 9
    z = np.arange(rows, dtype=np.float64)[:, None] * np.ones((1, cols))
    area = drainage_area(z)
    # Row 1 of an interior column collects rows 1..rows-2; the bottom border row 0 is an
    # outlet that also receives it.
    np.testing.assert_array_equal(area[1:-1, 3], np.arange(rows - 2, 0, -1))
    assert area[0, 3] == rows - 1
    assert area[-1, 3] == 1  # top border: an outlet, nothing drains into it
    assert depression_share(z) == 0.0


def test_cone_drains_outwards_and_area_sums_to_samples() -> None:
    n = 41
    zz, xx = np.mgrid[0:n, 0:n] - n // 2
    cone = 100.0 - np.hypot(zz, xx)
    routing = flow_routing(cone)
    area = routing.accumulate()
    # The apex drains only itself; outlets (border) together receive every sample.
    assert area[n // 2, n // 2] == 1
    border = np.zeros((n, n), dtype=bool)
    border[0, :] = border[-1, :] = border[:, 0] = border[:, -1] = True
    assert area[border].sum() == n * n
    # Receivers always point away from the centre (radius grows by at least 1 step).
    r = np.hypot(zz, xx).ravel()
    inner = routing.receivers >= 0
    assert (r[routing.receivers[inner]] > r[inner]).all()
    assert depression_share(cone) == 0.0


def test_bowl_is_all_depression_and_fills_to_the_rim() -> None:
    n = 33
    zz, xx = np.mgrid[0:n, 0:n] - n // 2
    bowl = np.hypot(zz, xx).astype(np.float64)
    bowl[0, :] = bowl[-1, :] = bowl[:, 0] = bowl[:, -1] = 1000.0  # a closed rim
    filled = fill_depressions(bowl)
    inner = slice(1, -1)
    # Every interior sample is below the rim: the whole inside is one depression.
    assert depression_share(bowl) == (n - 2) ** 2 / n**2
    # The rim is the only way out, so the lake rises to its lowest point (1000).
    np.testing.assert_array_equal(filled[inner, inner], 1000.0)
    # Still a tree: every sample drains to the border.
    area = drainage_area(bowl)
    border = np.zeros((n, n), dtype=bool)
    border[0, :] = border[-1, :] = border[:, 0] = border[:, -1] = True
    assert area[border].sum() == n * n


def test_pit_in_a_plane_fills_then_breaches() -> None:
    z = np.arange(30, dtype=np.float64)[:, None] * np.ones((1, 12))
    z[15, 6] = 2.0  # a pit 13 units deep
    assert depression_share(z) == pytest.approx(1 / z.size)
    filled = fill_depressions(z)
    assert filled[15, 6] == pytest.approx(14.0)  # up to its lowest neighbour (row 14)
    cut = breach_depressions(z, fill=0.5)
    assert cut[15, 6] == pytest.approx(8.0)  # half filled, then drained by a channel
    assert depression_share(cut) == 0.0
    np.testing.assert_array_equal(breach_depressions(z, fill=1.0), filled)
    with pytest.raises(InvalidParameterError):
        breach_depressions(z, fill=1.5)


def test_exponent_of_pareto_samples() -> None:
    # P(A >= a) = a^-0.45 for a >= 1 exactly (inverse transform of uniform samples).
    u = np.random.default_rng(1).random(400_000)
    areas = u ** (-1 / 0.45)
    assert exceedance_exponent(areas, a_min=2.0, a_max=1000.0) == pytest.approx(0.45, abs=0.01)
    np.testing.assert_allclose(exceedance(areas, [1.0, 10.0]), [1.0, 10**-0.45], rtol=0.02)
    with pytest.raises(InvalidParameterError):
        exceedance_exponent(areas, a_min=10.0, a_max=5.0)


def test_raw_fbm_has_many_depressions_and_is_deterministic() -> None:
    hm = fbm(129, scale=32.0, octaves=6, seed=3, spacing=4.0).normalised(0, 40)
    stats = drainage_statistics(hm)
    assert stats.depression_share > 0.15
    assert 0 < stats.top1_flow_share < 1
    again = drainage_statistics(hm)
    assert again == stats
    assert flow_routing(hm).order.tobytes() == flow_routing(hm).order.tobytes()


def test_nan_refused() -> None:
    z = np.zeros((5, 5))
    z[2, 2] = np.nan
    with pytest.raises(InvalidParameterError):
        flow_routing(z)
    with pytest.raises(InvalidParameterError):
        drainage_area("not an array")  # type: ignore[arg-type]
    assert isinstance(flow_routing(Heightmap(np.ones((4, 4)))).filled, np.ndarray)


def test_the_flood_told_to_stop_ends_at_once() -> None:
    """The flag an interrupted caller sets: the flood takes no more samples from its heap
    (it reads the flag every 65,536 samples, and first before the first)."""
    from terrascape.analysis.drainage import _priority_flood

    h = fbm(129, seed=3).heights.astype(np.float64)
    for stop, taken in ((0, h.size), (1, 0)):
        filled = np.empty_like(h)
        parent = np.empty(h.size, np.int64)
        order = np.empty(h.size, np.int64)
        assert _priority_flood(h, filled, parent, order, np.array([stop], np.uint8)) == taken
