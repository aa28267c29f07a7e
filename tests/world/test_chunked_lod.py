"""The chunked LOD over a pyramid: tiles cover the map once, their error bounds hold and the
screen error stays within the tolerance, no cracks between levels, memory bounded."""

from __future__ import annotations

import time

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter

from terrascape.camera import Camera
from terrascape.errors import MemoryLimitError
from terrascape.heightmap import Heightmap
from terrascape.mesh.terrain_mesh import terrain_mesh
from terrascape.world.chunked_lod import (
    EDGE_STEPS,
    EXACT_ROWS,
    TileCache,
    TileKey,
    TileLoader,
    array_reader,
    bintree_cells,
    build_pyramid,
    draw_set,
    select_tiles,
    skirt_edges,
    tile_grid,
    tile_indices,
    tile_mesh,
)

SPACING = 2.0
VIEW = (320, 180)


def _map(n: int = 257, seed: int = 5) -> np.ndarray:
    rng = np.random.default_rng(seed)
    h = sum(gaussian_filter(rng.standard_normal((n, n)), s) * s * 4.0 for s in (2, 6, 20))
    return (h - h.min()).astype(np.float32)


@pytest.fixture(scope="module")
def heights() -> np.ndarray:
    return _map()


@pytest.fixture(scope="module")
def pyramid(heights):
    return build_pyramid(array_reader(heights), heights.shape, SPACING, tile=16, block=40)


def _surface(h: np.ndarray, grid, key: TileKey, *,
             bintree: bool = False) -> tuple[np.ndarray, tuple[int, int, int, int]]:
    """The tile's interpolant at every full-resolution sample of its ground (the anti-
    diagonal split of the render mesh; ``bintree``: cells whose level-k row + column is
    even split along the other diagonal)."""
    a0, a1, b0, b1 = grid.samples(key)
    s = 1 << key.level
    c = h[a0 * s:a1 * s + 1:s, b0 * s:b1 * s + 1:s].astype(np.float64)
    r0, r1, c0, c1 = grid.span(key)
    rr, cc = np.meshgrid(np.arange(r0, r1 + 1), np.arange(c0, c1 + 1), indexing="ij")
    v, u = (rr - r0) / s, (cc - c0) / s
    i = np.minimum(np.floor(v).astype(int), c.shape[0] - 2)
    j = np.minimum(np.floor(u).astype(int), c.shape[1] - 2)
    fv, fu = v - i, u - j
    h00, h01, h10, h11 = c[i, j], c[i, j + 1], c[i + 1, j], c[i + 1, j + 1]
    lower = h00 + fu * (h01 - h00) + fv * (h10 - h00)
    upper = h11 + (1 - fu) * (h10 - h11) + (1 - fv) * (h01 - h11)
    surf = np.where(fu + fv <= 1.0, lower, upper)
    if bintree:
        even = (a0 + i + b0 + j) % 2 == 0
        right = h00 + fu * (h01 - h00) + fv * (h11 - h01)
        left = h00 + fv * (h10 - h00) + fu * (h11 - h10)
        surf = np.where(even, np.where(fu >= fv, right, left), surf)
    return surf, (r0, r1, c0, c1)


def _low_camera() -> Camera:
    return Camera.look_at((30.0, 60.0, 30.0), (300.0, 0.0, 300.0), fov_y=60.0,
                          aspect=VIEW[0] / VIEW[1], near=0.5, far=5000.0)


def test_grid_levels_and_tiles(pyramid):
    g = pyramid.grid
    assert g.top == 4 and g.roots() == [TileKey(4, 0, 0)]  # 256 cells = 16 · 2**4
    assert g.count(0) == (16, 16) and g.span(TileKey(1, 3, 2)) == (96, 128, 64, 96)
    assert g.children(TileKey(1, 3, 2)) == [TileKey(0, 6, 4), TileKey(0, 6, 5),
                                            TileKey(0, 7, 4), TileKey(0, 7, 5)]
    # a map whose side is not 2**n + 1 keeps its last row: fewer levels, more roots
    odd = tile_grid((201, 161), SPACING, 16)
    assert odd.top == 3 and odd.count(3) == (2, 2)
    assert odd.span(TileKey(3, 1, 1))[1::2] == (200, 160)


def test_error_bound_holds_for_every_tile(heights, pyramid):
    g = pyramid.grid
    exact_top = (EXACT_ROWS // g.tile).bit_length() - 1
    tight = []
    for k in range(g.top + 1):
        nr, nc = g.count(k)
        for i in range(nr):
            for j in range(nc):
                key = TileKey(k, i, j)
                surf, (r0, r1, c0, c1) = _surface(heights, g, key)
                true = np.abs(surf - heights[r0:r1 + 1, c0:c1 + 1]).max()
                bound = pyramid.error[k][i, j]
                assert true <= bound + 1e-4, (key, true, bound)
                ground = heights[r0:r1 + 1, c0:c1 + 1]
                assert pyramid.low[k][i, j] == ground.min()
                assert pyramid.high[k][i, j] == ground.max()
                if k:
                    tight.append(true / bound)
                if k <= exact_top:  # these levels hold the real error (float32 heights)
                    assert bound == pytest.approx(true, rel=1e-6, abs=1e-4), (key, true, bound)
    assert g.top >= 3 and np.median(tight) > 0.4  # a bound, not a blanket


def test_bintree_error_bound_holds_for_every_tile(heights, pyramid):
    """The second table bounds each tile's bintree interpolant B_k (the surface the
    simplified tile meshes coarsen) as the first bounds the grid's: exact on the exact
    levels, a bound above them, on every full-resolution sample."""
    g = pyramid.grid
    exact_top = (EXACT_ROWS // g.tile).bit_length() - 1
    differ = 0
    for k in range(g.top + 1):
        nr, nc = g.count(k)
        for i in range(nr):
            for j in range(nc):
                key = TileKey(k, i, j)
                surf, (r0, r1, c0, c1) = _surface(heights, g, key, bintree=True)
                true = np.abs(surf - heights[r0:r1 + 1, c0:c1 + 1]).max()
                bound = pyramid.error_bintree[k][i, j]
                assert true <= bound + 1e-4, (key, true, bound)
                if k <= exact_top:
                    assert bound == pytest.approx(true, rel=1e-6, abs=1e-4), (key, true, bound)
                differ += bool(k) and bound != pyramid.error[k][i, j]
    assert differ > 10  # the two interpolants differ
    # above the exact levels too (64 rows of 16-cell tiles: levels 3-4 are bounds)
    pyr = build_pyramid(array_reader(heights), heights.shape, SPACING, tile=16, block=40,
                        exact_rows=64)
    for k in (3, 4):
        nr, nc = g.count(k)
        for i in range(nr):
            for j in range(nc):
                surf, (r0, r1, c0, c1) = _surface(heights, g, TileKey(k, i, j), bintree=True)
                true = np.abs(surf - heights[r0:r1 + 1, c0:c1 + 1]).max()
                assert true <= pyr.error_bintree[k][i, j] + 1e-4


def test_bintree_cells_are_the_finest_bintree_mesh():
    """bintree_cells is the RTIN bintree split to its finest level (the same triangles),
    and faces up like the grid's triangles."""
    from terrascape.lod.rtin import _triangles_of

    for n in (3, 5, 17):
        cells = bintree_cells(n, n)
        full = _triangles_of(n, np.ones(n * n, np.bool_) & _splittable(n))
        assert {frozenset(t) for t in cells.tolist()} == {frozenset(t) for t in full.tolist()}
        r, c = np.divmod(cells.astype(np.int64), n)
        ax, az, bx, bz, cx, cz = c[:, 0], r[:, 0], c[:, 1], r[:, 1], c[:, 2], r[:, 2]
        up = (bz - az) * (cx - ax) - (bx - ax) * (cz - az)  # the y of (b − a) × (c − a)
        assert np.all(up > 0)


def _splittable(n: int) -> np.ndarray:
    """Every grid vertex but the four corners (which never split)."""
    m = np.ones((n, n), np.bool_)
    m[0, 0] = m[0, -1] = m[-1, 0] = m[-1, -1] = False
    return m.reshape(-1)


def test_levels_above_the_exact_ones_bound_the_error(heights):
    # 64 rows of 16-cell tiles: levels 1–2 exact, 3–4 summed
    pyr = build_pyramid(array_reader(heights), heights.shape, SPACING, tile=16, block=40,
                        exact_rows=64)
    wide = build_pyramid(array_reader(heights), heights.shape, SPACING, tile=16, block=256,
                         exact_rows=64)
    summed = build_pyramid(array_reader(heights), heights.shape, SPACING, tile=16,
                           exact_rows=0)
    g = pyr.grid
    assert g.top == 4
    for k in range(1, g.top + 1):
        assert np.array_equal(pyr.error[k], wide.error[k])  # the band is memory, not result
        nr, nc = g.count(k)
        true = np.empty((nr, nc))
        for i in range(nr):
            for j in range(nc):
                surf, (r0, r1, c0, c1) = _surface(heights, g, TileKey(k, i, j))
                true[i, j] = np.abs(surf - heights[r0:r1 + 1, c0:c1 + 1]).max()
        if k <= 2:
            np.testing.assert_allclose(pyr.error[k], true, rtol=1e-6, atol=1e-4)
        else:
            assert (true <= pyr.error[k] + 1e-4).all() and (pyr.error[k] > true).any()
            # bounded through a finer exact level, not by summing every level's error
            # (the sum gave 0.53-0.66 of the true error here)
            assert np.median(true / pyr.error[k]) > 0.75
        # the sum over every level (level 1's own error is its real one): never below
        assert (pyr.error[k] <= summed.error[k] + 1e-9).all()
        assert k == 1 or (summed.error[k] > pyr.error[k]).any()


def test_selection_covers_once_within_tolerance(heights, pyramid):
    g = pyramid.grid
    cam = _low_camera()
    for tol in (0.5, 2.0, 8.0):
        sel = select_tiles(pyramid, cam, VIEW, tolerance=tol)
        cover = np.zeros((256, 256), int)
        for key in sel.leaves:
            r0, r1, c0, c1 = g.span(key)
            cover[r0:r1, c0:c1] += 1
        assert (cover == 1).all()
        assert not sel.budget_bound and sel.max_pixels <= tol
        assert len(sel.levels()) >= 2  # far tiles coarser
        assert sel.culled or tol > 2.0  # unseen ones culled (8 px keeps coarse roots in view)
        # every visible tile's real error, projected from its nearest point, is in tolerance
        kpx = cam.pixels_per_radian(VIEW[1])
        for key in sel.visible:
            surf, (r0, r1, c0, c1) = _surface(heights, g, key)
            true = np.abs(surf - heights[r0:r1 + 1, c0:c1 + 1]).max()
            box = pyramid.box(key)
            d = np.linalg.norm(np.clip(cam.eye, box[:3], box[3:]) - cam.eye)
            assert true * kpx / d <= tol + 1e-6
    coarse = select_tiles(pyramid, cam, VIEW, tolerance=8.0)
    fine = select_tiles(pyramid, cam, VIEW, tolerance=0.5)
    assert len(fine.visible) > len(coarse.visible)
    # culled tiles are out of view: none of their ground projects into the image
    for key in fine.culled:
        r0, r1, c0, c1 = g.span(key)
        rr, cc = np.meshgrid(np.arange(r0, r1 + 1), np.arange(c0, c1 + 1), indexing="ij")
        pts = np.c_[cc.ravel() * SPACING, heights[rr, cc].ravel(), rr.ravel() * SPACING]
        px = cam.project(pts, VIEW)
        inside = ((px[:, 0] >= 0) & (px[:, 0] <= VIEW[0]) & (px[:, 1] >= 0)
                  & (px[:, 1] <= VIEW[1]) & (px[:, 2] > cam.near))
        assert not inside.any(), key


def test_no_cracks_between_tiles_of_different_levels(heights, pyramid):
    g = pyramid.grid
    sel = select_tiles(pyramid, _low_camera(), VIEW, tolerance=1.0)
    leaves = sel.leaves
    assert len({k.level for k in leaves}) >= 3
    surfaces = {k: _surface(heights, g, k) for k in leaves}
    pairs = same_level = 0
    for a in leaves:
        sa, (ar0, ar1, ac0, ac1) = surfaces[a]
        for b in leaves:
            sb, (br0, br1, bc0, bc1) = surfaces[b]
            assert abs(a.level - b.level) <= 1 or not _touch(g.span(a), g.span(b))
            if ac1 == bc0:  # b east of a: shared column, overlapping rows
                r0, r1 = max(ar0, br0), min(ar1, br1)
                if r1 <= r0:
                    continue
                ea = sa[r0 - ar0:r1 - ar0 + 1, -1]
                eb = sb[r0 - br0:r1 - br0 + 1, 0]
            elif ar1 == br0:  # b south of a
                c0, c1 = max(ac0, bc0), min(ac1, bc1)
                if c1 <= c0:
                    continue
                ea = sa[-1, c0 - ac0:c1 - ac0 + 1]
                eb = sb[0, c0 - bc0:c1 - bc0 + 1]
            else:
                continue
            pairs += 1
            if a.level == b.level:
                same_level += 1
                assert np.array_equal(ea, eb)
            # the higher edge's skirt reaches below the lower one: the gap is closed
            skirt_a = pyramid.skirt[a.level][a.row, a.col]
            skirt_b = pyramid.skirt[b.level][b.row, b.col]
            assert np.all(np.where(ea > eb, skirt_a <= eb, skirt_b <= ea))
    assert pairs > 20 and same_level > 0
    mesh = tile_mesh(array_reader(heights), pyramid, leaves[0])
    n = mesh.shape[0] * mesh.shape[1]
    assert len(mesh.positions) > n  # the skirt's ring
    assert np.allclose(mesh.positions[n:, 1], pyramid.skirt[leaves[0].level][leaves[0][1:]])
    idx = tile_indices(mesh.shape)
    assert idx.max() == len(mesh.positions) - 1 and idx.size % 3 == 0



def test_skirts_face_out_of_their_tile(heights, pyramid):
    """The surface faces up and every skirt triangle faces away from its tile (one winding:
    the gaps are seen from outside the higher tile only), each edge cell closed once."""
    for key in (TileKey(0, 3, 4), TileKey(2, 1, 2), TileKey(pyramid.grid.top, 0, 0)):
        mesh = tile_mesh(array_reader(heights), pyramid, key)
        idx = tile_indices(mesh.shape).reshape(-1, 3)
        n_r, n_c = mesh.shape
        p = mesh.positions.astype(np.float64)
        tri = p[idx]
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])  # ccw: front side
        on_grid = np.all(idx < n_r * n_c, axis=1)
        assert np.all(normal[on_grid, 1] > 0)  # seen from above
        skirt = ~on_grid
        assert skirt.sum() == 2 * 2 * (n_r - 1 + n_c - 1)  # two triangles per edge cell
        centre = p[:n_r * n_c].mean(axis=0)
        out = tri[skirt].mean(axis=1) - centre
        out[:, 1] = 0.0
        assert np.all(np.einsum("ij,ij->i", normal[skirt], out) > 0)
        assert np.allclose(normal[skirt, 1], 0.0, atol=1e-6 * np.abs(normal[skirt]).max())

def test_skirt_edges_are_the_skirt_of_each_edge(heights, pyramid):
    key = TileKey(1, 2, 3)
    mesh = tile_mesh(array_reader(heights), pyramid, key)
    n_r, n_c = mesh.shape
    idx = tile_indices(mesh.shape)
    grid = 6 * (n_r - 1) * (n_c - 1)
    edges = skirt_edges(mesh.shape)
    assert sum(c for _, c in edges) == idx.size - grid  # every skirt index, once
    assert [f for f, _ in edges] == list(np.cumsum([0] + [c for _, c in edges[:-1]]))
    r0, r1, c0, c1 = pyramid.grid.span(key)
    # each edge's skirt hangs from that edge's top vertices: the line toward its neighbour
    for (first, count), (di, dj) in zip(edges, EDGE_STEPS, strict=True):
        tops = idx[grid + first:grid + first + count]
        tops = tops[tops < n_r * n_c]
        x, z = mesh.positions[tops, 0], mesh.positions[tops, 2]
        sp = pyramid.grid.spacing
        if di:
            assert np.all(z == (r0 if di < 0 else r1) * sp)
        else:
            assert np.all(x == (c0 if dj < 0 else c1) * sp)
        assert len(np.unique(tops)) == (n_c if di else n_r)


def _touch(a, b) -> bool:
    ar0, ar1, ac0, ac1 = a
    br0, br1, bc0, bc1 = b
    rows = min(ar1, br1) > max(ar0, br0)
    cols = min(ac1, bc1) > max(ac0, bc0)
    return (rows and (ac1 == bc0 or bc1 == ac0)) or (cols and (ar1 == br0 or br1 == ar0))


def test_level_zero_tile_is_the_render_mesh(heights, pyramid):
    whole = terrain_mesh(Heightmap(heights, (SPACING, SPACING)), exaggeration=1.5)
    for key in (TileKey(0, 0, 0), TileKey(0, 7, 9), TileKey(0, 15, 15)):
        mesh = tile_mesh(array_reader(heights), pyramid, key, exaggeration=1.5)
        r0, r1, c0, c1 = pyramid.grid.span(key)
        n = mesh.shape[0] * mesh.shape[1]
        sel = (slice(r0, r1 + 1), slice(c0, c1 + 1))
        for mine, theirs, w in ((mesh.positions, whole.positions, 3),
                                (mesh.normals, whole.normals, 3),
                                (mesh.tangents, whole.tangents, 4)):
            assert np.array_equal(mine[:n], theirs.reshape(257, 257, w)[sel].reshape(-1, w))
    coarse = tile_mesh(array_reader(heights), pyramid, TileKey(2, 1, 2))
    assert coarse.shape == (17, 17)
    assert np.array_equal(coarse.positions[:17 * 17, 1],
                          heights[64:129:4, 128:193:4].reshape(-1))


def test_tile_budget_bounds_memory(pyramid):
    cam = _low_camera()
    free = select_tiles(pyramid, cam, VIEW, tolerance=0.25)
    capped = select_tiles(pyramid, cam, VIEW, tolerance=0.25, max_tiles=12)
    assert len(free.visible) > 12 >= len(capped.visible)
    assert capped.budget_bound and capped.max_pixels > 0.25
    # the largest errors went first: the capped view is still finer than the roots
    assert len(capped.visible) > 3
    # four roots in view and a budget of one tile: refused, with what to do
    h = _map(201)[:, :161]
    odd = build_pyramid(array_reader(h), h.shape, SPACING, tile=16)
    assert len(odd.grid.roots()) == 4
    above = Camera.look_at((160.0, 900.0, 200.0), (160.0, 0.0, 201.0), aspect=1.0, far=5000.0)
    assert len(select_tiles(odd, above, VIEW, tolerance=50.0).visible) == 4
    with pytest.raises(MemoryLimitError, match="raise --max-memory"):
        select_tiles(odd, above, VIEW, tolerance=0.25, max_tiles=1)


def test_draw_set_falls_back_to_loaded_parents(pyramid):
    g = pyramid.grid
    sel = select_tiles(pyramid, _low_camera(), VIEW, tolerance=1.0)
    everything = set(sel.visible)
    assert sorted(draw_set(g, sel.visible, everything.__contains__)) == sorted(sel.visible)
    # only the coarse levels loaded yet: the parents are drawn, never overlapping
    loaded = {k for k in _all_tiles(g) if k.level >= 2}
    drawn = draw_set(g, sel.visible, loaded.__contains__)
    assert drawn and all(k in loaded for k in drawn)
    cover = np.zeros((256, 256), int)
    for key in drawn:
        r0, r1, c0, c1 = g.span(key)
        cover[r0:r1, c0:c1] += 1
    assert cover.max() == 1
    for key in sel.visible:  # every selected tile's ground is drawn by one tile
        r0, r1, c0, c1 = g.span(key)
        assert (cover[r0:r1, c0:c1] == 1).all()
    assert draw_set(g, sel.visible, lambda k: False) == []


def _all_tiles(g):
    for k in range(g.top + 1):
        nr, nc = g.count(k)
        for i in range(nr):
            for j in range(nc):
                yield TileKey(k, i, j)


def test_cache_is_bounded_and_keeps_the_pinned():
    released = []
    cache = TileCache(100, size_of=len, release=released.append)
    for i in range(5):
        assert cache.put(TileKey(0, 0, i), "x" * 30, pinned={TileKey(0, 0, 0)})
        assert cache.bytes <= 100
    assert TileKey(0, 0, 0) in cache and len(cache) == 3 and cache.evicted == 2
    assert cache.peak_bytes <= 100
    assert not cache.put(TileKey(1, 0, 0), "y" * 90, pinned={TileKey(0, 0, 0),
                                                             TileKey(0, 0, 3), TileKey(0, 0, 4)})
    assert released[-1] == "y" * 90
    # the same tile twice (loaded again while the first was on its way): counted once
    before = cache.bytes
    assert cache.put(TileKey(0, 0, 4), "z" * 30) and cache.bytes == before
    assert cache.get(TileKey(0, 0, 4)) == "x" * 30 and released[-1] == "z" * 30


def test_loader_builds_on_a_background_thread(heights, pyramid):
    import threading

    main = threading.get_ident()
    threads = set()

    def build(key):
        threads.add(threading.get_ident())
        return tile_mesh(array_reader(heights), pyramid, key)

    loader = TileLoader(build, max_pending=2)
    try:
        keys = [TileKey(0, 0, j) for j in range(6)]
        loader.request(keys)
        got = []
        deadline = time.monotonic() + 20
        while len(got) < 6 and time.monotonic() < deadline:
            got += loader.finished()
            assert loader.pending() <= 6
            time.sleep(0.01)
        assert sorted(m.key for m in got) == keys and main not in threads
        loader.request([TileKey(9, 9, 9)])  # a tile that does not exist: the error surfaces
        deadline = time.monotonic() + 10
        with pytest.raises(Exception, match="no tile"):
            while time.monotonic() < deadline:
                loader.finished()
                time.sleep(0.01)
    finally:
        loader.close()


def test_simplified_tile_meshes_conform_keep_their_border_and_meet_their_error(
        mesh_on_samples):
    """The bintree simplification of a tile: at 0 its finest mesh (bintree_cells); for
    any error, a mesh that covers the tile once, keeps every border vertex (its edges meet
    the neighbours' exactly), has no T-junction, and is within the error of B_k at every
    sample; coarser for a larger error."""
    from terrascape.world.chunked_lod import simplified_tile_triangles, tile_bintree_errors

    rng = np.random.default_rng(4)
    for n in (9, 17, 33):
        z = gaussian_filter(rng.standard_normal((n, n)), 1.5) * 10.0
        errors = tile_bintree_errors(z)
        cells = bintree_cells(n, n)
        full = simplified_tile_triangles(errors, n, 0.0)
        assert {frozenset(t) for t in full.tolist()} == {frozenset(t) for t in cells.tolist()}
        exact = mesh_on_samples(cells, z, n, 1)  # B_k at the samples: the heights
        assert np.allclose(exact, z)
        counts = []
        for err in (0.05, 0.2, 0.8, 3.0, 1e9):
            tris = simplified_tile_triangles(errors, n, err)
            counts.append(len(tris))
            vals = mesh_on_samples(tris, z, n, 1)
            assert not np.isnan(vals).any()
            assert np.abs(vals - z).max() <= err + 1e-9
            # area: one cover of the square
            r, c = np.divmod(tris.astype(np.int64), n)
            area = ((r[:, 1] - r[:, 0]) * (c[:, 2] - c[:, 0])
                    - (c[:, 1] - c[:, 0]) * (r[:, 2] - r[:, 0]))
            assert np.all(area > 0) and area.sum() == 2 * (n - 1) ** 2
            # no T-junction: every interior edge is shared by exactly two triangles
            edges: dict[tuple[int, int], int] = {}
            for t in tris.tolist():
                for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
                    key = (min(a, b), max(a, b))
                    edges[key] = edges.get(key, 0) + 1
            used = set(np.unique(tris).tolist())
            border = {i * n + j for i in range(n) for j in range(n)
                      if i in (0, n - 1) or j in (0, n - 1)}
            assert border <= used  # every border vertex kept
            for (a, b), k in edges.items():
                (ar, ac), (br, bc) = divmod(a, n), divmod(b, n)
                on_border = (ar == br and ar in (0, n - 1)) or (ac == bc and ac in (0, n - 1))
                assert k == (1 if on_border else 2), (a, b, k)
        assert counts == sorted(counts, reverse=True) and counts[-1] < 0.75 * counts[0]


def test_float32_errors_leave_out_no_vertex_above_the_error():
    """The loader's float32 errors (rounded up) give the mesh their float64 values give,
    for thresholds between two float32 values: the threshold is rounded down in the
    errors' type, never up past a vertex's error."""
    from terrascape.world.chunked_lod import (
        _rounded_up_f32,
        simplified_tile_triangles,
        tile_bintree_errors,
    )

    z = gaussian_filter(np.random.default_rng(9).standard_normal((17, 17)), 1.0) * 5.0
    e32 = _rounded_up_f32(tile_bintree_errors(z))
    finite = np.unique(e32[np.isfinite(e32) & (e32 > 0)])
    assert len(finite) > 20
    for value in finite[::3]:
        # just below the float32 value: float32(threshold) would round up to it
        threshold = float(value) - float(np.spacing(value)) / 4
        assert np.float32(threshold) == value
        got = simplified_tile_triangles(e32, 17, threshold)
        want = simplified_tile_triangles(e32.astype(np.float64), 17, threshold)
        assert np.array_equal(got, want)
