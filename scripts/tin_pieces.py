"""The greedy TIN in pieces against one greedy order over the whole map.

    python scripts/tin_pieces.py             # the bench's maps, 7 rounds
    python scripts/tin_pieces.py SIZE ERROR  # one synthetic SIZE² map, one round

For the maps of ``terrascape bench peers``' TIN rows (synthetic 1025², Jacksboro DEM) at
1, 2, 5 and 10 m: triangles and build time (median of 7 interleaved rounds, all threads)
of ``greedy_tin(in_pieces=False)`` and of the default (pieces meshed in parallel, joined,
seams relaxed), and how much of the pieces' shared lines' length is still mesh edges
(one greedy order: the same lines measured on its mesh). With SIZE and ERROR: the synthetic
map of that size (heights 0–1000 m) at that error, each build once.
"""

from __future__ import annotations

import sys
import time

import numba
import numpy as np

from terrascape.bench.peers import paired_ratio, real_dem
from terrascape.bench.shade import terrain
from terrascape.lod import greedy_tin as gt
from terrascape.lod.mesh_checks import line_edge_share

ERRORS = (1.0, 2.0, 5.0, 10.0)
ROUNDS = 7


def line_share(shape: tuple[int, int], tri: np.ndarray) -> float:
    """Share of the inner piece lines' length that runs along mesh edges."""
    rows, cols = shape
    return line_edge_share(tri, shape, gt._piece_edges(rows)[1:-1], gt._piece_edges(cols)[1:-1])


def once(size: int, err: float) -> None:
    hm = terrain(size).normalised(0.0, 1000.0)
    for label, pieces in (("one greedy order", False), ("pieces", True)):
        t0 = time.perf_counter()
        tri = gt.greedy_tin(hm, max_error=err, in_pieces=pieces)
        took = time.perf_counter() - t0
        print(f"synthetic {size}², {err:g} m, {numba.get_num_threads()} threads, {label}: "
              f"{len(tri)} triangles in {took:.2f} s, line share "
              f"{line_share(hm.shape, tri):.3f}")


def main() -> None:
    print(f"threads: {numba.get_num_threads()}; medians of {ROUNDS} interleaved rounds")
    print("map | max error m | one order: triangles, ms, line share | pieces: triangles, "
          "ms, line share | time pieces ÷ one")
    for name, hm in (("synthetic 1025²", terrain(1025).normalised(0.0, 400.0)),
                     ("Jacksboro DEM 344×403", real_dem())):
        for err in ERRORS:
            def one(err=err, hm=hm):
                return gt.greedy_tin(hm, max_error=err, in_pieces=False)

            def pieces(err=err, hm=hm):
                return gt.greedy_tin(hm, max_error=err)

            tri_one, tri_pieces = one(), pieces()
            ratio, _, _, t_pieces, t_one = paired_ratio(pieces, one, ROUNDS)
            print(f"{name} | {err:g} | {len(tri_one)}, {t_one * 1e3:.1f}, "
                  f"{line_share(hm.shape, tri_one):.3f} | {len(tri_pieces)}, "
                  f"{t_pieces * 1e3:.1f}, "
                  f"{line_share(hm.shape, tri_pieces):.3f} | {ratio:.2f}")


if __name__ == "__main__":
    if len(sys.argv) == 3:
        once(int(sys.argv[1]), float(sys.argv[2]))
    else:
        main()
