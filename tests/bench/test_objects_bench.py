"""The objects benchmark's scene: its counts, its objects on the drawn surface, seeded."""

from __future__ import annotations

import numpy as np

from terrascape.bench.objects import BUILDINGS, TREES, bench_scene
from terrascape.objects import surface_height


def test_bench_scene_places_trees_and_buildings_on_the_surface():
    hm, inst, size = bench_scene(quick=True)
    assert size == (640, 360) and hm.shape == (257, 257)
    names = [inst.meshes[k].name for k in inst.kind]
    assert sum(n in TREES for n in names) == 2000
    assert sum(n in BUILDINGS for n in names) == 40
    x, y, z = inst.positions.T
    np.testing.assert_allclose(y, surface_height(hm, x, z), atol=1e-4)
    ex, ez = hm.extent
    assert (x > 0).all() and (x < ex).all() and (z > 0).all() and (z < ez).all()
    _, again, _ = bench_scene(quick=True)
    np.testing.assert_array_equal(inst.positions, again.positions)
    np.testing.assert_array_equal(inst.kind, again.kind)
