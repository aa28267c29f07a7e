"""Dynamic resolution: the render scale follows the frame times to hold the target rate."""

from __future__ import annotations

import math

import pytest

from terrascape.errors import InvalidParameterError
from terrascape.viewer.resolution import HEADROOM, QUANTUM, ResolutionControl


def _fly(control: ResolutionControl, cost, frames: int) -> list[float]:
    """Feed ``frames`` frame times of ``cost(scale)`` ms; the scales they were drawn at."""
    drawn = []
    for _ in range(frames):
        drawn.append(control.scale)
        control.update(cost(control.scale))
    return drawn


@pytest.mark.parametrize("fixed, per_pixel", [(30.0, 72.0), (0.0, 100.0), (50.0, 40.0)])
def test_a_heavy_look_settles_at_the_largest_scale_that_holds_the_rate(fixed, per_pixel):
    control = ResolutionControl(target_fps=15.0)

    def cost(s: float) -> float:
        return fixed + per_pixel * s * s

    drawn = _fly(control, cost, 40)
    budget = 1000.0 / 15.0
    settled = drawn[-1]
    assert drawn[-15:] == [settled] * 15  # settled, no oscillation
    assert cost(settled) <= budget  # the rate is held
    # and not much smaller than needed: one more step up would miss the aimed frame time
    best = max(k * QUANTUM for k in range(1, 21) if cost(k * QUANTUM) <= budget * HEADROOM)
    assert settled >= best - QUANTUM - 1e-9
    assert drawn.index(settled) <= 12  # found within a second at 15 frames/s


def test_light_looks_stay_full_size_and_a_lighter_one_grows_back():
    control = ResolutionControl(target_fps=15.0)
    assert _fly(control, lambda s: 50.0, 20) == [1.0] * 20
    control.scale = 0.5
    drawn = _fly(control, lambda s: 20.0 + 30.0 * s * s, 30)
    assert drawn[-1] == 1.0 and drawn == sorted(drawn)  # grows, never back down


def test_one_slow_frame_does_not_shrink_it():
    control = ResolutionControl(target_fps=15.0)
    times = [50.0] * 5 + [400.0] + [50.0] * 10
    drawn = []
    for t in times:
        drawn.append(control.scale)
        control.update(t)
    assert set(drawn) == {1.0}


def test_the_lowest_scale_bounds_it_and_restart_returns_to_full_size():
    control = ResolutionControl(target_fps=30.0, min_scale=0.5)
    assert _fly(control, lambda s: 500.0 * s * s, 40)[-1] == 0.5
    control.restart()
    assert control.scale == 1.0 and control.frame_ms is None


def test_target_zero_is_off_and_bad_settings_are_refused():
    control = ResolutionControl(target_fps=0.0)
    assert not control.active
    assert _fly(control, lambda s: 1000.0, 10) == [1.0] * 10
    for t in (math.nan, -1.0, 0.0):
        assert ResolutionControl().update(t) == 1.0
    with pytest.raises(InvalidParameterError, match="target frame rate"):
        ResolutionControl(target_fps=-5.0)
    with pytest.raises(InvalidParameterError, match="lowest render scale"):
        ResolutionControl(min_scale=0.0)


def test_a_frame_whose_time_is_not_in_its_pixels_goes_back_to_full_size():
    """70 ms of LOD update and vertices and 6 ms of pixels: shrinking cannot reach 66.7 ms,
    so the one step tried is taken back and the frames stay full size."""
    control = ResolutionControl(target_fps=15.0)
    drawn = _fly(control, lambda s: 70.0 + 6.0 * s * s, 60)
    assert drawn[-40:] == [1.0] * 40
    assert min(drawn) >= 0.75  # one step down was tried, no more
