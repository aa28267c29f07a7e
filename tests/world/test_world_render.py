"""Rendering straight from a world store: only the chunks in view, at the level needed,
within the memory budget — and the same picture as the map loaded whole."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import zarr

from terrascape.camera import Camera
from terrascape.errors import MemoryLimitError
from terrascape.heightmap import Heightmap
from terrascape.world import build_world, connect, recipe_from_dict
from terrascape.world.window import camera_window, read_level, world_camera

SIZE = (192, 108)


@pytest.fixture(scope="module")
def world(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("world") / "w.zarr"
    recipe = recipe_from_dict({
        "size": [257, 257], "spacing": 2.0, "seed": 3, "chunk": 64,
        "generator": {"name": "fbm", "relief": 60.0, "scale": 80.0, "octaves": 6}})
    with connect("local", workers=2, processes=False, memory_limit=None) as client:
        assert build_world(recipe, path, client=client).complete
    return path


def _heights(path: Path) -> np.ndarray:
    return np.asarray(zarr.open_group(str(path), mode="r")["height"][...])


def test_bounds_are_each_chunks_range(world):
    h = _heights(world)
    bounds = np.asarray(zarr.open_group(str(world), mode="r")["bounds"][...])
    assert bounds.shape == (5, 5, 2)
    for i in range(5):
        for j in range(5):
            tile = h[i * 64:(i + 1) * 64, j * 64:(j + 1) * 64]
            assert bounds[i, j, 0] == tile.min() and bounds[i, j, 1] == tile.max()


def test_window_reads_only_chunks_in_view_at_needed_level(world):
    h = _heights(world)
    # A low camera in one corner looking into it: the far corner is out of view.
    cam = Camera.look_at((40.0, 90.0, 40.0), (10.0, 40.0, 10.0), fov_y=45.0,
                         aspect=SIZE[0] / SIZE[1], near=0.5, far=2000.0)
    win = camera_window(world, cam, SIZE, budget=1 << 30)
    assert win.visible_chunks < win.total_chunks == 25
    assert win.level == 0 and win.offset == (0.0, 0.0)
    assert win.rows[1] < 257 and win.cols[1] < 257
    assert np.array_equal(win.heightmap.heights, h[:win.rows[1], :win.cols[1]])
    # Looking the other way, into the opposite corner: the window starts there.
    cam = Camera.look_at((470.0, 90.0, 470.0), (500.0, 40.0, 500.0), fov_y=45.0,
                         aspect=SIZE[0] / SIZE[1], near=0.5, far=2000.0)
    win = camera_window(world, cam, SIZE, budget=1 << 30)
    r0, c0 = win.rows[0], win.cols[0]
    assert r0 > 0 and c0 > 0 and win.offset == (c0 * 2.0, r0 * 2.0)
    assert np.array_equal(win.heightmap.heights, h[r0:, c0:])
    # Far away, a small image: one sample per pixel needs a coarse level, read from the
    # pyramid (level k = every 2**k-th sample).
    far = Camera.look_at((256.0, 4000.0, 6000.0), (256.0, 30.0, 256.0), fov_y=30.0,
                         aspect=SIZE[0] / SIZE[1], near=1.0, far=20000.0)
    win = camera_window(world, far, SIZE, budget=1 << 30)
    assert win.level >= 2 and win.needed_level == win.level
    step = 1 << win.level
    assert np.array_equal(win.heightmap.heights, h[::step, ::step])
    assert win.heightmap.spacing == (2.0 * step, 2.0 * step)


def test_budget_picks_coarser_levels_then_refuses(world):
    h = _heights(world)
    cam = world_camera(world, SIZE)
    full = camera_window(world, cam, SIZE, budget=1 << 30)
    assert full.level == 0 and full.heightmap.shape == (257, 257)
    budget = int(full.estimate_bytes * 0.6)
    coarser = camera_window(world, cam, SIZE, budget=budget)
    assert coarser.level == 1 and coarser.estimate_bytes <= budget
    assert np.array_equal(coarser.heightmap.heights, h[::2, ::2])
    # Beyond the stored pyramid (3 levels here) levels are made on demand.
    group = zarr.open_group(str(world), mode="r")
    assert group.attrs["levels"] == 3
    assert np.array_equal(read_level(group, 5, 0, 9, 0, 9), h[::32, ::32])
    with pytest.raises(MemoryLimitError, match="raise --max-memory"):
        camera_window(world, cam, SIZE, budget=100)


def _block_means(img: np.ndarray, b: int = 4) -> np.ndarray:
    h, w = img.shape[0] // b * b, img.shape[1] // b * b
    x = img[:h, :w, :3].astype(np.float64)
    return x.reshape(h // b, b, w // b, b, 3).mean(axis=(1, 3))


@pytest.mark.gl
def test_render_from_world_equals_whole_map(world, gl_ctx, tmp_path):
    from PIL import Image
    from typer.testing import CliRunner

    from terrascape.cli import app
    from terrascape.render.offscreen import OffscreenRenderer
    from terrascape.world.render import render_world, world_haze

    cam = world_camera(world, SIZE)
    params = {"sun": (135.0, 45.0), "haze": world_haze(world)}
    whole = OffscreenRenderer(gl_ctx, Heightmap(_heights(world), (2.0, 2.0)), size=SIZE)
    try:
        expected = whole.render(cam, "material", params)
    finally:
        whole.release()
    # Everything fits: every tile the view needs at level 0 (tiles of 64² cells: none of
    # them far enough for level 1), over the whole map's overview: the same pixels (a
    # rounding step at most where triangles meet differently).
    img, frame = render_world(world, cam, size=SIZE, params=params, ctx=gl_ctx,
                              budget=1 << 30, tile=64)
    assert frame.proxy_level == 0 and frame.levels == {0: frame.tiles}
    assert frame.max_pixels == 0.0 and not frame.budget_bound
    diff = np.abs(img.astype(int) - expected)
    assert diff.max() <= 2 and diff.mean() < 0.01
    # A far camera: the tiles take coarser levels, within the tolerance of half a pixel,
    # and the picture still matches the whole map's.
    far = Camera.look_at((256.0, 700.0, 1500.0), (256.0, 30.0, 256.0), fov_y=40.0,
                         aspect=SIZE[0] / SIZE[1], near=1.0, far=20000.0)
    whole = OffscreenRenderer(gl_ctx, Heightmap(_heights(world), (2.0, 2.0)), size=SIZE)
    try:
        expected_far = whole.render(far, "material", params)
    finally:
        whole.release()
    img, frame = render_world(world, far, size=SIZE, params=params, ctx=gl_ctx,
                              budget=1 << 30)
    assert max(frame.levels) >= 1 and 0 < frame.max_pixels <= 0.5
    assert frame.tiles < 16  # fewer, coarser tiles than the 16 of level 0
    diff = np.abs(img[..., :3].astype(int) - expected_far[..., :3])
    assert diff.mean() < 1.0 and np.percentile(diff, 99) < 24
    # --max-memory below the full-resolution render's need: the CLI reads level 1 and
    # the picture matches the whole map's within a tolerance (4×4 block means).
    np.save(tmp_path / "h.npy", _heights(world))
    runner = CliRunner()
    refused = runner.invoke(app, ["render", str(tmp_path / "h.npy"), "-o",
                                  str(tmp_path / "whole.png"), "--size", "192x108",
                                  "--max-memory", "8M"])
    assert refused.exit_code != 0 and not (tmp_path / "whole.png").exists()
    res = runner.invoke(app, ["render", str(world), "-o", str(tmp_path / "w.png"), "--size",
                              "192x108", "--max-memory", "8M", "--sun", "135,45"])
    assert res.exit_code == 0, res.output
    assert "overview level 1 (129×129)" in res.output and "tiles (" in res.output
    got = np.asarray(Image.open(tmp_path / "w.png"))
    assert got.shape == (108, 192, 3)
    diff = np.abs(_block_means(got) - _block_means(expected))
    assert diff.mean() < 8.0, diff.mean()
    assert np.percentile(diff, 90) < 25.0
    # The picture is the terrain, not the sky or a misplaced window: the lower half holds
    # the terrain's detail (a flat colour would have no variance).
    assert got[60:, :, :].std() > 15.0


def test_overview_window_for_the_viewer(world):
    from terrascape.world.window import overview_window

    h = _heights(world)
    win = overview_window(world, budget=1 << 30)
    assert win.level == 0 and np.array_equal(win.heightmap.heights, h)
    win = overview_window(world, budget=1 << 30, max_side=100)
    assert win.level == 2 and np.array_equal(win.heightmap.heights, h[::4, ::4])
    assert win.heightmap.spacing == (8.0, 8.0)
    win = overview_window(world, budget=129 * 129 * 200)
    assert win.level == 1
    with pytest.raises(MemoryLimitError, match="coarsest"):
        overview_window(world, budget=10)


@pytest.mark.xvfb
def test_view_a_world_in_a_window(world, tmp_path, xvfb):
    """`terrascape view world.zarr` opens the viewer on the world and draws frames."""
    import subprocess
    import sys

    env = dict(xvfb, TERRASCAPE_MAX_MEMORY="8M")
    res = subprocess.run(
        [sys.executable, "-c", "import sys; from terrascape.cli import main; "
         "main(sys.argv[1:])", "view", str(world), "--frames", "3", "--size", "320x240",
         "--screenshot-dir", str(tmp_path)],
        env=env, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    # 8 MiB: the 257² world (13 MB to draw) has its overview at level 1, 129² samples, and
    # its tiles stream in within what is left
    assert "world at level 1" in res.stderr and "129×129" in res.stderr
    assert "tiles of levels 0–3 stream in within" in res.stderr  # 32² tiles of 256²
    assert "after 3 frames" in res.stderr


def test_tile_table_of_a_store_is_cached_and_exact(world):
    from terrascape.world.chunked_lod import (
        StoreReader,
        TileKey,
        array_reader,
        build_pyramid,
        tile_mesh,
        world_pyramid,
    )

    h = _heights(world)
    cache = world / "terrascape_lod4_32.npz"
    cache.unlink(missing_ok=True)
    reader = StoreReader(world, cache_bytes=3 * 64 * 64 * 4)  # three zarr chunks
    built = world_pyramid(world, tile=32, reader=reader)
    assert cache.is_file()
    again = world_pyramid(world, tile=32)  # read from the cache
    mem = build_pyramid(array_reader(h), h.shape, 2.0, tile=32)
    assert built.grid == again.grid == mem.grid and built.grid.top == 3
    for k in range(built.grid.top + 1):
        for table in ("error", "low", "high", "skirt", "error_bintree"):
            assert np.array_equal(getattr(built, table)[k], getattr(mem, table)[k])
            assert np.array_equal(getattr(again, table)[k], getattr(mem, table)[k])
    # tiles read through the chunk cache equal those of the map in memory
    for key in ((0, 3, 5), (2, 1, 1), (3, 0, 0)):
        a = tile_mesh(reader, built, TileKey(*key))
        b = tile_mesh(array_reader(h), mem, TileKey(*key))
        assert np.array_equal(a.positions, b.positions)
        assert np.array_equal(a.normals, b.normals)
