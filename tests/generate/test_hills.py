"""Cosine hills (Filipović 2008 §2.4): the profile formula, bounding-box locality, errors."""

from __future__ import annotations

from itertools import pairwise

import numpy as np
import pytest

from terrascape.errors import HeightmapSizeError, InvalidParameterError
from terrascape.generate import hills
from terrascape.generate.hills import default_radius_range, draw_hills


def seed_formula(dist: np.ndarray, diameter: float, odmak: float) -> np.ndarray:
    """The thesis's pseudocode with π for 3.14:
    pd = dist*2/diameter; inside: d/2 + cos(pd·π)·d/2."""
    pd = dist * 2 / diameter
    return np.where(np.abs(pd) <= 1.0, odmak / 2 + np.cos(pd * np.pi) * odmak / 2, 0.0)


def test_single_hill_touches_only_its_box_and_follows_formula() -> None:
    shape = (60, 80)
    hm = hills(shape, count=1, radius_range=(6.0, 12.0), height=3.0, seed=21)
    (cx,), (cz,), (r,), (d,) = draw_hills(np.random.default_rng(21), 1, *shape, (6.0, 12.0),
                                          (3.0, 3.0))
    h = hm.heights.astype(np.float64)
    z, x = np.mgrid[0:shape[0], 0:shape[1]].astype(np.float64)
    inside_box = (np.abs(x - cx) <= r) & (np.abs(z - cz) <= r)
    assert np.all(h[~inside_box] == 0.0)
    assert np.count_nonzero(h) > 50
    np.testing.assert_allclose(h, seed_formula(np.hypot(x - cx, z - cz), 2 * r, d), atol=1e-6)
    # Peak next to the centre is close to odmak; nothing exceeds it.
    assert h.max() <= d + 1e-6
    assert h[round(cz), round(cx)] > 0.9 * d


def test_many_hills_sum_and_height_range() -> None:
    shape, n = (45, 38), 40
    hm = hills(shape, count=n, radius_range=(2.0, 10.0), height=(0.5, 2.0), seed=3)
    cx, cz, r, d = draw_hills(np.random.default_rng(3), n, *shape, (2.0, 10.0), (0.5, 2.0))
    assert np.all((d >= 0.5) & (d <= 2.0)) and np.all((r >= 2.0) & (r <= 10.0))
    z, x = np.mgrid[0:shape[0], 0:shape[1]].astype(np.float64)
    ref = sum(seed_formula(np.hypot(x - cx[k], z - cz[k]), 2 * r[k], d[k]) for k in range(n))
    np.testing.assert_allclose(hm.heights, ref, atol=1e-5)
    assert hm.min >= 0.0


def test_determinism_defaults_and_progress() -> None:
    calls = []
    a = hills(64, count=250, seed=5, progress=lambda done, total: calls.append((done, total)))
    b = hills(64, count=250, seed=5)
    c = hills(64, count=250, seed=6)
    assert a.heights.tobytes() == b.heights.tobytes()
    assert a.heights.tobytes() != c.heights.tobytes()
    # progress in hills done (row blocks × chunks of hills): rising, ending at the total
    assert calls[-1] == (250, 250) and 2 <= len(calls) <= 250
    assert all(p[0] <= q[0] for p, q in pairwise(calls)) and {t for _, t in calls} == {250}
    assert default_radius_range(64, 128) == (1.0, 4.0)
    assert a.metadata["radius_range"] == (1.0, 4.0)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"count": 0},
        {"radius_range": 0.0},
        {"radius_range": (5.0, 2.0)},
        {"radius_range": (1.0, 2.0, 3.0)},
        {"height": -1.0},
        {"height": float("nan")},
        {"seed": 1.5},
    ],
)
def test_bad_parameters(kwargs: dict) -> None:
    with pytest.raises(InvalidParameterError):
        hills(16, **kwargs)


def test_bad_shape() -> None:
    with pytest.raises(HeightmapSizeError):
        hills((0, 10))
