"""Bintree numbering, neighbours and Duchaineau's nested error bounds (Filipović 2008 §4.1)."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape import Heightmap, HeightmapSizeError, InvalidParameterError
from terrascape.lod import bintree as bt
from terrascape.lod.mesh_checks import conformity_report, sample_errors


def _reference_diamond_errors(h: np.ndarray) -> np.ndarray:
    """Slow reference: per-triangle recursion over the id numbering (not the vertex loops)."""
    size = h.shape[0] - 1
    top = bt.max_level(size)
    out = np.zeros(h.shape)
    for lvl in range(top - 1, -1, -1):
        for t in range(2 << lvl, 4 << lvl):
            _, _, r0, c0, r1, c1 = bt._tri_coords(t, size)
            mr, mc = (r0 + r1) // 2, (c0 + c1) // 2
            d = abs(float(h[mr, mc]) - 0.5 * (float(h[r0, c0]) + float(h[r1, c1])))
            child = 0.0
            if lvl + 1 < top:
                for u in (2 * t, 2 * t + 1):
                    _, _, a0, b0, a1, b1 = bt._tri_coords(u, size)
                    child = max(child, out[(a0 + a1) // 2, (b0 + b1) // 2])
            out[mr, mc] = max(out[mr, mc], d + child)
    return out


@pytest.mark.parametrize("n", [1, 2, 3, 5])
def test_wedgie_errors_match_reference(rng, n):
    size = 2**n
    h = rng.normal(size=(size + 1, size + 1)).astype(np.float32) * 10
    got = bt.wedgie_errors(h)
    ref = _reference_diamond_errors(h)
    assert got.dtype == np.float32
    assert (got >= ref).all()  # rounded up, never down
    np.testing.assert_allclose(got, ref, rtol=1e-6, atol=1e-6)
    corners = got[[0, 0, -1, -1], [0, -1, 0, -1]]
    assert (corners == 0).all()


def test_wedgie_bound_is_true_and_nested(rng):
    size = 32
    h = np.cumsum(rng.normal(size=(size + 1, size + 1)), axis=0).astype(np.float32)
    err = bt.wedgie_errors(h)
    top = bt.max_level(size)
    for lvl in range(top + 1):
        ids = np.arange(2 << lvl, 4 << lvl)
        tris = bt.uniform_triangles(size, lvl)
        # the per-sample error of the uniform level mesh is within each triangle's bound
        per_sample = sample_errors(h, tris)
        verts = bt._tri_coords
        bound = np.zeros(len(ids))
        for i, t in enumerate(ids):
            _, _, r0, c0, r1, c1 = verts(t, size)
            bound[i] = bt._tri_error(err, lvl, top, r0, c0, r1, c1)
        if lvl == top:
            assert per_sample.max() == 0.0 and (bound == 0).all()
        else:
            assert per_sample.max() <= bound.max() * (1 + 1e-6) + 1e-9
            assert per_sample.max() > 0
        if lvl > 0:
            # nested: no child bound exceeds its parent's
            parents = ids >> 1
            pb = np.array(
                [bt._tri_error(err, lvl - 1, top, *verts(p, size)[2:]) for p in parents]
            )
            assert (bound <= pb).all()


def test_every_triangle_bound_holds_on_its_samples(rng):
    size = 16
    h = rng.normal(size=(size + 1, size + 1)).astype(np.float32)
    err = bt.wedgie_errors(h)
    top = bt.max_level(size)
    ids = np.arange(2, 2 << top)
    for t in ids[rng.choice(ids.size, 300, replace=False)]:
        lvl = int(bt.level_of([t])[0])
        coords = bt._tri_coords(t, size)
        tri = bt.triangle_vertices([t], size).astype(np.int64)
        # vertical error of the triangle's plane against the samples it covers
        (ar, ac, r0, c0, r1, c1) = coords
        det = (c0 - ac) * (r1 - ar) - (r0 - ar) * (c1 - ac)
        worst = 0.0
        for r in range(min(ar, r0, r1), max(ar, r0, r1) + 1):
            for c in range(min(ac, c0, c1), max(ac, c0, c1) + 1):
                wa = (c0 - c) * (r1 - r) - (r0 - r) * (c1 - c)
                wb = (c1 - c) * (ar - r) - (r1 - r) * (ac - c)
                wc = (ac - c) * (r0 - r) - (ar - r) * (c0 - c)
                if det < 0 and max(wa, wb, wc) > 0:
                    continue
                z = (wa * h[ar, ac] + wb * h[r0, c0] + wc * h[r1, c1]) / det
                worst = max(worst, abs(float(h[r, c]) - float(z)))
        assert worst <= bt._tri_error(err, lvl, top, r0, c0, r1, c1) + 1e-6
        assert tri.shape == (1, 3)


@pytest.mark.parametrize("size", [2, 4, 8])
def test_numbering_geometry_and_partners(size):
    top = bt.max_level(size)
    ids = np.arange(2, 2 << (top + 1))
    levels = bt.level_of(ids)
    assert levels.min() == 0 and levels.max() == top
    partners = bt.partner_of(ids, size)
    for t, b, lvl in zip(ids, partners, levels, strict=True):
        coords = bt._tri_coords(t, size)
        assert bt._locate(lvl, *coords, size) == t  # geometry → id round trip
        if b >= 0:
            assert bt.partner_of([b], size)[0] == t
            assert bt.level_of([b])[0] == lvl
            cb = bt._tri_coords(b, size)
            # same hypotenuse, reversed; apex mirrored through its midpoint
            assert (cb[2:4], cb[4:6]) == (coords[4:6], coords[2:4])
        else:
            ar, ac, r0, c0, r1, c1 = coords
            br, bc = r0 + r1 - ar, c0 + c1 - ac
            assert not (0 <= br <= size and 0 <= bc <= size)
    for lvl in range(top + 1):
        rep = conformity_report(bt.uniform_triangles(size, lvl), (size + 1, size + 1))
        assert rep.ok, str(rep)
        assert rep.n_triangles == 2 << lvl


def test_roots_and_children_are_ccw_from_above():
    tri = bt.triangle_vertices(np.arange(2, 64), 4).astype(np.int64)
    r, c = tri // 5, tri % 5
    # Y of (p1 − p0) × (p2 − p0) with x = col, z = row
    y = (r[:, 1] - r[:, 0]) * (c[:, 2] - c[:, 0]) - (c[:, 1] - c[:, 0]) * (r[:, 2] - r[:, 0])
    assert (y > 0).all()


def test_bad_input():
    with pytest.raises(HeightmapSizeError, match="pad"):
        bt.wedgie_errors(np.zeros((10, 10)))
    with pytest.raises(HeightmapSizeError):
        bt.wedgie_errors(Heightmap(np.zeros((9, 17))))
    with pytest.raises(InvalidParameterError):
        bt.triangle_vertices([1], 4)
    with pytest.raises(InvalidParameterError):
        bt.triangle_vertices([64], 4)
    with pytest.raises(InvalidParameterError):
        bt.max_level(6)
    with pytest.raises(InvalidParameterError):
        bt.uniform_triangles(4, 5)
