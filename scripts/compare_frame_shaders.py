"""Time the streamed viewer's frame with an earlier commit's shaders against this checkout's,
in one process.

    python scripts/compare_frame_shaders.py REV [TECHNIQUE] [ROUNDS]

Extracts ``src/terrascape/render/shaders`` as it was at REV, opens two headless GL contexts
on the benchmark world of ``terrascape bench world_view`` (4097², built when missing), one
compiling REV's shaders and one this checkout's, with every tile of four views of the
seeded flight loaded, and renders each view in both, in turn, ROUNDS times (default 7), so
the host's load weighs on both alike. Prints per view the median frame time (draw calls and
rasterising) of each and the median of the per-round ratios, then the overall median ratio
and how far the two frames' pixels differ.
"""

from __future__ import annotations

import contextlib
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from io import BytesIO
from pathlib import Path

import numpy as np

import terrascape.render.shaders as shaders
from terrascape.bench import world_view
from terrascape.bench.viewer import _Surface
from terrascape.render.tiled_terrain import TiledGeometry, seeded_flight, split_budget
from terrascape.viewer.session import ViewerSession
from terrascape.world.chunked_lod import StoreReader, tile_mesh, world_pyramid

VIEWS = (20, 60, 100, 140)


def _shaders_at(rev: str, into: Path) -> Path:
    repo = Path(__file__).resolve().parents[1]
    tree = "src/terrascape/render/shaders"
    data = subprocess.run(["git", "-C", str(repo), "archive", rev, tree], check=True,
                          capture_output=True).stdout
    with tarfile.open(fileobj=BytesIO(data)) as tar:
        tar.extractall(into, filter="data")
    return into / tree


@contextlib.contextmanager
def _shader_dir(path: Path):
    old = shaders.SHADER_DIR
    shaders.SHADER_DIR = path
    try:
        yield
    finally:
        shaders.SHADER_DIR = old


def main() -> int:
    if len(sys.argv) < 2:
        print(__doc__)
        return 2
    rev = sys.argv[1]
    technique = sys.argv[2] if len(sys.argv) > 2 else "plain"
    rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 7
    path, _ = world_view.ensure_world(4097)
    proxy, share = split_budget(path, world_view.BUDGET)
    reader = StoreReader(path, cache_bytes=256 << 20)
    pyramid = world_pyramid(path, reader=reader)
    cams = seeded_flight(proxy.heightmap, 150, seed=7, size=world_view.SIZE, crossing_s=40.0)
    with tempfile.TemporaryDirectory() as tmp:
        dirs = {rev: _shaders_at(rev, Path(tmp)), "this checkout": shaders.SHADER_DIR}
        runs = {}
        try:
            for name, folder in dirs.items():
                surface = _Surface(world_view.SIZE)
                with surface.ctx, _shader_dir(folder):
                    geometry = TiledGeometry(surface.ctx, pyramid,
                                             lambda key: tile_mesh(reader, pyramid, key),
                                             budget_bytes=share.tile_bytes, background=False)
                    session = ViewerSession(surface.ctx, proxy.heightmap, size=world_view.SIZE,
                                            hud=False, technique=technique, geometry=geometry,
                                            warn=lambda m: None)
                runs[name] = (session, surface, folder)

            def render(name: str) -> float:
                session, surface, folder = runs[name]
                # one GL context current at a time: moderngl calls go to the current one
                with surface.ctx, _shader_dir(folder):
                    surface.ctx.finish()
                    t0 = time.perf_counter()
                    session.render(surface.fbo, 0.0)
                    surface.ctx.finish()
                    return (time.perf_counter() - t0) * 1000.0

            ratios = []
            print(f"{technique} frames at {world_view.SIZE[0]}×{world_view.SIZE[1]}, ms: "
                  f"{rev} / this checkout")
            for view in VIEWS:
                for session, _, _ in runs.values():
                    session.camera = cams[view]
                for name in runs:
                    render(name)  # loads the view's tiles, compiles what it needs
                ms = {name: [] for name in runs}
                for _ in range(rounds):
                    for name in runs:
                        ms[name].append(render(name))
                old, new = ms[rev], ms["this checkout"]
                r = [b / a for a, b in zip(old, new, strict=True)]
                ratios += r
                print(f"view {view:3d}: {statistics.median(old):6.1f} / "
                      f"{statistics.median(new):6.1f}   ratio {statistics.median(r):.3f} "
                      f"({min(r):.2f}–{max(r):.2f})")
            print(f"median ratio (this checkout ÷ {rev}): {statistics.median(ratios):.3f}")
            frames = []
            for name, (_, surface, _) in runs.items():
                render(name)
                with surface.ctx:
                    frames.append(np.frombuffer(surface.fbo.read(components=3),
                                                np.uint8).astype(np.int16).reshape(-1, 3))
            signed = frames[1] - frames[0]
            diff = np.abs(signed).max(axis=-1)
            print(f"last view's pixels: largest difference {int(diff.max())} levels; "
                  f"{100.0 * (diff > 0).mean():.2f} % differ, {100.0 * (diff > 1).mean():.2f} % "
                  f"by more than 1; mean difference (R, G, B) "
                  + ", ".join(f"{v:+.3f}" for v in signed.reshape(-1, 3).mean(axis=0)))
        finally:
            for session, surface, _ in runs.values():
                with surface.ctx:
                    session.release()
                surface.release()
    return 0


if __name__ == "__main__":
    sys.exit(main())
