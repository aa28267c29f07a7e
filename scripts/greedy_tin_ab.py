"""The greedy TIN against another checkout's: time and triangles on the bench's maps.

    python scripts/greedy_tin_ab.py OTHER_SRC [--one-order] [--large] [--rounds N]

``OTHER_SRC`` is another checkout's ``src`` folder (e.g. a ``git worktree`` of an earlier
commit). Both meshers run in one process, interleaved round by round (odd rounds the other
first), on the maps of ``terrascape bench peers`` (synthetic 1025² relief 400 m and the
Jacksboro DEM, at 1, 2, 5 and 10 m; with ``--large`` the synthetic 4097² at 2 m instead).
Printed per map and error: the median of the within-round time ratios (this ÷ other) with
its spread, both meshes' triangles ÷ pydelatin's (when installed) and this one's measured
error. ``--one-order`` meshes as one greedy order (``in_pieces=False``), else in pieces on
numba's threads. Written to measure the sparse search of large triangles and the
decimation of dense pieces (2026-12-06).
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path

import numpy as np

from terrascape.bench.peers import TIN_ERRORS, TIN_LARGE, paired_ratio, real_dem
from terrascape.bench.shade import terrain
from terrascape.lod.greedy_tin import greedy_tin
from terrascape.lod.mesh_checks import max_vertical_error


def _other_mesher(src: str):
    """``greedy_tin`` of the checkout at ``src``, imported under its own module name (numba's
    cache then keeps its kernels apart from this checkout's). Its cache entries, in that
    checkout's ``__pycache__``, name this module: run from that checkout itself, its greedy
    TIN fails to load them (``No module named 'terrascape.lod._other_greedy_tin'``) until
    ``src/terrascape/lod/__pycache__/greedy_tin.*.nb[ic]`` there are deleted."""
    path = Path(src).resolve() / "terrascape" / "lod" / "greedy_tin.py"
    name = "terrascape.lod._other_greedy_tin"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module.greedy_tin


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("other_src")
    parser.add_argument("--one-order", action="store_true")
    parser.add_argument("--large", action="store_true")
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()
    other = _other_mesher(args.other_src)
    pieces = not args.one_order
    if args.large:
        name, size, err = TIN_LARGE
        maps = [(name, terrain(size).normalised(0.0, 1000.0), (err,))]
    else:
        maps = [("synthetic 1025²", terrain(1025).normalised(0.0, 400.0), TIN_ERRORS),
                ("Jacksboro DEM 344×403", real_dem(), TIN_ERRORS)]
    try:
        from pydelatin import Delatin
    except ImportError:
        Delatin = None
    print(f"{'map':24} {'error':>5}  {'time this ÷ other (spread)':28} "
          f"{'triangles ÷ pydelatin: this, other':36} measured error")
    for map_name, hm, errors in maps:
        rows, cols = hm.shape
        for err in errors:
            this = lambda hm=hm, err=err: greedy_tin(hm, max_error=err, in_pieces=pieces)  # noqa: E731
            that = lambda hm=hm, err=err: other(hm, max_error=err, in_pieces=pieces)  # noqa: E731
            ratio, lo, hi, _, _ = paired_ratio(this, that, args.rounds)
            mine, theirs = this(), that()
            if Delatin is not None:
                n_peer = len(Delatin(np.asarray(hm.heights, np.float32), width=cols,
                                     height=rows, max_error=err).triangles)
                counts = f"{len(mine) / n_peer:.3f}, {len(theirs) / n_peer:.3f}"
            else:
                counts = f"{len(mine)}, {len(theirs)} (no pydelatin)"
            print(f"{map_name:24} {err:5g}  {ratio:.3f} ({lo:.3f}–{hi:.3f}){'':10} "
                  f"{counts:36} {max_vertical_error(hm, mine):.5f}", flush=True)


if __name__ == "__main__":
    main()
