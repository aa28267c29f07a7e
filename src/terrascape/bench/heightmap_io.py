"""Benchmark: read/write time and file size of every heightmap format."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from terrascape.bench import BenchTable, best_of
from terrascape.heightmap import Heightmap
from terrascape.io import read_heightmap, write_heightmap

_EXTENSIONS = (".png", ".bmp", ".r16", ".r32", ".tif", ".npy", ".ter")


def _terrain(side: int) -> Heightmap:
    # A smooth deterministic surface with fine detail: PNG compression sees realistic data.
    z, x = np.mgrid[0:side, 0:side] / (side - 1)
    h = 800 * np.sin(6 * x) * np.cos(5 * z) + 40 * np.sin(97 * x + 61 * z) + 1200
    return Heightmap(h.astype(np.float32), (30.0, 30.0))


def run(quick: bool = False) -> list[BenchTable]:
    """Write then read each format; report best-of wall times, size and max error."""
    side = 257 if quick else 2049
    repeat = 2 if quick else 3
    hm = _terrain(side)
    table = BenchTable(
        title=f"heightmap I/O, {side}×{side} float32 ({hm.heights.nbytes / 2**20:.1f} MiB)",
        columns=["format", "write ms", "read ms", "file KiB", "max |error|", "MB/s read"],
    )
    with tempfile.TemporaryDirectory(prefix="terrascape-bench-") as tmp:
        for ext in _EXTENSIONS:
            path = Path(tmp) / f"h{ext}"
            t_write = best_of(lambda p=path: write_heightmap(hm, p, force=True), repeat=repeat)
            t_read = best_of(lambda p=path: read_heightmap(p), repeat=repeat)
            back = read_heightmap(path)
            if ext == ".bmp":  # normalised preview: compare in [0, 1]
                ref = (hm.heights - hm.min) / (hm.max - hm.min)
            else:
                ref = hm.heights
            err = float(np.abs(back.heights.astype(np.float64) - ref).max())
            table.rows.append(
                [
                    ext,
                    t_write * 1e3,
                    t_read * 1e3,
                    path.stat().st_size / 1024,
                    err,
                    hm.heights.nbytes / t_read / 1e6,
                ]
            )
    table.notes.append(f"best of {repeat} after one warm-up; .bmp error is in normalised units")
    table.notes.append("RAW formats also write a .json sidecar (not counted in the size)")
    return [table]
