"""Diamond-square: decay laws (Filipović 2008 §5.3.1), per-level statistics, integer mode,
errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from terrascape.errors import HeightmapSizeError, InvalidParameterError, TerrascapeError
from terrascape.generate import detail_depth, diamond_square, roughness_schedule


def level_residuals(h: np.ndarray, *, integer: bool = False) -> list[np.ndarray]:
    """Offset added at every level: sample minus the mean of its parents (recomputed here).

    Every sample is written once and never changed afterwards, so the final map still holds
    each level's parents.
    """
    n = h.shape[0]
    s = n - 1
    out = []
    h64 = h.astype(np.float64)
    while s > 1:
        half = s // 2
        res = []
        for i in range(half, n, s):
            for j in range(half, n, s):
                tot = h64[i - half, j - half] + h64[i - half, j + half]
                tot += h64[i + half, j - half] + h64[i + half, j + half]
                mean = math.trunc(tot / 4) if integer else tot / 4
                res.append(h64[i, j] - mean)
        for i in range(0, n, half):
            for j in range(half if (i // half) % 2 == 0 else 0, n, s):
                nb = [h64[a, b] for a, b in ((i - half, j), (i + half, j), (i, j - half),
                                             (i, j + half)) if 0 <= a < n and 0 <= b < n]
                mean = math.trunc(sum(nb) / len(nb)) if integer else sum(nb) / len(nb)
                res.append(h64[i, j] - mean)
        out.append(np.array(res))
        s = half
    return out


def test_seed_depth_analysis_8bit() -> None:
    # Filipović 2008 §5.3.1: start 255; linear (-40) hits 0 at depth 7, halving (>>1) at depth 8,
    # rounded sqrt falls to 1 at depth 4.
    assert detail_depth(255, "linear", step=40, integer=True) == 7
    assert detail_depth(255, "halve", integer=True) == 8
    assert detail_depth(255, "sqrt", integer=True) == 4
    lin = roughness_schedule(255, "linear", step=40, integer=True, levels=9)
    assert lin.tolist() == [255, 215, 175, 135, 95, 55, 15, 0, 0]
    div = roughness_schedule(255, "halve", integer=True, levels=9)
    assert div.tolist() == [255, 127, 63, 31, 15, 7, 3, 1, 0]
    sq = roughness_schedule(255, "sqrt", integer=True, levels=6)
    assert sq.tolist() == [255, 16, 4, 2, 1, 1]


def test_float_schedules() -> None:
    np.testing.assert_allclose(roughness_schedule(8.0, "halve", levels=4), [8, 4, 2, 1])
    np.testing.assert_allclose(
        roughness_schedule(1.0, "hurst", hurst=0.5, levels=5), 2.0 ** (-0.5 * np.arange(5))
    )
    np.testing.assert_allclose(roughness_schedule(16.0, "sqrt", levels=3), [16, 4, 2])
    # Default linear step reaches zero exactly after the last level.
    np.testing.assert_allclose(roughness_schedule(4.0, "linear", levels=4), [4, 3, 2, 1])
    # tol = 1e-3: at depth 9 the step to the next level, 2**-10, is below tol.
    assert detail_depth(1.0, "halve") == 9
    # Float sqrt from 255: 255, 15.97, 4.0, 2.0, 1.414, 1.189 — the step 0.225 < 0.255 = tol.
    assert detail_depth(255.0, "sqrt") == 4


@pytest.mark.parametrize("decay", ["halve", "hurst", "linear", "sqrt"])
def test_level_offsets_follow_the_law(decay: str) -> None:
    size, r0 = 129, 100.0
    hm = diamond_square(size, roughness=r0, decay=decay, hurst=0.6, decay_step=20.0, seed=7)
    sched = roughness_schedule(r0, decay, hurst=0.6, step=20.0, levels=7)
    assert hm.metadata["roughness_schedule"] == pytest.approx(sched.tolist())
    res = level_residuals(hm.heights)
    assert len(res) == 7
    for k, (r, rk) in enumerate(zip(res, sched, strict=True)):
        # The offset is uniform in [-r_k, r_k]: bounded, and std r_k/sqrt(3) once enough samples.
        assert np.abs(r).max() <= rk * (1 + 1e-5) + 1e-3, (decay, k)
        if r.size >= 500:
            assert np.std(r) == pytest.approx(rk / math.sqrt(3), rel=0.08, abs=1e-3), (decay, k)
    if decay == "linear":
        # 100 - 5*20 = 0: the schedule stays at 0 and the last two levels add nothing.
        assert sched[-1] == 0.0
        assert np.abs(res[-1]).max() < 1e-3


def test_sqrt_law_loses_high_frequencies() -> None:
    kw = {"roughness": 255.0, "seed": 3}
    div = diamond_square(257, decay="halve", **kw).heights.astype(np.float64)
    sqr = diamond_square(257, decay="sqrt", **kw).heights.astype(np.float64)

    def fine_share(h: np.ndarray) -> float:
        # Share of neighbour-difference energy relative to the overall relief.
        return float(np.std(np.diff(h, axis=1)) / np.std(h))

    assert fine_share(sqr) < 0.5 * fine_share(div)


def test_determinism_and_corners() -> None:
    a = diamond_square(65, roughness=3.0, seed=11)
    b = diamond_square(65, roughness=3.0, seed=11)
    c = diamond_square(65, roughness=3.0, seed=12)
    assert a.heights.tobytes() == b.heights.tobytes()
    assert a.heights.tobytes() != c.heights.tobytes()
    assert a.heights.dtype == np.float32 and a.shape == (65, 65)
    # Random corners lie within [-r0, r0].
    corners = a.heights[[0, 0, -1, -1], [0, -1, 0, -1]]
    assert np.all(np.abs(corners) <= 3.0)
    fixed = diamond_square(33, corners=(1.0, 2.0, 3.0, 4.0), roughness=0.0, seed=1,
                           spacing=(2.0, 3.0))
    h = fixed.heights
    assert (h[0, 0], h[0, -1], h[-1, 0], h[-1, -1]) == (1.0, 2.0, 3.0, 4.0)
    assert fixed.spacing == (2.0, 3.0)
    # With zero roughness the surface is pure (bilinear-like) interpolation: centre = mean.
    assert h[16, 16] == pytest.approx(2.5)
    assert h[0, 16] == pytest.approx((1 + 2 + h[16, 16]) / 3)


def test_integer_mode_follows_integer_arithmetic() -> None:
    hm = diamond_square(129, roughness=255, decay="linear", decay_step=40, integer=True, seed=5)
    h = hm.heights
    assert np.all(h == np.round(h))
    res = level_residuals(h, integer=True)
    sched = [255, 215, 175, 135, 95, 55, 15]
    for r, rk in zip(res, sched, strict=True):
        assert np.all(r == np.round(r))
        assert np.abs(r).max() <= rk
    # Offsets use the whole integer range [-r, r] at a level with enough samples.
    assert res[6].max() == 15 and res[6].min() == -15
    # Depth 7 is where linear decay reaches 0: a 257 grid's last level is a pure truncating mean.
    h257 = diamond_square(257, roughness=255, decay="linear", decay_step=40, integer=True).heights
    assert np.all(level_residuals(h257, integer=True)[7] == 0)
    with pytest.raises(InvalidParameterError, match="integer"):
        diamond_square(17, roughness=2.5, integer=True)
    with pytest.raises(InvalidParameterError, match="integer"):
        diamond_square(17, roughness=255, decay="linear", decay_step=2.5, integer=True)


@pytest.mark.parametrize("size", [0, 1, 2, 10, 256, 1024, -3])
def test_bad_sizes(size: int) -> None:
    with pytest.raises(HeightmapSizeError, match="2\\*\\*n \\+ 1"):
        diamond_square(size)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"decay": "cubic"},
        {"roughness": -1.0},
        {"roughness": float("nan")},
        {"decay": "linear", "decay_step": -2.0},
        {"decay": "linear", "decay_step": float("inf")},
        {"decay": "hurst", "hurst": 1.5},
        {"corners": (1.0, 2.0)},
        {"corners": (1.0, 2.0, float("nan"), 0.0)},
        {"seed": -1},
        {"spacing": 0.0},
    ],
)
def test_bad_parameters(kwargs: dict) -> None:
    with pytest.raises(InvalidParameterError):
        diamond_square(17, **kwargs)


def test_schedule_errors_are_typed() -> None:
    with pytest.raises(InvalidParameterError, match="decay must be one of"):
        roughness_schedule(1.0, "log")
    with pytest.raises(TerrascapeError):
        detail_depth(1.0, "halve", tol=-1.0)
    with pytest.raises(InvalidParameterError):
        roughness_schedule(1.0, "halve", levels=0)
