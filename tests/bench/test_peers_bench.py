"""The peers benchmark's helpers: paired ratios, the sampled exact walk, the peer's axes."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from terrascape.bench.peers import exact_shadow_at, insolation_shadow, paired_ratio
from terrascape.bench.shade import terrain
from terrascape.lighting import shadow_mask_reference


def test_paired_ratio_of_known_costs():
    """Sleeps of 40 and 20 ms, 5 rounds: long enough that a loaded host's wake-up latency
    (a few ms) does not move the ratio out of its bounds, as it did with 4 and 2 ms."""
    import time

    def slow():
        time.sleep(0.04)

    def fast():
        time.sleep(0.02)

    median, lo, hi, t_slow, t_fast = paired_ratio(slow, fast, rounds=5)
    assert lo <= median <= hi
    assert 1.3 < median < 3.0
    assert t_slow > t_fast


@pytest.mark.parametrize(("az", "el"), [(30.0, 8.0), (135.0, 20.0), (290.0, 40.0)])
def test_exact_shadow_at_samples_equals_the_full_ray_walk(az, el):
    hm = terrain(129, seed=2)
    full = shadow_mask_reference(hm, az, el)
    rng = np.random.default_rng(0)
    rows, cols = rng.integers(0, 129, 500), rng.integers(0, 129, 500)
    np.testing.assert_array_equal(exact_shadow_at(hm, az, el, rows, cols), full[rows, cols])


@pytest.mark.skipif(importlib.util.find_spec("insolation") is None,
                    reason="insolation (a peer) is not installed")
@pytest.mark.parametrize("az", [30.0, 135.0, 225.0, 315.0])
def test_peer_shadows_fall_on_the_same_side(az):
    """The axis conversion is right: the peer agrees with the exact walk almost everywhere."""
    hm = terrain(129, seed=4).normalised(0.0, 40.0)
    ref = shadow_mask_reference(hm, az, 15.0)
    peer = insolation_shadow(hm, az, 15.0)
    assert ref.mean() > 0.05
    assert np.mean(peer == ref) > 0.9
