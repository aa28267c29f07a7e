"""`terrascape view world.zarr` without a window: a seeded flight over a small world whose
tiles stream in on a background thread — frames drawn while tiles load (by their parents),
the tile memory bound held, the finished view drawn at the levels the selection asked."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from terrascape.world import build_world, connect, recipe_from_dict
from terrascape.world.chunked_lod import TileKey

SIZE = (160, 96)


@pytest.fixture(scope="module")
def world(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("stream") / "w.zarr"
    recipe = recipe_from_dict({
        "size": [257, 257], "spacing": 4.0, "seed": 11, "chunk": 64,
        "generator": {"name": "fbm", "relief": 120.0, "scale": 160.0, "octaves": 6}})
    with connect("local", workers=1, processes=False, memory_limit=None) as client:
        assert build_world(recipe, path, client=client).complete
    return path


def _frames_for(session, fbo, values, apply) -> tuple[dict, dict]:
    """The frame and its triangle count for each of ``values``, set by ``apply(value)``
    before the session draws."""
    frames, tris = {}, {}
    for value in values:
        apply(value)
        session.render(fbo, 0.0)
        frames[value], tris[value] = _frame(fbo), session.stats["triangles"]
    return frames, tris


def _frame(fbo) -> np.ndarray:
    w, h = fbo.size
    return np.frombuffer(fbo.read(components=3), np.uint8).reshape(h, w, 3)[::-1].astype(int)


@pytest.mark.gl
def test_flight_streams_tiles_without_waiting(world, gl_ctx):
    from terrascape.render.tiled_terrain import TiledGeometry, seeded_flight
    from terrascape.viewer.session import ViewerSession
    from terrascape.world.chunked_lod import StoreReader, tile_mesh, world_pyramid
    from terrascape.world.window import overview_window

    reader = StoreReader(world)
    pyramid = world_pyramid(world, tile=16, reader=reader)
    assert pyramid.grid.top == 4
    built = []

    def slow_build(key):
        time.sleep(0.03)  # a slow disk: a frame that waited for its tiles would show it
        built.append(key)
        return tile_mesh(reader, pyramid, key)

    budget = 30 * pyramid.grid.max_tile_bytes()
    geometry = TiledGeometry(gl_ctx, pyramid, slow_build, budget_bytes=budget, tolerance=1.0)
    proxy = overview_window(world, budget=1 << 30, max_side=65).heightmap
    assert proxy.shape == (65, 65)
    session = ViewerSession(gl_ctx, proxy, size=SIZE, hud=False, technique="plain",
                            geometry=geometry, moving_sun_shadows=False, warn=lambda m: None)
    fbo = gl_ctx.simple_framebuffer(SIZE)
    cams = seeded_flight(proxy, 45, seed=4, size=SIZE, crossing_s=3.0)
    assert cams == seeded_flight(proxy, 45, seed=4, size=SIZE, crossing_s=3.0)
    try:
        loading_frames, update_ms, peak = 0, [], 0
        for cam in cams:
            session.camera = cam
            session.render(fbo, 1 / 30)
            update_ms.append(geometry.last_update_ms)
            st = session.tile_stats
            assert st["tiles_drawn"] > 0 and st["tile_bytes"] <= budget
            assert st["tile_bytes"] == sum(t.nbytes for t in geometry.cache.values())
            peak = max(peak, st["tile_bytes_peak"])
            if not st["complete"]:
                loading_frames += 1
                img = _frame(fbo)
                assert img[SIZE[1] // 2:].std() > 5.0  # the terrain, drawn by parents
        assert loading_frames >= 5
        # the frames never waited for the 30 ms loads: selecting, uploading a few tiles
        assert np.median(update_ms) < 30.0
        # bounded: at most 30 tiles' bytes; every upload beyond them dropped an old tile
        assert peak <= budget and len(geometry.cache) <= 30
        assert len(geometry.cache) + geometry.cache.evicted == geometry.uploaded
        # the root before the first frame, then what the flight asked for, on the thread
        assert built[0] == pyramid.grid.roots()[0]
        # hold the last view: the loads finish, and the frame draws exactly the selection
        deadline = time.monotonic() + 60
        while not session.tile_stats["complete"] and time.monotonic() < deadline:
            time.sleep(0.05)
            session.render(fbo, 1 / 30)
        # (how many the thread built while the flight went on depends on the frames' speed;
        # the flight and the held view ask for more than 5 over the root)
        assert len(built) > 5
        st = session.tile_stats
        assert st["complete"] and st["max_pixels"] <= 1.0
        assert set(geometry.drawn) == set(geometry.selection.visible)
        assert len({k.level for k in geometry.drawn}) >= 2
        lines = session.status_lines()
        assert any(line.startswith("tiles ") and "resident" in line for line in lines)
    finally:
        fbo.release()
        session.release()
    assert geometry.loader is None and len(geometry.cache) == 0


@pytest.mark.gl
def test_streamed_view_matches_the_whole_map(world, gl_ctx):
    """Once loaded, the streamed frame looks like the whole map's at full resolution."""
    import zarr

    from terrascape.heightmap import Heightmap
    from terrascape.render.tiled_terrain import stream_world
    from terrascape.viewer.session import ViewerSession
    from terrascape.world.window import overview_window

    h = np.asarray(zarr.open_group(str(world), mode="r")["height"][...])
    proxy = overview_window(world, budget=1 << 30).heightmap  # the whole 257² world
    frames = {}
    for name in ("tiles", "whole"):
        geometry = (stream_world(gl_ctx, world, budget_bytes=64 << 20, tolerance=0.2)
                    if name == "tiles" else None)
        s = ViewerSession(gl_ctx, proxy if geometry else Heightmap(h, (4.0, 4.0)), size=SIZE,
                          hud=False, technique="plain", geometry=geometry,
                          moving_sun_shadows=False, warn=lambda m: None)
        fbo = gl_ctx.simple_framebuffer(SIZE)
        try:
            deadline = time.monotonic() + 60
            s.render(fbo, 0.0)
            while geometry is not None and geometry.loading() and time.monotonic() < deadline:
                time.sleep(0.05)
                s.render(fbo, 0.0)
            frames[name] = _frame(fbo)
            if geometry is not None:
                # a moving frame drawn at half size and enlarged: the same view, softer
                from dataclasses import replace

                from terrascape.viewer.resolution import ResolutionControl

                held = s.camera
                s.resolution = ResolutionControl(target_fps=15.0, scale=0.5)
                s.camera = replace(held, yaw=held.yaw + 3.0)
                s.render(fbo, 0.05)
                s.camera = held
                s.render(fbo, 0.05)
                assert s.drawn_scale == 0.5
                moving = np.abs(_frame(fbo) - frames[name])
                assert moving.mean() < 8.0, moving.mean()
            if geometry is not None:  # built in the loader process, drawn here
                from terrascape.world.chunked_lod import ProcessTileLoader

                assert isinstance(geometry.loader, ProcessTileLoader)
                assert len(geometry.selection.visible) > 1 and not geometry.loading()
                assert geometry.loader.loaded >= len(geometry.selection.visible) - 1
                assert geometry.loader.peak_rss() > 0
        finally:
            fbo.release()
            s.release()
    diff = np.abs(frames["tiles"] - frames["whole"])
    assert diff.mean() < 2.0 and np.percentile(diff, 99) < 40


def test_loader_process_fills_its_slots_ahead(world):
    """The loader process builds ahead of the viewer into its shared slots (not one mesh
    per frame through the pipe) and no further, bit for bit the meshes built here, and
    reuses the slots as they are taken."""
    from terrascape.world.chunked_lod import (
        ProcessTileLoader,
        StoreReader,
        tile_bintree_errors,
        tile_mesh,
        world_pyramid,
    )

    reader = StoreReader(world)
    pyramid = world_pyramid(world, tile=16, reader=reader)
    grid = pyramid.grid
    keys = grid.roots() + grid.children(grid.roots()[0])
    keys += [c for k in keys[1:] for c in grid.children(k)]
    assert len(keys) >= 13
    loader = ProcessTileLoader(world, tile=16, slots=4)
    try:
        loader.request(keys)
        deadline = time.monotonic() + 60
        while not loader._conn.poll(0.1) and time.monotonic() < deadline:
            pass  # the process starting
        time.sleep(1.5)  # nothing collected meanwhile: a 16² tile takes milliseconds
        first = loader.finished()
        assert len(first) == 4  # every slot's mesh at once, none beyond the slots
        got = list(first)
        while len(got) < len(keys) and time.monotonic() < deadline:
            got += loader.finished()
            time.sleep(0.01)
        assert [m.key for m in got] == keys  # in the order asked, the slots reused
        for mesh in got:
            want = tile_mesh(reader, pyramid, mesh.key, bintree=True)
            assert mesh.shape == want.shape
            for a, b in ((mesh.positions, want.positions), (mesh.normals, want.normals),
                         (mesh.tangents, want.tangents),
                         (mesh.bintree_errors, want.bintree_errors)):
                assert a.dtype == np.float32 and np.array_equal(a, b)
            # the bintree errors of the drawn heights, rounded up to float32 (a bound)
            n = mesh.shape[0] * mesh.shape[1]
            exact = tile_bintree_errors(mesh.positions[:n, 1].reshape(mesh.shape))
            assert np.all(mesh.bintree_errors.astype(np.float64) >= exact)
            assert np.allclose(mesh.bintree_errors, exact, rtol=1e-6)
        assert loader.pending() == 0 and loader.loaded == len(keys)
    finally:
        loader.close()


class _ReadyLoader:
    """A loader whose every requested tile is already built: the frame's byte budget, not
    the loader, decides how many are taken."""

    def __init__(self, build) -> None:
        self._build, self._ready, self.asked = build, [], []

    def request(self, keys) -> None:
        known = {m.key for m in self._ready} | set(self.asked)
        for key in keys:
            if key not in known:
                self._ready.append(self._build(key))
                self.asked.append(key)

    def pending(self) -> int:
        return len(self._ready)

    def finished(self, limit=None):
        n = len(self._ready) if limit is None else limit
        out, self._ready = self._ready[:n], self._ready[n:]
        return out

    def close(self) -> None:
        pass


@pytest.mark.gl
def test_upload_budget_spreads_a_burst_of_tiles_over_frames(world, gl_ctx):
    from terrascape.render.tiled_terrain import TiledGeometry
    from terrascape.world.chunked_lod import StoreReader, tile_mesh, world_pyramid
    from terrascape.world.window import overview_window

    reader = StoreReader(world)
    pyramid = world_pyramid(world, tile=16, reader=reader)
    per_tile = pyramid.grid.max_tile_bytes()

    def build(key):
        return tile_mesh(reader, pyramid, key)

    proxy = overview_window(world, budget=1 << 30, max_side=65).heightmap
    cam = _last_flight_camera(proxy)
    frames = {}
    for budget in (3 * per_tile, 1 << 30):
        loader = _ReadyLoader(build)
        geo = TiledGeometry(gl_ctx, pyramid, build, budget_bytes=200 * per_tile,
                            tolerance=0.3, upload_ms=1e6, upload_bytes=budget, loader=loader)
        try:
            taken = []
            for _ in range(100):
                geo.update(cam, SIZE)
                taken.append(geo.last_uploads)
                assert geo.last_upload_bytes <= budget  # never more than the budget a frame
                if not geo.loading():
                    break
            # the selection and the parents asked for first, all taken, past the root
            assert not geo.loading() and sum(taken) == geo.uploaded - 1
            assert set(geo.selection.visible) <= set(loader.asked)
            frames[budget] = (taken, sorted(loader.asked))
        finally:
            geo.release()
    # every tile was ready at once: all in the first frame without a budget, at most 3 a
    # frame with one of 3 whole tiles' bytes, the same tiles in the end
    (burst, asked), (spread, asked_spread) = frames[1 << 30], frames[3 * per_tile]
    assert burst[0] == sum(burst) > 6 and asked == asked_spread
    assert max(spread) <= 3 and len(spread) >= sum(spread) // 3 and sum(spread) == sum(burst)


def _last_flight_camera(proxy):
    from terrascape.render.tiled_terrain import seeded_flight

    return seeded_flight(proxy, 30, seed=4, size=SIZE, crossing_s=3.0)[-1]


@pytest.mark.gl
def test_tiles_front_to_back_skirts_between_levels_same_pixels(world, gl_ctx):
    """Tiles drawn nearest first, and skirts only on edges not shared with a drawn tile of
    the same level: the picture of the quadtree order with every skirt (no crack opens),
    with fewer triangles and fewer fragments through the depth test."""
    from terrascape.render.tiled_terrain import seeded_flight, stream_world
    from terrascape.viewer.session import ViewerSession
    from terrascape.world.chunked_lod import draw_set
    from terrascape.world.window import overview_window

    proxy = overview_window(world, budget=1 << 30, max_side=65).heightmap
    cam = seeded_flight(proxy, 30, seed=4, size=SIZE, crossing_s=3.0)[-1]
    geo = stream_world(gl_ctx, world, budget_bytes=64 << 20, tolerance=0.5, background=False)
    s = ViewerSession(gl_ctx, proxy, size=SIZE, hud=False, technique="plain", geometry=geo,
                      moving_sun_shadows=False, warn=lambda m: None)
    fbo = gl_ctx.simple_framebuffer(SIZE)
    draw, update = geo.draw, geo.update
    passed = {}

    def counted(program, camera, viewport):
        q = gl_ctx.query(samples=True)
        with q:
            out = draw(program, camera, viewport)
        passed[geo.every_skirt] = q.samples
        return out

    def quadtree_order(camera, viewport):
        out = update(camera, viewport)
        if geo.every_skirt:  # the draw set's own order, as the tiles were drawn before
            by_distance = geo.drawn
            geo.drawn = draw_set(geo.grid, geo.selection.visible, geo.cache.__contains__)
            assert sorted(geo.drawn) == sorted(by_distance) and geo.drawn != by_distance
        return out

    geo.draw, geo.update = counted, quadtree_order
    try:
        s.camera = cam
        frames, tris = _frames_for(s, fbo, (False, True),
                                   lambda every: setattr(geo, "every_skirt", every))
        assert len(geo.drawn) >= 8 and len({k.level for k in geo.drawn}) >= 2
    finally:
        fbo.release()
        s.release()
    diff = np.abs(frames[False] - frames[True])
    assert np.percentile(diff, 99.5) <= 2 and diff.mean() < 0.05  # ties at equal depth only
    assert passed[False] < 0.9 * passed[True]
    # the shared edges' skirts left out (one edge's: 32 of a 16² tile's 640 triangles)
    assert tris[False] < tris[True] - 100


def test_loader_process_is_asked_for_the_front_of_the_queue(world):
    """A request names the first LOADER_QUEUE tiles only (a long list a frame would fill the
    pipe while the process builds); the rest are asked for again by later frames."""
    from terrascape.world.chunked_lod import LOADER_QUEUE, ProcessTileLoader, world_pyramid

    grid = world_pyramid(world, tile=16).grid
    keys = [TileKey(0, i, j) for i in range(grid.count(0)[0]) for j in range(grid.count(0)[1])]
    assert len(keys) > LOADER_QUEUE
    loader = ProcessTileLoader(world, tile=16, slots=4)
    try:
        loader.request(keys)
        assert loader._last == keys[:LOADER_QUEUE] and loader.pending() == LOADER_QUEUE
        got, deadline = [], time.monotonic() + 60
        while len(got) < 8 and time.monotonic() < deadline:
            got += loader.finished()
            time.sleep(0.01)
        assert [m.key for m in got[:8]] == keys[:8]
        loader.request(keys[8:])  # the next frame: what is still missing
        assert loader._last == keys[8:8 + LOADER_QUEUE]
    finally:
        loader.close()


@pytest.mark.timeout(120)
def test_requests_never_wait_for_a_loader_process_that_reads_none(world):
    """A loader process that reads no messages for a while (stopped here; on a first run it
    compiles its kernels for seconds) never holds the view: its requests, new each frame,
    return at once however many pile up, and once it runs again it loads the last view's
    tiles, its emptied slots given back. (A blocking send waited until the process read
    again: here, for ever.)"""
    import os
    import signal

    from terrascape.world.chunked_lod import LOADER_QUEUE, ProcessTileLoader, world_pyramid

    grid = world_pyramid(world, tile=16).grid
    keys = [TileKey(0, i, j) for i in range(grid.count(0)[0]) for j in range(grid.count(0)[1])]
    loader = ProcessTileLoader(world, tile=16, slots=4)
    pid = loader._proc.pid
    rng = np.random.default_rng(7)
    try:
        os.kill(pid, signal.SIGSTOP)
        start = time.monotonic()
        for _ in range(2000):  # about 8 MB of requests: far more than the pipe holds
            view = [keys[i] for i in rng.permutation(len(keys))[:LOADER_QUEUE]]
            loader.request(view)
        assert time.monotonic() - start < 10.0
        os.kill(pid, signal.SIGCONT)
        got, deadline = [], time.monotonic() + 60
        while not set(view[:12]) <= {m.key for m in got} and time.monotonic() < deadline:
            loader.request(view)  # the next frames ask again
            got += loader.finished()
            time.sleep(0.01)
        assert set(view[:12]) <= {m.key for m in got}  # 12 tiles through 4 slots
        assert loader._last == view
    finally:
        os.kill(pid, signal.SIGCONT)
        loader.close()


@pytest.mark.gl
def test_tiles_submitted_in_parts_draw_the_same_frame(world, gl_ctx, monkeypatch):
    """The frame's tiles handed to the rasteriser in parts (a flush after each but the
    last): the same pixels as one submission, and one flush between parts."""
    import terrascape.render.tiled_terrain as tiled
    from terrascape.render.context import flush_commands
    from terrascape.render.tiled_terrain import stream_world
    from terrascape.viewer.session import ViewerSession
    from terrascape.world.window import overview_window

    assert flush_commands()  # PyOpenGL (the render extra) is there
    flushes = []
    monkeypatch.setattr(tiled, "flush_commands", lambda: flushes.append(1) or flush_commands())
    proxy = overview_window(world, budget=1 << 30, max_side=65).heightmap
    geo = stream_world(gl_ctx, world, budget_bytes=64 << 20, tolerance=0.5, background=False)
    s = ViewerSession(gl_ctx, proxy, size=SIZE, hud=False, technique="plain", geometry=geo,
                      moving_sun_shadows=False, warn=lambda m: None)
    fbo = gl_ctx.simple_framebuffer(SIZE)
    frames = {}
    try:
        s.camera = _last_flight_camera(proxy)
        for parts in (1, 3):
            geo.submit_parts = parts
            flushes.clear()
            s.render(fbo, 0.0)
            frames[parts] = _frame(fbo)
            assert len(flushes) == parts - 1, (parts, len(geo.drawn))
        assert len(geo.drawn) >= 3
    finally:
        fbo.release()
        s.release()
    assert np.array_equal(frames[1], frames[3])
    assert frames[1][SIZE[1] // 2:].std() > 5.0  # the terrain is in the frame


def test_frustum_test_of_many_tile_boxes_is_the_per_box_test():
    """The draw's one-call frustum test of every tile box decides each box as the test of
    its corner furthest along each plane's normal does, box by box."""
    from terrascape.camera import Camera
    from terrascape.render.tiled_terrain import _in_frustum

    rng = np.random.default_rng(3)
    cam = Camera(position=(50.0, 30.0, 80.0), yaw=35.0, pitch=-15.0, fov_y=60.0, aspect=16 / 9,
                 near=0.5, far=400.0)
    planes = cam.frustum_planes()
    lo = rng.uniform(-300.0, 300.0, (500, 3))
    boxes = np.concatenate([lo, lo + rng.uniform(0.5, 60.0, (500, 3))], axis=1)
    got = _in_frustum(planes, boxes)
    want = []
    for box in boxes:
        inside = True
        for a, b, c, d in planes:
            x = box[3] if a >= 0 else box[0]
            y = box[4] if b >= 0 else box[1]
            z = box[5] if c >= 0 else box[2]
            inside &= a * x + b * y + c * z + d >= 0
        want.append(inside)
    np.testing.assert_array_equal(got, want)
    assert 20 < got.sum() < 480


@pytest.mark.gl
def test_simplified_tiles_stay_within_the_tolerance_and_draw_the_same_view(world, gl_ctx,
                                                                         mesh_on_samples):
    """The viewer's tiles drawn as bintree meshes of the view's spare error: fewer
    triangles; each mesh within the tolerance of the full-resolution heights, measured on
    every sample of its ground and seen from the nearest point of its box; the same frame
    as the whole tiles but for shading within a few levels, with no hole."""
    import zarr

    from terrascape.render.tiled_terrain import SIMPLIFY_STEPS, seeded_flight, stream_world
    from terrascape.viewer.session import ViewerSession
    from terrascape.world.chunked_lod import simplified_tile_triangles
    from terrascape.world.window import overview_window

    h = np.asarray(zarr.open_group(str(world), mode="r")["height"][...], dtype=np.float64)
    proxy = overview_window(world, budget=1 << 30, max_side=65).heightmap
    cam = seeded_flight(proxy, 30, seed=4, size=SIZE, crossing_s=3.0)[-1]
    geo = stream_world(gl_ctx, world, budget_bytes=64 << 20, tolerance=3.0, background=False,
                       simplify=True)
    s = ViewerSession(gl_ctx, proxy, size=SIZE, hud=False, technique="plain", geometry=geo,
                      moving_sun_shadows=False, warn=lambda m: None)
    fbo = gl_ctx.simple_framebuffer(SIZE)
    try:
        s.camera = cam
        frames, tris = _frames_for(s, fbo, (False, True),
                                   lambda simplify: setattr(geo, "simplify", simplify))
        kpx = cam.pixels_per_radian(SIZE[1])
        eye = cam.eye
        checked = 0
        for key in geo.drawn:
            tile = geo.cache.peek(key)
            if tile is None or tile.simplified is None:
                continue
            n = tile.shape[0]
            step = 1 << key.level
            r0, _, c0, _ = geo.grid.span(key)
            ground = h[r0:r0 + (n - 1) * step + 1, c0:c0 + (n - 1) * step + 1]
            z = ground[::step, ::step]
            mesh = simplified_tile_triangles(tile.errors, n,
                                             2.0 ** (tile.simplified.step / SIMPLIFY_STEPS))
            assert mesh.size == tile.simplified.count
            surface = mesh_on_samples(mesh, z, n, step)
            assert not np.isnan(surface).any()
            box = tile.box
            dist = float(np.linalg.norm(np.clip(eye, box[:3], box[3:]) - eye))
            assert np.abs(surface - ground).max() <= 3.0 * dist / kpx + 1e-4
            checked += 1
        assert checked >= 4
    finally:
        fbo.release()
        s.release()
    assert tris[True] < 0.8 * tris[False]
    diff = np.abs(frames[True] - frames[False])
    assert diff.mean() < 3.0 and np.percentile(diff, 99) < 60
    # no hole: every pixel the whole tiles cover, the simplified ones cover too
    sky = frames[False][0, 0]  # a corner of sky (the camera looks ahead and down)
    covered = np.any(np.abs(frames[False] - sky) > 12, axis=-1)
    holes = covered & ~np.any(np.abs(frames[True] - sky) > 12, axis=-1)
    assert holes.sum() <= 0.002 * covered.sum()
