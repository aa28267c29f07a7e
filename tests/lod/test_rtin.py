"""Static RTIN mesh with a true error bound and a hard triangle budget (terrascape.lod.rtin)."""

from __future__ import annotations

from itertools import pairwise

import numpy as np
import pytest
from scipy import ndimage

from terrascape import Heightmap
from terrascape.errors import HeightmapSizeError, InvalidParameterError
from terrascape.lod import Rtin, conformity_report, max_vertical_error, rtin_mesh


@pytest.fixture(scope="module", params=[0, 1])
def rtin(request):
    rng = np.random.default_rng(100 + request.param)
    if request.param == 0:  # smooth hills in metres
        h = ndimage.gaussian_filter(rng.standard_normal((129, 129)), 4) * 800
    else:  # rough: white noise plus a ramp
        h = rng.random((65, 65)) * 20 + np.arange(65)[None, :] * 3
    return Rtin(Heightmap(h.astype(np.float32), spacing=(5.0, 5.0)))


@pytest.mark.parametrize("max_error", [0.0, 0.25, 1.0, 3.0, 10.0, 40.0])
def test_true_bound_measured_on_every_sample(rtin, max_error):
    m = rtin.mesh(max_error=max_error)
    assert conformity_report(m.triangles, rtin.heightmap.shape).ok
    measured = max_vertical_error(rtin.heightmap, m.triangles)
    assert measured <= max_error + 1e-9
    assert measured <= m.bound + 1e-9 and m.bound <= max_error + 1e-12
    if max_error == 0.0:
        assert measured == 0.0


def test_error_falls_and_triangles_grow_as_the_error_shrinks(rtin):
    counts = [len(rtin.mesh(max_error=e).triangles) for e in (40.0, 10.0, 3.0, 1.0)]
    assert counts == sorted(counts) and counts[0] < counts[-1]


@pytest.mark.parametrize("budget", [2, 3, 50, 333, 1000, 4001])
def test_budget_zero_overshoot(rtin, budget):
    m = rtin.mesh(max_triangles=budget)
    assert len(m.triangles) <= budget
    assert len(m.triangles) >= budget - 1  # each split adds 1 or 2: stops within one
    assert conformity_report(m.triangles, rtin.heightmap.shape).ok
    assert max_vertical_error(rtin.heightmap, m.triangles) <= m.bound + 1e-9


def test_achieved_error_falls_as_budget_grows(rtin):
    budgets = [16, 64, 256, 1024, 4096]
    meshes = [rtin.mesh(max_triangles=b) for b in budgets]
    bounds = [m.bound for m in meshes]
    measured = [max_vertical_error(rtin.heightmap, m.triangles) for m in meshes]
    # the guaranteed bound never rises; the measured error stays below it
    assert all(a >= b for a, b in pairwise(bounds))
    assert bounds[0] > bounds[-1]
    assert all(m <= b + 1e-9 for m, b in zip(measured, bounds, strict=True))
    assert measured[0] > measured[-1]


def test_measured_error_falls_with_budget_on_smooth_terrain():
    # On smooth terrain the measured error is monotone too. (On white noise a child's plane
    # can fit a few samples worse than its parent's did, so only the bound is monotone.)
    rng = np.random.default_rng(9)
    h = ndimage.gaussian_filter(rng.standard_normal((257, 257)), 6) * 2000
    r = Rtin(Heightmap(h.astype(np.float32)))
    measured = [max_vertical_error(r.heightmap, r.mesh(max_triangles=b).triangles)
                for b in (256, 1024, 4096, 16384)]
    assert all(a > b for a, b in pairwise(measured))


def test_first_criterion_wins(rtin):
    by_error = rtin.mesh(max_error=3.0)
    n = len(by_error.triangles)
    both_loose_budget = rtin.mesh(max_error=3.0, max_triangles=n + 100)
    np.testing.assert_array_equal(both_loose_budget.triangles, by_error.triangles)
    tight = rtin.mesh(max_error=3.0, max_triangles=n // 2)
    assert len(tight.triangles) <= n // 2 and tight.bound > 3.0


def test_planar_and_function_api():
    r, c = np.mgrid[0:33, 0:33]
    hm = Heightmap((0.5 * r - 2 * c).astype(np.float32))
    tri = rtin_mesh(hm, max_error=1e-3)
    assert len(tri) == 2 and tri.dtype == np.uint32
    assert conformity_report(tri, hm.shape).ok


def test_bad_inputs():
    with pytest.raises(HeightmapSizeError, match=r"2\*\*n \+ 1"):
        Rtin(Heightmap(np.zeros((30, 30), np.float32)))
    with pytest.raises(HeightmapSizeError):
        Rtin(Heightmap(np.zeros((17, 33), np.float32)))
    r = Rtin(Heightmap(np.zeros((17, 17), np.float32)))
    with pytest.raises(InvalidParameterError, match="max_error"):
        r.mesh(max_error=-1.0)
    with pytest.raises(InvalidParameterError, match="max_error"):
        r.mesh(max_error=float("nan"))
    for bad in (0, 1, -5):
        with pytest.raises(InvalidParameterError, match="max_triangles"):
            r.mesh(max_triangles=bad)
    with pytest.raises(InvalidParameterError, match="max_triangles"):
        r.mesh(max_triangles=10.5)
    with pytest.raises(InvalidParameterError, match="give"):
        r.mesh()


@pytest.mark.parametrize("kind", ["smooth", "rough", "terraced", "spiky"])
def test_one_error_fast_path_equals_the_full_error_table(kind):
    # rtin_mesh(max_error=…) decides each vertex with bounds and early-exit scans instead of
    # every triangle's exact error; the mesh must be the same, triangle for triangle.
    rng = np.random.default_rng(len(kind))
    n = 129
    if kind == "smooth":
        h = ndimage.gaussian_filter(rng.standard_normal((n, n)), 5) * 900
    elif kind == "rough":
        h = rng.random((n, n)) * 30 + np.arange(n)[None, :] * 2
    elif kind == "terraced":  # plateaus: many exact zeros and ties with the tolerance
        h = np.floor(ndimage.gaussian_filter(rng.standard_normal((n, n)), 8) * 200) * 4.0
    else:  # flat with isolated spikes: errors only where a scan reaches a spike
        h = np.zeros((n, n))
        h[rng.integers(0, n, 12), rng.integers(0, n, 12)] = 50.0
    hm = Heightmap(h.astype(np.float32), spacing=(10.0, 10.0))
    full = Rtin(hm)
    tolerances = [0.0, 0.5, 2.0, 4.0, 10.0, 49.9, 50.0, 1000.0]
    tolerances += list(np.quantile(full.errors[full.errors > 0], [0.1, 0.5, 0.9]))  # exact ties
    for tol in tolerances:
        fast = rtin_mesh(hm, max_error=float(tol))
        np.testing.assert_array_equal(fast, full.mesh(max_error=float(tol)).triangles)
        assert max_vertical_error(hm, fast) <= tol


def test_fast_path_bad_inputs():
    with pytest.raises(HeightmapSizeError):
        rtin_mesh(Heightmap(np.zeros((30, 30), np.float32)), max_error=1.0)
    with pytest.raises(InvalidParameterError, match="max_error"):
        rtin_mesh(Heightmap(np.zeros((17, 17), np.float32)), max_error=-1.0)
    with pytest.raises(InvalidParameterError, match="Heightmap"):
        rtin_mesh(np.zeros((17, 17), np.float32), max_error=1.0)
