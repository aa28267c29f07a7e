"""Greedy Delaunay insertion: the error bound on every sample, a conforming mesh, any size."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from terrascape.errors import InvalidParameterError
from terrascape.generate import diamond_square
from terrascape.heightmap import Heightmap
from terrascape.lod import rtin_mesh
from terrascape.lod.greedy_tin import greedy_tin
from terrascape.lod.mesh_checks import conformity_report, max_vertical_error, sample_errors


def _terrain(n=129, seed=3, relief=60.0):
    return diamond_square(n, roughness=0.6, seed=seed).normalised(0.0, relief)


@pytest.mark.parametrize("max_error", [0.5, 2.0, 8.0])
def test_error_bound_holds_on_every_sample_and_mesh_conforms(max_error):
    hm = _terrain()
    tri = greedy_tin(hm, max_error=max_error)
    report = conformity_report(tri, hm.shape)
    assert report.ok, str(report)
    assert max_vertical_error(hm, tri) <= max_error + 1e-9
    # not trivially fine: the error is close to the bound (the greedy stops just under it)
    assert max_vertical_error(hm, tri) > 0.5 * max_error


def test_fewer_triangles_than_rtin_at_the_same_error():
    hm = _terrain(257, seed=5, relief=120.0)
    for e in (1.0, 4.0):
        greedy = greedy_tin(hm, max_error=e)
        rtin = rtin_mesh(hm, max_error=e)
        assert len(greedy) < 0.8 * len(rtin)


def test_lossless_at_zero_error_and_flat_map_is_two_triangles():
    hm = _terrain(33, relief=10.0)
    tri = greedy_tin(hm, max_error=0.0)
    assert np.all(sample_errors(hm, tri) < 1e-4)
    flat = Heightmap(np.full((17, 40), 3.0, np.float32))
    assert len(greedy_tin(flat, max_error=0.1)) == 2


def test_rectangular_grid_and_budget():
    rng = np.random.default_rng(0)
    h = np.cumsum(np.cumsum(rng.standard_normal((57, 90)), 0), 1).astype(np.float32)
    hm = Heightmap(h, spacing=(2.0, 2.0))
    tri = greedy_tin(hm, max_error=1.0)
    assert conformity_report(tri, hm.shape).ok
    assert max_vertical_error(hm, tri) <= 1.0 + 1e-9
    capped = greedy_tin(hm, max_error=1.0, max_triangles=200)
    assert 150 <= len(capped) <= 200
    assert conformity_report(capped, hm.shape).ok


def test_deterministic():
    hm = _terrain(129, seed=9)
    np.testing.assert_array_equal(greedy_tin(hm, max_error=1.5), greedy_tin(hm, max_error=1.5))


def test_bad_input():
    hm = _terrain(33)
    with pytest.raises(InvalidParameterError):
        greedy_tin(hm)
    with pytest.raises(InvalidParameterError):
        greedy_tin(hm, max_error=-1.0)
    with pytest.raises(InvalidParameterError):
        greedy_tin(hm.heights, max_error=1.0)


@pytest.mark.skipif(importlib.util.find_spec("pydelatin") is None,
                    reason="pydelatin (a peer) is not installed")
@pytest.mark.parametrize("max_error", [1.0, 5.0])
def test_no_more_triangles_than_pydelatin(max_error):
    from pydelatin import Delatin

    hm = _terrain(257, seed=2, relief=150.0)
    peer = Delatin(hm.heights, width=257, height=257, max_error=max_error)
    ours = greedy_tin(hm, max_error=max_error)
    assert len(ours) <= len(peer.triangles) * 1.001 + 2
