"""shadow_mask(origin=…): a window with a halo toward the sun gives the whole map's shadow."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape.generate.noise import fbm
from terrascape.heightmap import Heightmap
from terrascape.lighting.shadows import shadow_mask
from terrascape.world.recipe import recipe_from_dict
from terrascape.world.stages import _window, chunk_bounds, shadow_halo


@pytest.mark.parametrize("azimuth", [17.0, 100.0, 200.0, 290.0])
def test_windows_with_origin_match_whole_map(azimuth):
    h = fbm((170, 150), scale=40, octaves=5, amplitude=30.0, seed=4).heights
    whole = shadow_mask(Heightmap(h, (1.0, 1.0)), azimuth, 25.0)
    recipe = recipe_from_dict({"size": [170, 150], "chunk": 48, "generator": {"name": "fbm"},
                               "shadow": {"azimuth": azimuth, "elevation": 25.0}})
    halo = shadow_halo(recipe, float(h.min()), float(h.max()))
    tiled = np.zeros_like(whole)
    without = np.zeros_like(whole)
    for i in range(4):
        for j in range(4):
            r0, r1, c0, c1 = b = chunk_bounds(h.shape, 48, i, j)
            a0, a1, b0, b1 = _window(h.shape, b, halo)
            win = Heightmap(h[a0:a1, b0:b1], (1.0, 1.0))
            crop = (slice(r0 - a0, r1 - a0), slice(c0 - b0, c1 - b0))
            tiled[r0:r1, c0:c1] = shadow_mask(win, azimuth, 25.0, origin=(b0, a0))[crop]
            without[r0:r1, c0:c1] = shadow_mask(win, azimuth, 25.0)[crop]
    assert np.array_equal(tiled, whole)
    # Without the origin the windows' ray lines are their own: edges move (the reason for it).
    assert not np.array_equal(without, whole)
    assert 0.05 < whole.mean() < 0.95


def test_origin_default_is_whole_map():
    h = fbm((60, 70), scale=20, octaves=4, amplitude=20.0, seed=1).heights
    assert np.array_equal(shadow_mask(h, 120.0, 20.0), shadow_mask(h, 120.0, 20.0,
                                                                    origin=(0, 0)))
