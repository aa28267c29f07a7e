"""Where the greedy TIN's time goes, on the maps of ``terrascape bench peers``.

    python scripts/greedy_tin_probes.py passes [syn|dem] [ERROR ...]
    python scripts/greedy_tin_probes.py join [ERROR ...]
    python scripts/greedy_tin_probes.py rtin [PASSES]

``passes``: the mesh in pieces with 8, 2, 1 and no removal passes (median of 5 builds, ms)
and its triangles ÷ pydelatin's: what the removal of redundant vertices costs and buys.
``join``: the Jacksboro DEM's join of the pieces step by step (medians of 15 meshes, ms):
the whole join, and in it stitching the pieces, offering the lines' vertices to the
removal, the flips, the output, and what is left (concatenating the pieces' arrays).
``rtin``: the other way the issue suggested, RTIN and then
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

    def timed(name, kernel):
        def run(*args):
            t0 = time.perf_counter()
            out = kernel(*args)
            steps.setdefault(name, []).append(time.perf_counter() - t0)
            return out
        return run

    # the join's own calls, each timed (the join looks them up when it runs); what is left
    # of its time is concatenating the pieces' arrays and allocating the slots
    kernels = {"_join_pieces": "join", "_stitch": "stitch", "_remove_vertices": "remove",
               "_relax_edges": "flips", "_grid_triangles": "output"}
    originals = {name: getattr(gt, name) for name in kernels}
    for name, label in kernels.items():
        setattr(gt, name, timed(label, originals[name]))
    try:
        for err in errors:
            for _ in range(3):
                gt.greedy_tin(hm, max_error=err)
            steps.clear()
            for _ in range(15):
                gt.greedy_tin(hm, max_error=err)
            med = {k: 1e3 * statistics.median(v) for k, v in steps.items()}
            rest = med["join"] - sum(med[k] for k in ("stitch", "remove", "flips", "output"))
            print(f"DEM {err:g} m: join {med['join']:.2f} ms — concatenating and allocating "
                  f"{rest:.2f}, " + ", ".join(f"{k} {med[k]:.2f}" for k in
                                              ("stitch", "remove", "flips", "output")),
                  flush=True)
    finally:
        for name, kernel in originals.items():
            setattr(gt, name, kernel)


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
                                np.ones(len(coords), np.bool_), np.zeros(1, np.uint8))
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
