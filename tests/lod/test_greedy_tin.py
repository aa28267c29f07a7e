"""Greedy Delaunay insertion: the error bound on every sample, a conforming mesh, any size."""

from __future__ import annotations

import importlib.util
import os
from itertools import pairwise

import numpy as np
import pytest
from scipy import ndimage

from terrascape.errors import InvalidParameterError
from terrascape.generate import diamond_square
from terrascape.heightmap import Heightmap
from terrascape.lod import rtin_mesh
from terrascape.lod.greedy_tin import greedy_tin
from terrascape.lod.mesh_checks import (
    conformity_report,
    line_edge_share,
    max_vertical_error,
    sample_errors,
)


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
    # the greedy insertion alone matches pydelatin's count (the same algorithm); the
    # removal of the vertices it no longer needs takes a tenth to a fifth away
    assert len(ours) <= 0.95 * len(peer.triangles)


def test_removing_redundant_vertices_keeps_the_bound_with_fewer_triangles(monkeypatch):
    from terrascape.lod import greedy_tin as gt

    rng = np.random.default_rng(4)
    quantised = np.round(_terrain(129, seed=6, relief=90.0).heights)  # many equal errors
    for hm in (_terrain(257, seed=2, relief=150.0), Heightmap(quantised.astype(np.float32)),
               Heightmap(np.cumsum(rng.standard_normal((70, 101)), 1).astype(np.float32))):
        for max_error in (0.0, 1.0, 4.0):
            # one greedy order: pieces dense enough are decimated from every sample instead
            monkeypatch.setattr(gt, "_REMOVAL_PASSES", 0)
            inserted = gt.greedy_tin(hm, max_error=max_error, in_pieces=False)
            monkeypatch.setattr(gt, "_REMOVAL_PASSES", 8)
            pruned = gt.greedy_tin(hm, max_error=max_error, in_pieces=False)
            assert conformity_report(pruned, hm.shape).ok
            assert max_vertical_error(hm, pruned) <= max_error + 1e-9
            # lossless (0 m): only vertices exactly on their neighbours' planes can go
            assert len(pruned) <= len(inserted)
            # only vertices go, none is added: the pruned mesh's vertices are the inserted ones'
            assert set(np.unique(pruned)) <= set(np.unique(inserted))
            if max_error > 0 and len(inserted) > 200:
                assert len(pruned) < 0.95 * len(inserted)


def test_no_removal_when_the_budget_stops_first(monkeypatch):
    from terrascape.lod import greedy_tin as gt

    hm = _terrain(129, seed=8)
    capped = gt.greedy_tin(hm, max_error=0.01, max_triangles=300)
    monkeypatch.setattr(gt, "_REMOVAL_PASSES", 0)
    assert np.array_equal(capped, gt.greedy_tin(hm, max_error=0.01, max_triangles=300))


def _candidate_reference(h, p):
    """The largest |plane − height| over a triangle's samples by brute force (numpy)."""
    (x0, y0), (x1, y1), (x2, y2) = p
    ys, xs = np.mgrid[min(y0, y1, y2):max(y0, y1, y2) + 1, min(x0, x1, x2):max(x0, x1, x2) + 1]

    def orient(ax, ay, bx, by, cx, cy):
        return (bx - cx) * (ay - cy) - (by - cy) * (ax - cx)

    w0 = orient(x1, y1, x2, y2, xs, ys)
    w1 = orient(x2, y2, x0, y0, xs, ys)
    w2 = orient(x0, y0, x1, y1, xs, ys)
    area = orient(x0, y0, x1, y1, x2, y2)
    inside = (w0 >= 0) & (w1 >= 0) & (w2 >= 0)
    z = (h[y0, x0] * w0 + h[y1, x1] * w1 + h[y2, x2] * w2) / area
    err = np.where(inside, np.abs(z - h[ys, xs]), -1.0)
    return err, xs, ys


@pytest.mark.parametrize("rough", [False, True])
def test_candidate_search_equals_brute_force(rough):
    """Every path of the candidate search (sample by sample, row spans, tiles searched by
    their error bound) finds the brute-force maximum and its first sample in row order;
    searched from a floor, the same when the maximum is above it; asked whether any sample
    is above the floor, the right answer; searched sparsely (the refinement), the worst
    lattice sample when it is above the floor, else the full search's answer."""
    from terrascape.lod import greedy_tin as gt

    rng = np.random.default_rng(11 if rough else 12)
    rows, cols = 150, 200
    if rough:
        h = rng.uniform(0.0, 50.0, (rows, cols))
    else:
        h = np.cumsum(np.cumsum(rng.standard_normal((rows, cols)), 0), 1) * 0.1
    h = h.astype(np.float32)
    h.flags.writeable = False  # as the mesher hands heights to its kernels
    tiles = (-(-rows // gt._TILE), -(-cols // gt._TILE))
    tplane, tres = np.empty((*tiles, 3)), np.empty((*tiles, 4))
    gt._tile_ranges(h, tplane, tres)
    bound, order = np.empty(tres[..., 0].size), np.empty(tres[..., 0].size, np.int64)
    h64 = h.astype(np.float64)
    sizes = {"box": 0, "rows": 0, "tiles": 0, "lattice": 0}
    for k in range(300):
        span = (6, 40, 200)[k % 3]
        p = np.stack([rng.integers(0, min(cols, span), 3), rng.integers(0, min(rows, span), 3)], 1)
        p += [rng.integers(0, cols - p[:, 0].max()), rng.integers(0, rows - p[:, 1].max())]
        (x0, y0), (x1, y1), (x2, y2) = p
        area = (x1 - x2) * (y0 - y2) - (y1 - y2) * (x0 - x2)
        if area == 0:
            continue
        if area < 0:
            p = p[[0, 2, 1]]
        box = np.ptp(p[:, 0]) + 1, np.ptp(p[:, 1]) + 1
        n_box = int(box[0] * box[1])
        sizes["box" if n_box <= gt._BOX_SCAN else "rows" if n_box <= gt._TILED_SEARCH
              else "tiles"] += 1
        coords = p.astype(np.int64)
        tris = np.arange(3, dtype=np.int32)
        cand, cerr = np.zeros((1, 2), np.int32), np.zeros(1)
        gt._rasterise(h, tplane, tres, bound, order, coords, tris, 0, cand, cerr, 0.0, False)
        err, xs, ys = _candidate_reference(h64, coords)
        best = err.max()
        if best < 1e-6:
            assert cerr[0] < 1e-6
            continue
        assert cerr[0] == pytest.approx(best, rel=1e-9)
        first = np.flatnonzero(err.ravel() >= best - 1e-9 * best)[0]
        assert (cand[0, 0], cand[0, 1]) == (xs.ravel()[first], ys.ravel()[first])
        found = cerr[0], tuple(cand[0])
        # from a floor (the mesh's error) below the maximum: the same sample; above it: no
        # sample beyond the floor. Asked only whether one is beyond: the answer, not the
        # largest
        for floor in (0.5 * best, 0.99 * best, 1.01 * best, 2.0 * best):
            gt._rasterise(h, tplane, tres, bound, order, coords, tris, 0, cand, cerr, floor,
                          False)
            if best > floor:
                assert (cerr[0], tuple(cand[0])) == found
            else:
                assert cerr[0] <= floor
            gt._rasterise(h, tplane, tres, bound, order, coords, tris, 0, cand, cerr, floor,
                          True)
            assert (cerr[0] > floor) == (best > floor)
            if best > floor:  # a sample of the triangle, with its own error
                at = (xs == cand[0, 0]) & (ys == cand[0, 1])
                assert cerr[0] == pytest.approx(err[at][0], rel=1e-9)
            # the refinement's sparse search: a large triangle's worst lattice sample when
            # it is beyond the floor, otherwise the full search's answer
            step = 1
            while n_box > gt._SPARSE_SAMPLES * (2 * step) ** 2:
                step *= 2
            sizes["lattice"] += step > 1
            lattice = np.where((xs % step == 0) & (ys % step == 0), err, -1.0)
            gt._rasterise(h, tplane, tres, bound, order, coords, tris, 0, cand, cerr, floor,
                          False, True)
            if step > 1 and lattice.max() > floor:
                first = np.flatnonzero(lattice.ravel() >= lattice.max() * (1 - 1e-9))[0]
                assert cerr[0] == pytest.approx(lattice.max(), rel=1e-9)
                assert (cand[0, 0], cand[0, 1]) == (xs.ravel()[first], ys.ravel()[first])
            elif best > floor:
                assert (cerr[0], tuple(cand[0])) == found
            else:
                assert cerr[0] <= floor
    assert min(sizes.values()) >= 20, sizes


@pytest.mark.parametrize("in_pieces", [True, False])
def test_a_spike_between_the_lattice_samples_is_still_found(monkeypatch, in_pieces):
    """Single-sample spikes on odd rows and columns of a flat map: the sparse search of a
    large triangle never sees them, so only the full search before a triangle is settled
    finds them; every one must become a vertex."""
    from terrascape.lod import greedy_tin as gt

    monkeypatch.setattr(gt, "_PIECE", 100)
    h = np.zeros((301, 257), np.float32)
    spikes = [(37, 101), (151, 201), (255, 33), (99, 99), (201, 155)]
    for y, x in spikes:
        h[y, x] = 5.0
    hm = Heightmap(h)
    tri = gt.greedy_tin(hm, max_error=1.0, in_pieces=in_pieces)
    assert max_vertical_error(hm, tri) <= 1.0
    used = set(np.unique(tri).tolist())
    assert all(y * 257 + x in used for y, x in spikes)


def test_same_mesh_on_one_thread_or_two():
    import numba

    hm = _terrain(129, seed=4)
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = greedy_tin(hm, max_error=1.0)
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        two = greedy_tin(hm, max_error=1.0)
    finally:
        numba.set_num_threads(before)
    np.testing.assert_array_equal(one, two)


# --- the mesh built in pieces ----------------------------------------------------------------
def _piece_maps():
    rng = np.random.default_rng(11)
    walk = np.cumsum(np.cumsum(rng.standard_normal((97, 143)), 0), 1).astype(np.float32)
    quantised = np.round(_terrain(129, seed=6, relief=90.0).heights).astype(np.float32)
    return [_terrain(129, seed=12, relief=120.0), Heightmap(walk, spacing=(3.0, 3.0)),
            Heightmap(quantised)]


@pytest.mark.parametrize("max_error", [0.0, 0.7, 3.0])
def test_pieces_keep_the_bound_and_meet_without_cracks(monkeypatch, max_error):
    from terrascape.lod import greedy_tin as gt

    for hm in _piece_maps():
        monkeypatch.setattr(gt, "_PIECE", 10**6)
        whole = gt.greedy_tin(hm, max_error=max_error)
        monkeypatch.setattr(gt, "_PIECE", 40)
        assert len(gt._piece_edges(hm.shape[0])) > 2  # several pieces each way
        pieces = gt.greedy_tin(hm, max_error=max_error)
        # no crack and no T-junction where pieces meet, and the bound on every sample
        report = conformity_report(pieces, hm.shape)
        assert report.ok, str(report)
        err = max_vertical_error(hm, pieces)
        assert err <= max_error + 1e-9
        if max_error == 0.0:
            assert np.all(sample_errors(hm, pieces) < 1e-4)
        else:
            assert err > 0.5 * max_error
        # the shared lines cost few triangles (here pieces are only 40 samples wide)
        assert len(pieces) <= 1.1 * len(whole) + 20


def _side_keep(side, line_tol):
    """Mask of the samples of one piece's side that its simplification keeps (every
    sample when the tolerance is not above 0), as the pieces compute it."""
    from terrascape.lod.greedy_tin import _simplify_line

    keep = np.ones(side.shape[0], np.bool_)
    if line_tol > 0:
        _simplify_line(np.ascontiguousarray(side), line_tol, keep)
    return keep


def _line_keeps(h, tol, ys, xs):
    """Per row line and column line, the samples each piece's side keeps (as the pieces
    simplify them; the map's own borders stay empty)."""
    from terrascape.lod import greedy_tin as gt

    rows, cols = h.shape
    line_tol = gt._line_tolerance(gt._magnitude(h), tol)
    row_keep = np.zeros((len(ys), cols), np.bool_)
    col_keep = np.zeros((len(xs), rows), np.bool_)
    for k, y in enumerate(ys[1:-1], start=1):
        for x0, x1 in pairwise(xs):
            row_keep[k, x0:x1 + 1] = _side_keep(h[y, x0:x1 + 1], line_tol)
    for k, x in enumerate(xs[1:-1], start=1):
        for y0, y1 in pairwise(ys):
            col_keep[k, y0:y1 + 1] = _side_keep(h[y0:y1 + 1, x], line_tol)
    return row_keep, col_keep


def test_pieces_meet_on_their_line_vertices_and_relax_the_seams(monkeypatch):
    from terrascape.lod import greedy_tin as gt

    hm = _terrain(129, seed=13, relief=100.0)
    monkeypatch.setattr(gt, "_PIECE", 40)
    rows, cols = hm.shape
    ys, xs = gt._piece_edges(rows), gt._piece_edges(cols)
    row_keep, col_keep = _line_keeps(hm.heights, 1.5, ys, xs)
    for k, y in enumerate(ys[1:-1], start=1):
        # the simplification holds each line within the error (tighter, not looser)
        kept = np.flatnonzero(row_keep[k])
        line = np.interp(np.arange(cols), kept, hm.heights[y, kept].astype(np.float64))
        assert np.abs(line - hm.heights[y]).max() <= 1.5

    def line_edges(tri):
        """How much of the inner lines' length runs along mesh edges."""
        return line_edge_share(tri, hm.shape, ys[1:-1], xs[1:-1])

    tri = gt.greedy_tin(hm, max_error=1.5)
    verts = np.unique(tri)
    r, c = verts // cols, verts % cols
    for k, y in enumerate(ys[1:-1], start=1):
        # the mesh keeps only line vertices the simplification chose (some go at the seams)
        assert set(c[r == y]) <= set(np.flatnonzero(row_keep[k]))
    for k, x in enumerate(xs[1:-1], start=1):
        assert set(r[c == x]) <= set(np.flatnonzero(col_keep[k]))
    # without the flips at the seams, most of the lines' length stays mesh edges; the
    # flips (each kept only within the error) take a good part of it away
    monkeypatch.setattr(gt, "_relax_edges", lambda *a: None)
    unrelaxed = gt.greedy_tin(hm, max_error=1.5)
    assert line_edges(unrelaxed) > 0.7
    assert line_edges(tri) < 0.8 * line_edges(unrelaxed)
    assert max_vertical_error(hm, tri) <= 1.5 + 1e-9


def test_simplified_line_is_the_greedy_polyline():
    from terrascape.lod.greedy_tin import _simplify_line

    rng = np.random.default_rng(5)
    z = np.cumsum(rng.standard_normal(300)).astype(np.float32)
    keep = np.zeros(300, np.bool_)
    _simplify_line(z, 2.0, keep)
    kept = np.flatnonzero(keep)
    assert kept[0] == 0 and kept[-1] == 299
    line = np.interp(np.arange(300), kept, z[kept].astype(np.float64))
    assert np.abs(line - z).max() <= 2.0
    # the same points as the recursion written out in numpy: split each segment at its
    # worst sample (the first of equal ones) while that is beyond the error
    expected = {0, 299}
    segments = [(0, 299)]
    while segments:
        a, b = segments.pop()
        i = np.arange(a + 1, b)
        if len(i) == 0:
            continue
        za = float(z[a])
        err = np.abs(za + (float(z[b]) - za) / (b - a) * (i - a) - z[i].astype(np.float64))
        if err.max() > 2.0:
            m = int(i[np.argmax(err)])
            expected.add(m)
            segments += [(a, m), (m, b)]
    assert set(kept.tolist()) == expected
    _simplify_line(np.zeros(50, np.float32), 0.5, keep[:50])
    assert np.flatnonzero(keep[:50]).tolist() == [0, 49]


def _on_threads(n, job):
    """``job()`` on ``n`` of numba's threads (at most as many as it has)."""
    import numba

    before = numba.get_num_threads()
    try:
        numba.set_num_threads(min(n, numba.config.NUMBA_NUM_THREADS))
        return job()
    finally:
        numba.set_num_threads(before)


def test_pieces_same_mesh_on_one_thread_or_two(monkeypatch):
    """Pieces meshed on one thread, on two (the threads' pool), and on two again (the pool
    kept for the next mesh): the same mesh."""
    import numba

    from terrascape.lod import greedy_tin as gt

    hm = _terrain(129, seed=14, relief=80.0)
    monkeypatch.setattr(gt, "_PIECE", 50)
    one = _on_threads(1, lambda: gt.greedy_tin(hm, max_error=0.8))
    two = _on_threads(2, lambda: gt.greedy_tin(hm, max_error=0.8))
    pools = dict(gt._POOLS)
    again = _on_threads(2, lambda: gt.greedy_tin(hm, max_error=0.8))
    assert pools == gt._POOLS  # the same threads meshed it again
    if min(2, numba.config.NUMBA_NUM_THREADS) == 2:
        assert (os.getpid(), 2) in pools
    np.testing.assert_array_equal(one, two)
    np.testing.assert_array_equal(one, again)


def test_pieces_tile_bounds_are_the_whole_maps(monkeypatch):
    """The seams are searched with the whole map's tile bounds, put together from the
    pieces' own: they must be exactly those of the map (a wrong bound could skip the worst
    sample of a triangle)."""
    from terrascape.lod import greedy_tin as gt

    rng = np.random.default_rng(8)
    h = np.cumsum(rng.standard_normal((150, 211)), 1).astype(np.float32)
    monkeypatch.setattr(gt, "_PIECE", 48)
    seen = {}
    join = gt._join_pieces

    def spy(h, tol, parts, tplane, tres, ys, xs):
        seen["tiles"] = tplane.copy(), tres.copy()
        return join(h, tol, parts, tplane, tres, ys, xs)

    monkeypatch.setattr(gt, "_join_pieces", spy)
    gt.greedy_tin(Heightmap(h), max_error=0.5)
    assert all(e % gt._TILE == 0 for e in gt._piece_edges(150)[:-1])
    tiles = (-(-150 // gt._TILE), -(-211 // gt._TILE))
    tplane, tres = np.empty((*tiles, 3)), np.empty((*tiles, 4))
    gt._tile_ranges(h, tplane, tres)
    np.testing.assert_array_equal(seen["tiles"][0], tplane)
    np.testing.assert_array_equal(seen["tiles"][1], tres)


def test_magnitude_is_the_largest_height_and_flags_non_finite():
    from terrascape.lod.greedy_tin import _magnitude

    h = np.array([[1.0, -7.5], [3.0, 2.0]], np.float32)
    assert _magnitude(h) == 7.5
    for bad in (np.nan, np.inf, -np.inf):
        g = h.copy()
        g[1, 0] = bad
        assert not np.isfinite(_magnitude(g))


def test_each_kernel_compiles_once_whatever_the_heights(monkeypatch):
    """float32 and float64 heights, in pieces, as one greedy order and under a budget: the
    kernels always get read-only float32 heights, so numba compiles each once. (The
    pieces' writable copies beside the map's read-only heights made it compile the removal
    and the search twice.) A kernel loaded from numba's disk cache lists no types, so the
    count is at most one."""
    from terrascape.lod import greedy_tin as gt

    if not hasattr(gt._refine, "signatures"):
        pytest.skip("numba's compiler is switched off")
    monkeypatch.setattr(gt, "_PIECE", 50)
    seen = []
    for name in ("_mesh_piece", "_remove_vertices", "_relax_edges"):
        def spy(heights, *args, _kernel=getattr(gt, name), _name=name):
            seen.append((_name, heights.dtype, heights.flags.writeable,
                         heights.flags.c_contiguous))
            return _kernel(heights, *args)

        monkeypatch.setattr(gt, name, spy)
    rng = np.random.default_rng(5)
    h = np.cumsum(rng.standard_normal((90, 120)), 0)
    for dtype in (np.float32, np.float64):
        hm = Heightmap(h.astype(dtype))
        gt.greedy_tin(hm, max_error=1.0)
        gt.greedy_tin(hm, max_error=1.0, in_pieces=False)
        gt.greedy_tin(hm, max_triangles=60)
    assert {name for name, *_ in seen} == {"_mesh_piece", "_remove_vertices", "_relax_edges"}
    assert {tuple(rest) for _, *rest in seen} == {(np.dtype(np.float32), False, True)}
    monkeypatch.undo()
    for name in ("_mesh_piece", "_refine", "_insert_border_points", "_legalize",
                 "_split_on_edge", "_tiled_search", "_scan_rows", "_remove_vertices",
                 "_remove_kernel", "_relax_edges", "_scan_lattice", "_grid_start",
                 "_drop_unused", "_insert_piece", "_compact_triangles"):
        assert len(getattr(gt, name).signatures) <= 1, (name, getattr(gt, name).signatures)


def test_the_kernels_end_at_once_when_told_to_stop():
    """The stop flag another thread sets (an interrupted mesh): the insertion returns no
    triangles, the decimation of a dense piece and the removal remove nothing more."""
    from terrascape.lod import greedy_tin as gt

    rng = np.random.default_rng(7)
    piece = gt.read_only((rng.random((48, 40)) * 30).astype(np.float32))
    ny, nx = piece.shape
    tiles = (-(-ny // gt._TILE), -(-nx // gt._TILE))

    def mesh(stop, dense_sides):
        return gt._mesh_piece(piece, ny, nx, 0, 0, 0.5, 0.0, gt._NO_BUDGET,
                              gt._REMOVAL_PASSES, dense_sides, np.empty((*tiles, 3)),
                              np.empty((*tiles, 4)), gt._NO_SLOT_LIMIT,
                              np.array([stop], np.uint8))

    assert len(mesh(0, np.inf)[1]) > 3 * 1000  # inserted: most of the noise's samples
    assert len(mesh(1, np.inf)[1]) == 0
    # decimated from every sample: with the flag set, nothing is removed
    assert len(mesh(1, 0.0)[1]) == 3 * 2 * (ny - 1) * (nx - 1) > len(mesh(0, 0.0)[1])


def test_one_order_runs_on_a_pool_thread_only_for_the_main_thread(monkeypatch):
    """From the main thread the one-order mesher of a big map runs on a worker thread (the
    main thread waits and so handles signals at once); from any other thread, or for a
    small map, it runs right there, so meshes asked for on several threads run side by
    side, not queued on that pool."""
    import threading

    from terrascape.lod import greedy_tin as gt

    ran_on = []
    mesh_piece = gt._mesh_piece

    def spy(*args):
        ran_on.append(threading.current_thread())
        return mesh_piece(*args)

    monkeypatch.setattr(gt, "_mesh_piece", spy)
    hm = Heightmap(np.random.default_rng(3).random((40, 50)).astype(np.float32) * 10)
    gt.greedy_tin(hm, max_triangles=300)
    assert ran_on[-1] is threading.current_thread()  # a small map: no hand-over
    monkeypatch.setattr(gt, "_WAIT_SAMPLES", 40 * 50 - 1)
    expected = gt.greedy_tin(hm, max_triangles=300)
    if threading.current_thread() is threading.main_thread():
        assert ran_on[-1] is not threading.main_thread()
        assert ran_on[-1].name == "terrascape-long"
    callers = [threading.Thread(target=lambda: gt.greedy_tin(hm, max_triangles=300))
               for _ in range(2)]
    for t in callers:
        t.start()
    for t in callers:
        t.join()
    assert set(ran_on[-2:]) == set(callers)
    np.testing.assert_array_equal(gt.greedy_tin(hm, max_triangles=300), expected)


def test_compacting_keeps_the_live_triangles_in_order_with_their_twins():
    """A decimated piece's triangles moved to the front: the live ones in their order, the
    twins pointing at the same (moved) halfedges."""
    from terrascape.lod import greedy_tin as gt

    rng = np.random.default_rng(7)
    piece = (ndimage.gaussian_filter(rng.standard_normal((48, 40)), 2) * 30).astype(np.float32)
    ny, nx = piece.shape
    keep = np.ones((4, max(nx, ny)), np.bool_)
    coords, tris, half = gt._grid_start(nx, ny, keep)
    tiles = (-(-ny // gt._TILE), -(-nx // gt._TILE))
    plane, res = np.empty((*tiles, 3)), np.empty((*tiles, 4))
    gt._tile_ranges(piece, plane, res)
    removed = gt._remove_vertices(piece, plane, res, np.empty(tiles[0] * tiles[1]),
                                  np.empty(tiles[0] * tiles[1], np.int64), coords, tris, half,
                                  len(coords), len(tris), 1.0, 8, np.ones(len(coords), np.bool_),
                                  np.zeros(1, np.uint8))
    assert removed > 100
    live = tris.reshape(-1, 3)[:, 0] >= 0
    assert 0 < live.sum() < len(live)
    before = tris.reshape(-1, 3)[live].copy()
    # each live halfedge's twin as (triangle's rank among the live ones, corner)
    rank = np.cumsum(live) - 1
    twin_before = np.where(half >= 0, 3 * rank[np.maximum(half, 0) // 3] + half % 3, -1)
    twin_before = twin_before.reshape(-1, 3)[live].reshape(-1)
    n = gt._compact_triangles(tris, half, len(tris))
    assert n == 3 * live.sum()
    np.testing.assert_array_equal(tris[:n].reshape(-1, 3), before)
    np.testing.assert_array_equal(half[:n], twin_before)
    twinned = half[:n] >= 0
    assert np.all(half[half[:n][twinned]] == np.flatnonzero(twinned))


@pytest.mark.parametrize(("nx", "ny"), [(4, 4), (5, 9), (23, 17), (60, 41)])
def test_grid_start_triangulates_the_piece_with_its_kept_side_samples(nx, ny):
    """The decimation's start: every inner sample and the kept side samples are vertices,
    the triangles cover the piece once (a conforming mesh), all wound like the insertion's,
    each twin is the reverse halfedge, and the open halfedges are exactly the side
    segments between kept samples."""
    from terrascape.lod import greedy_tin as gt

    rng = np.random.default_rng(nx * 100 + ny)
    for density in (0.0, 0.3, 1.0):
        keep = rng.random((4, max(nx, ny))) < density
        keep[:2, [0, nx - 1]] = True
        keep[2:, [0, ny - 1]] = True
        coords, tris, half = gt._grid_start(nx, ny, keep)
        tri = tris.reshape(-1, 3)
        grid = (coords[:, 1] * nx + coords[:, 0])[tri].astype(np.uint32)
        report = conformity_report(grid, (ny, nx))
        assert report.ok, str(report)
        p = coords[tri]
        orient = ((p[:, 1, 0] - p[:, 2, 0]) * (p[:, 0, 1] - p[:, 2, 1])
                  - (p[:, 1, 1] - p[:, 2, 1]) * (p[:, 0, 0] - p[:, 2, 0]))
        assert np.all(orient > 0)
        assert orient.sum() == 2 * (nx - 1) * (ny - 1)  # twice the area: covered once
        inner = {(x, y) for y in range(1, ny - 1) for x in range(1, nx - 1)}
        sides = ({(x, 0) for x in range(nx) if keep[0, x]}
                 | {(x, ny - 1) for x in range(nx) if keep[1, x]}
                 | {(0, y) for y in range(ny) if keep[2, y]}
                 | {(nx - 1, y) for y in range(ny) if keep[3, y]})
        assert {tuple(c) for c in coords.tolist()} == inner | sides
        assert len(coords) == len(inner | sides)
        assert [tuple(c) for c in coords[:4].tolist()] == [
            (0, 0), (nx - 1, 0), (0, ny - 1), (nx - 1, ny - 1)]
        nxt = np.arange(len(tris)) - np.arange(len(tris)) % 3 + (np.arange(len(tris)) + 1) % 3
        a, b = tris, tris[nxt]
        twinned = half >= 0
        assert np.all(half[half[twinned]] == np.flatnonzero(twinned))
        assert np.all(a[half[twinned]] == b[twinned]) and np.all(b[half[twinned]] == a[twinned])
        # open halfedges: the sides between consecutive kept samples, nothing else
        open_edges = {tuple(sorted((tuple(coords[u]), tuple(coords[v]))))
                      for u, v in zip(a[~twinned], b[~twinned], strict=True)}
        expected = set()
        for line in ([(x, 0) for x in range(nx) if keep[0, x]],
                     [(x, ny - 1) for x in range(nx) if keep[1, x]],
                     [(0, y) for y in range(ny) if keep[2, y]],
                     [(nx - 1, y) for y in range(ny) if keep[3, y]]):
            expected |= {tuple(sorted(pair)) for pair in pairwise(line)}
        assert open_edges == expected


def test_dense_pieces_are_decimated_and_meet_the_sparse_ones(monkeypatch):
    """A map rough on its left half (every sample nearly needed: those pieces start from
    every sample and remove what the error allows) and smooth on its right (greedy
    insertion): the bound on every sample, no crack where the two kinds of piece meet,
    fewer triangles than one greedy order plus a little for the lines, and the same mesh
    on one thread or two."""

    from terrascape.lod import greedy_tin as gt

    rng = np.random.default_rng(21)
    rows, cols = 150, 180
    h = np.cumsum(np.cumsum(rng.standard_normal((rows, cols)), 0), 1) * 0.02
    h[:, :90] += rng.uniform(0.0, 6.0, (rows, 90))
    hm = Heightmap(h.astype(np.float32))
    monkeypatch.setattr(gt, "_PIECE", 60)
    ys, xs = gt._piece_edges(rows), gt._piece_edges(cols)
    assert len(xs) > 3 and len(ys) > 2
    line_tol = gt._line_tolerance(gt._magnitude(hm.heights), 0.5)
    kept = [_side_keep(hm.heights[0, xs[j]:xs[j + 1] + 1], line_tol).mean()
            for j in range(len(xs) - 1)]
    assert kept[0] > 0.8 and kept[-1] < 0.2  # both kinds of piece are there
    # the rough corner piece is decimated (not what insertion alone gives), the smooth one
    # inserted (the same as insertion alone)
    tiles = (-(-rows // gt._TILE), -(-cols // gt._TILE))
    for j, decimated in ((0, True), (len(xs) - 2, False)):
        piece = gt._piece_of(gt.read_only(hm.heights), ys[0], ys[1], xs[j], xs[j + 1])

        def mesh(dense_sides, piece=piece, x0=xs[j]):
            return gt._mesh_piece(piece, rows, cols, 0, x0, 0.5, line_tol, gt._NO_BUDGET,
                                  gt._REMOVAL_PASSES, dense_sides, np.empty((*tiles, 3)),
                                  np.empty((*tiles, 4)), gt._NO_SLOT_LIMIT,
                                  np.zeros(1, np.uint8))[1]

        same = np.array_equal(mesh(gt._DENSE_SIDES), mesh(np.inf))
        assert same != decimated, (j, decimated)
    one = _on_threads(1, lambda: gt.greedy_tin(hm, max_error=0.5))
    two = _on_threads(2, lambda: gt.greedy_tin(hm, max_error=0.5))
    np.testing.assert_array_equal(one, two)
    report = conformity_report(one, hm.shape)
    assert report.ok, str(report)
    err = max_vertical_error(hm, one)
    assert 0.4 < err <= 0.5 + 1e-9
    whole = gt.greedy_tin(hm, max_error=0.5, in_pieces=False)
    assert len(one) <= 1.1 * len(whole) + 20


def test_piece_edges_increase_for_any_piece_size(monkeypatch):
    """Pieces start on tile multiples; however small the pieces asked for, no piece is
    empty or reaches past the map (they would have divided by zero)."""
    from terrascape.lod import greedy_tin as gt

    for piece in (4, 8, 12, 16, 20, 448):
        monkeypatch.setattr(gt, "_PIECE", piece)
        for n in range(2, 200):
            edges = gt._piece_edges(n)
            assert edges[0] == 0 and edges[-1] == n - 1
            assert np.all(np.diff(edges) > 0), (piece, n, edges)


@pytest.mark.parametrize("piece", [4, 12, 40])
def test_random_maps_in_small_pieces_keep_the_bound(monkeypatch, piece):
    """Rough, smooth and terraced maps of random sizes, in pieces small enough that many
    are dense (decimated) and many are sparse (inserted), at errors from 0: every mesh
    conforms and meets its bound."""
    from terrascape.lod import greedy_tin as gt

    monkeypatch.setattr(gt, "_PIECE", piece)
    rng = np.random.default_rng(piece)
    for case in range(12):
        rows, cols = (int(v) for v in rng.integers(2, 70, 2))
        if case % 3 == 0:
            h = rng.uniform(0.0, 5.0, (rows, cols))
        elif case % 3 == 1:
            h = np.cumsum(np.cumsum(rng.standard_normal((rows, cols)), 0), 1) * 0.05
        else:
            h = np.round(rng.uniform(0.0, 3.0, (rows, cols)))
        hm = Heightmap(h.astype(np.float32))
        err = float(rng.choice([0.0, 0.1, 0.5, 2.0]))
        tri = gt.greedy_tin(hm, max_error=err)
        report = conformity_report(tri, hm.shape)
        assert report.ok, (case, rows, cols, err, str(report))
        assert max_vertical_error(hm, tri) <= err + 1e-6, (case, rows, cols, err)


def test_a_signal_while_the_pieces_pool_starts_a_thread_does_not_hang_the_exit(
        interrupted_thread_start):
    """The executor registers a thread for the interpreter's exit only once its start has
    returned: interrupted before, the exit waited for that thread for ever. The pool is
    shut down on the way out (its threads end) and the next mesh makes a new one."""
    setup = ("import numpy as np\n"
             "from terrascape.heightmap import Heightmap\n"
             "from terrascape.lod.greedy_tin import greedy_tin\n"
             "hm = Heightmap((np.random.default_rng(1).random((700, 700)) * 50)"
             ".astype(np.float32))")
    for then, said in (("exit", ["interrupted"]), ("again", ["interrupted", "True"])):
        # two workers: the pieces go to the pool
        proc = interrupted_thread_start(setup, "len(greedy_tin(hm, max_error=5.0)) > 0", then,
                                        NUMBA_NUM_THREADS="2")
        assert proc.returncode == 0, proc.stderr
        assert proc.stdout.split() == said
