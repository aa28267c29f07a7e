"""Where the greedy TIN's time goes, on the maps of ``terrascape bench peers``.

    python scripts/greedy_tin_probes.py passes [syn|dem] [ERROR ...]
    python scripts/greedy_tin_probes.py join [ERROR ...]
    python scripts/greedy_tin_probes.py rtin [PASSES]

``passes``: the mesh in pieces with 8, 2, 1 and no removal passes (median of 5 builds, ms)
and its triangles ÷ pydelatin's: what the removal of redundant vertices costs and buys.
``join``: the Jacksboro DEM's join of the pieces step by step (median of 15 meshes, ms):
concatenating the pieces' arrays, stitching them, offering the lines' vertices to the
removal, the flips, the output. ``rtin``: the other way the issue suggested, RTIN and then
the removal (one thread; times of RTIN, of the conversion to a halfedge mesh, and of
``PASSES`` removal passes), against the greedy TIN, on the synthetic 1025² map.
Needs pydelatin for ``passes`` and ``rtin`` (the ``peers`` extra).
"""

from __future__ import annotations

import statistics
import sys
import time

import numpy as np

import terrascape.lod.greedy_tin as gt
from terrascape.bench.peers import real_dem
from terrascape.bench.shade import terrain


def _synthetic():
    return terrain(1025).normalised(0, 400)


def passes(which: str, errors: list[float]) -> None:
    from pydelatin import Delatin

    hm = _synthetic() if which == "syn" else real_dem()
    for err in errors:
        theirs = len(Delatin(hm.heights, width=hm.shape[1], height=hm.shape[0],
                             max_error=err).triangles)
        for n in (8, 2, 1, 0):
            gt._REMOVAL_PASSES = n
            gt.greedy_tin(hm, max_error=err)
            times = []
            for _ in range(5):
                t0 = time.perf_counter()
                mesh = gt.greedy_tin(hm, max_error=err)
                times.append(time.perf_counter() - t0)
            print(f"{which} {err:g} m, {n} passes: {1e3 * statistics.median(times):.1f} ms, "
                  f"{len(mesh) / theirs:.3f}× pydelatin's triangles", flush=True)
    gt._REMOVAL_PASSES = 8


def join(errors: list[float]) -> None:
    hm = real_dem()
    steps: dict[str, list[float]] = {}

    def lap(name, t0):
        t = time.perf_counter()
        steps.setdefault(name, []).append(t - t0)
        return t

    def timed_join(h, tol, parts, tplane, tres, ys, xs):  # _join_pieces, step by step
        t = time.perf_counter()
        rows, cols = h.shape
        coords = np.concatenate([c for c, _, _ in parts])
        tris = np.concatenate([t for _, t, _ in parts])
        half = np.concatenate([hf for _, _, hf in parts])
        v_start = np.cumsum([0] + [len(c) for c, _, _ in parts])
        e_start = np.cumsum([0] + [len(t) for _, t, _ in parts])
        t = lap("concatenate", t)
        is_row_line = np.zeros(rows, np.int64) - 1
        is_row_line[ys[1:-1]] = np.arange(len(ys) - 2)
        is_col_line = np.zeros(cols, np.int64) - 1
        is_col_line[xs[1:-1]] = np.arange(len(xs) - 2)
        ids = np.empty(len(coords), np.int64)
        on_line = np.zeros(len(coords), np.bool_)
        slots = (len(ys) - 2) * cols + (len(xs) - 2) * rows
        seams = np.empty(slots, np.int64)
        n_points, n_seams = gt._stitch(coords, tris, half, v_start, e_start, is_row_line,
                                       is_col_line, len(ys) - 2, np.full(slots, -1, np.int64),
                                       np.full(slots, -1, np.int64), ids, on_line, seams)
        t = lap("stitch", t)
        coords, on_line = coords[:n_points], on_line[:n_points]
        bound = np.empty(tres.shape[0] * tres.shape[1])
        order = np.empty(tres.shape[0] * tres.shape[1], np.int64)
        gt._remove_vertices(h, tplane, tres, bound, order, coords, tris, half, n_points,
                            len(tris), float(tol), gt._REMOVAL_PASSES, on_line)
        t = lap("remove", t)
        stack = np.empty(max(64, 8 * n_seams), np.int64)
        stack[:n_seams] = seams[:n_seams]
        gt._relax_edges(h, tplane, tres, bound, order, coords, tris, half, stack, n_seams,
                        float(tol), np.empty(6, np.int32), np.empty((2, 2), np.int32),
                        np.empty(2))
        t = lap("flips", t)
        out = gt._grid_triangles(coords, tris, cols)
        lap("output", t)
        steps.setdefault("triangle slots", []).append(len(tris) // 3)
        return out

    gt._join_pieces = timed_join
    for err in errors:
        for _ in range(3):
            gt.greedy_tin(hm, max_error=err)
        steps.clear()
        for _ in range(15):
            gt.greedy_tin(hm, max_error=err)
        slots = steps.pop("triangle slots")[0]
        print(f"DEM {err:g} m ({slots} triangle slots joined): " + ", ".join(
            f"{k} {1e3 * statistics.median(v):.2f} ms" for k, v in steps.items()), flush=True)


def rtin_then_removal(n_passes: int) -> None:
    from pydelatin import Delatin

    from terrascape.lod.rtin import rtin_mesh

    hm = _synthetic()
    h = np.ascontiguousarray(hm.heights, np.float32)
    rows, cols = h.shape
    for err in (1.0, 2.0, 5.0, 10.0):
        theirs = len(Delatin(hm.heights, width=cols, height=rows, max_error=err).triangles)
        for _ in range(2):  # the second round is timed (the first compiles)
            t0 = time.perf_counter()
            tri = rtin_mesh(hm, max_error=err)
            t1 = time.perf_counter()
            used, inverse = np.unique(tri.reshape(-1), return_inverse=True)
            coords = np.column_stack([used % cols, used // cols]).astype(np.int64)
            faces = inverse.reshape(-1, 3).astype(np.int64)
            # twins: the reverse of each halfedge, found by sorting the edge keys
            a, b = faces.reshape(-1), faces[:, [1, 2, 0]].reshape(-1)
            key, reverse = a * len(used) + b, b * len(used) + a
            order = np.argsort(key)
            pos = np.minimum(np.searchsorted(key[order], reverse), len(key) - 1)
            half = np.where(key[order][pos] == reverse, order[pos], -1).astype(np.int32)
            tris = faces.reshape(-1).astype(np.int32)
            tiles = (-(-rows // gt._TILE), -(-cols // gt._TILE))
            plane, res = np.empty((*tiles, 3)), np.empty((*tiles, 4))
            gt._tile_ranges(h, plane, res)
            t2 = time.perf_counter()
            gt._remove_vertices(h, plane, res, np.empty(tiles[0] * tiles[1]),
                                np.empty(tiles[0] * tiles[1], np.int64), coords, tris, half,
                                len(coords), len(tris), err, n_passes,
                                np.ones(len(coords), np.bool_))
            t3 = time.perf_counter()
        out = gt._grid_triangles(coords, tris, cols)
        t4 = time.perf_counter()
        greedy = gt.greedy_tin(hm, max_error=err)
        t5 = time.perf_counter()
        print(f"{err:g} m: RTIN {len(tri) / theirs:.3f}× pydelatin's triangles in "
              f"{1e3 * (t1 - t0):.1f} ms (conversion {1e3 * (t2 - t1):.1f} ms), after "
              f"{n_passes} removal passes {len(out) / theirs:.3f}× in {1e3 * (t3 - t2):.1f} ms; "
              f"the greedy TIN {len(greedy) / theirs:.3f}× in {1e3 * (t5 - t4):.1f} ms",
              flush=True)


def main(argv: list[str]) -> None:
    mode = argv[0] if argv else "passes"
    if mode == "passes":
        which = argv[1] if len(argv) > 1 else "syn"
        passes(which, [float(v) for v in argv[2:]] or [1.0, 2.0, 5.0, 10.0])
    elif mode == "join":
        join([float(v) for v in argv[1:]] or [1.0, 10.0])
    elif mode == "rtin":
        rtin_then_removal(int(argv[1]) if len(argv) > 1 else 8)
    else:
        raise SystemExit(__doc__)


if __name__ == "__main__":
    main(sys.argv[1:])
