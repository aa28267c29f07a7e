"""A world's terrain drawn by streamed tiles (:mod:`terrascape.world.chunked_lod`): the GPU
side — tile buffers in a bounded least-recently-used cache, uploaded a few per frame from
the background loader, drawn with the frame's technique program.

:class:`TiledGeometry` replaces the mesh of a :class:`~terrascape.render.terrain.
TerrainRenderer` (set ``renderer.geometry``): the renderer keeps a small overview of the
world (the "proxy" heightmap) for its textures, shadows, sky and water — all sampled by
world position — while the tiles give the surface its detail, each at the pyramid level
its screen-space error allows. The frame never waits for a load: a tile not yet uploaded
is drawn by its finest loaded ancestor (:func:`~terrascape.world.chunked_lod.draw_set`),
and the roots are loaded before the first frame.
"""

from __future__ import annotations

import gc
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from terrascape.camera import Camera
from terrascape.errors import MemoryLimitError
from terrascape.memory import format_bytes
from terrascape.render.context import flush_commands
from terrascape.world.chunked_lod import (
    EDGE_STEPS,
    ProcessTileLoader,
    StoreReader,
    TileCache,
    TileKey,
    TileLoader,
    TileMesh,
    TilePyramid,
    TileSelection,
    draw_set,
    select_tiles,
    simplifiable,
    simplified_tile_triangles,
    skirt_edges,
    tile_bintree_errors,
    tile_indices,
    tile_mesh,
    world_pyramid,
)

#: Screen error (pixels) of the streaming viewer and of a world render. llvmpipe draws the
#: viewer's frame at a cost about proportional to its triangles, and 3 px needs about half
#: the tiles of 1.5 px with the same look but for fine shading detail in the nearest tiles
#: (figures: docs/benchmarks.md, "Streaming viewer").
VIEW_TOLERANCE = 3.0
RENDER_TOLERANCE = 0.5
#: Vertex bytes a streamed frame uploads at most (at least one tile): about 40 full 32² tiles.
UPLOAD_BYTES = 2 << 20
#: Parts a frame's tiles are handed to the rasteriser in (TiledGeometry.submit_parts).
SUBMIT_PARTS = 2
#: Steps per doubling of a simplified tile's error budget: a tile's mesh is made again only
#: when its budget crosses a step (rounded down, so the bound always holds).
SIMPLIFY_STEPS = 4
#: Simplified tile meshes made in a frame at most (each a bintree walk and an index
#: upload): the rest wait for the next frames, drawn whole or by their finer mesh meanwhile.
SIMPLIFY_PER_FRAME = 48


@dataclass
class _Simplified:
    """A tile's bintree mesh for this view: its own index buffer (the skirts, then the
    triangles), the triangles' index count and the error step it was made for."""

    ibo: Any
    step: int = -(1 << 30)
    count: int = 0
    vaos: dict[int, Any] = field(default_factory=dict)
    #: within this view's budget (a coarser step than the budget's waits, drawn whole)
    usable: bool = True

    def release(self) -> None:
        for vao in self.vaos.values():
            vao.release()
        self.vaos.clear()
        self.ibo.release()


@dataclass
class _GpuTile:
    key: TileKey
    buffers: list[Any]
    shape: tuple[int, int]
    nbytes: int
    box: np.ndarray
    vaos: dict[int, Any] = field(default_factory=dict)
    #: the bintree errors of its vertices (tile_bintree_errors); None: always drawn whole
    errors: np.ndarray | None = None
    #: its bound e_k against the bintree interpolant (world units, exaggerated)
    error_bintree: float = 0.0
    simplified: _Simplified | None = None

    def release_simplified(self) -> None:
        if self.simplified is not None:
            self.simplified.release()
            self.simplified = None

    def release(self) -> None:
        self.release_simplified()
        for vao in self.vaos.values():
            vao.release()
        self.vaos.clear()
        for buf in self.buffers:
            buf.release()
        self.buffers = []


def _in_frustum(planes: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Which of ``boxes`` (``(n, 6)``: min xyz, max xyz) reach inside every plane (``(6, 4)``,
    inward normals): the corner furthest along each plane's normal is not behind it."""
    normals = planes[:, :3]
    far = np.where(normals >= 0, boxes[:, None, 3:], boxes[:, None, :3])  # (n, planes, 3)
    return np.all(np.einsum("pj,npj->np", normals, far) + planes[:, 3] >= 0, axis=1)


class TiledGeometry:
    """Streamed tiles as a terrain renderer's geometry.

    Parameters
    ----------
    ctx
        moderngl context (the renderer's).
    pyramid
        The world's :class:`~terrascape.world.chunked_lod.TilePyramid`.
    build
        Makes one tile's mesh (:func:`~terrascape.world.chunked_lod.tile_mesh` over the
        store); called on the loader thread when ``background``.
    budget_bytes
        Bytes the tile buffers may hold (the cache's bound). The view selects at most half
        as many tiles as fit, so a frame's tiles and the parents drawn while they load fit
        together.
    tolerance
        Screen-space error of a tile (pixels).
    background
        Load on a thread and never wait (the viewer); False: :meth:`update` loads every
        selected tile before returning (a still render).
    upload_ms, upload_bytes
        Time and vertex bytes per frame for uploading finished tiles, whichever runs out
        first (at least one tile a frame is uploaded); the rest wait in the loader, so a
        burst of finished tiles is spread over the next frames.
    loader
        What builds the tiles in the background (default: a
        :class:`~terrascape.world.chunked_lod.TileLoader` thread over ``build``;
        :func:`stream_world` uses a :class:`~terrascape.world.chunked_lod.ProcessTileLoader`).
        The geometry closes it.
    simplify
        Draw each tile as the coarsest bintree mesh of its samples that the view's error
        allows (:meth:`_simplify`) instead of its whole grid. A tile is drawn at the first
        level whose error projects within ``tolerance`` at its nearest point, so its own
        error often uses half of it or less; the rest lets its mesh leave out the vertices
        the view cannot tell from their neighbours' plane. Needs the pyramid's
        :attr:`~terrascape.world.chunked_lod.TilePyramid.error_bintree`; the attribute
        ``simplify`` switches it off and on between frames.
    """

    def __init__(self, ctx, pyramid: TilePyramid, build: Callable[[TileKey], TileMesh], *,
                 budget_bytes: int, tolerance: float = VIEW_TOLERANCE, exaggeration: float = 1.0,
                 background: bool = True, upload_ms: float = 4.0,
                 upload_bytes: int = UPLOAD_BYTES, loader=None, simplify: bool = False) -> None:
        self.ctx = ctx
        self.pyramid = pyramid
        self.grid = pyramid.grid
        self.tolerance = float(tolerance)
        self.exaggeration = float(exaggeration)
        self.upload_ms = float(upload_ms)
        self.upload_bytes = int(upload_bytes)
        self._every_skirt = False
        #: Draw the tiles nearest first (False: in the quadtree's order).
        self.sort_tiles = True
        #: The frame's tiles go to the rasteriser in this many parts, each flushed when
        #: drawn (:func:`~terrascape.render.context.flush_commands`): the nearest tiles
        #: are rasterised while the vertices of the farther ones are shaded (1: one part).
        self.submit_parts = SUBMIT_PARTS
        # tiles get their bintree errors as they arrive; ``simplify`` may be switched off
        # (and on again) between frames
        self._bintree = bool(simplify) and pyramid.error_bintree is not None
        self.simplify = self._bintree
        if self._bintree:
            # numba compiles (or loads from its cache) the meshing kernels now, not in the
            # middle of the first frames that simplify a tile (a 0.3 s frame when compiled)
            simplified_tile_triangles(tile_bintree_errors(np.zeros((3, 3))), 3, 0.0)
        self._skirts: dict[tuple[int, int], np.ndarray] = {}
        self._simplified_tiles: dict[TileKey, _GpuTile] = {}
        self._build = build
        self.cache = TileCache(int(budget_bytes), size_of=lambda t: t.nbytes,
                               release=lambda t: t.release())
        per_tile = self.grid.max_tile_bytes()
        roots = self.grid.roots()
        if len(roots) * per_tile > budget_bytes:
            raise MemoryLimitError(
                f"the world's {len(roots)} coarsest tiles need "
                f"{format_bytes(len(roots) * per_tile)}, over the tile budget of "
                f"{format_bytes(budget_bytes)}; raise --max-memory")
        self.max_tiles = max(len(roots), int(budget_bytes // (2 * per_tile)))
        self._ibos: dict[tuple[int, int], tuple[Any, int]] = {}
        # what draw() needs of the drawn tiles, made once per change of them: (tiles, their
        # boxes, each one's skirt runs)
        self._plan: tuple[list, np.ndarray, list] | None = None
        self._drawn: list[TileKey] = []
        self.selection: TileSelection | None = None
        self._view: tuple | None = None  # the camera the selection was made for
        self.uploaded = 0
        self.last_update_ms = 0.0
        #: The last update's share: selecting the tiles, and taking in finished ones.
        self.last_select_ms = 0.0
        self.last_upload_ms = 0.0
        self.last_uploads = 0
        self.last_upload_bytes = 0
        for key in roots:  # something to draw from the first frame on
            self._upload(build(key), pinned=set(roots))
        if loader is not None:
            self.loader = loader
        else:
            self.loader = TileLoader(build) if background else None

    @property
    def drawn(self) -> list[TileKey]:
        """The tiles the frame draws, nearest first (set by :meth:`update`)."""
        return self._drawn

    @drawn.setter
    def drawn(self, tiles: list[TileKey]) -> None:
        if tiles != self._drawn:
            self._plan = None
        self._drawn = tiles

    @property
    def every_skirt(self) -> bool:
        """Skirts on every tile edge (False: not between drawn tiles of one level)."""
        return self._every_skirt

    @every_skirt.setter
    def every_skirt(self, value: bool) -> None:
        self._every_skirt = bool(value)
        self._plan = None

    # --- streaming ---------------------------------------------------------------------
    def _ibo(self, shape: tuple[int, int]) -> tuple[Any, int, list[tuple[int, int]]]:
        """The index buffer of a tile shape (:func:`~terrascape.world.chunked_lod.
        tile_indices`), the grid's indices, and each edge's skirt ``(first, count)``."""
        have = self._ibos.get(shape)
        if have is None:
            idx = tile_indices(shape)
            n = 6 * (shape[0] - 1) * (shape[1] - 1)
            edges = [(n + first, count) for first, count in skirt_edges(shape)]
            have = self._ibos[shape] = (self.ctx.buffer(idx.tobytes()), n, edges)
        return have

    def _upload(self, mesh: TileMesh, *, pinned) -> bool:
        if mesh.key in self.cache:  # loaded twice (asked again while on its way)
            return True
        bufs = [self.ctx.buffer(np.ascontiguousarray(a).tobytes())
                for a in (mesh.positions, mesh.normals, mesh.tangents)]
        tile = _GpuTile(mesh.key, bufs, mesh.shape, mesh.nbytes,
                        self.pyramid.box(mesh.key, self.exaggeration))
        if self._bintree and simplifiable(mesh.shape):
            n_r, n_c = mesh.shape
            if mesh.bintree_errors is not None:  # made by the loader (rounded up)
                tile.errors = mesh.bintree_errors
            else:  # of the drawn heights (exaggerated): world units, like the budget
                tile.errors = tile_bintree_errors(
                    mesh.positions[:n_r * n_c, 1].reshape(n_r, n_c))
            k, i, j = mesh.key
            tile.error_bintree = float(self.pyramid.error_bintree[k][i, j]) * self.exaggeration
        ok = self.cache.put(mesh.key, tile, pinned=pinned)
        self._plan = None  # (the tiles the plan holds may have changed)
        self.uploaded += ok
        return ok

    def update(self, camera: Camera, viewport: tuple[int, int]) -> dict[str, Any]:
        """Select the tiles of this view, take in the loaded ones (within ``upload_ms``, or
        all of them when not streaming) and decide what the frame draws."""
        t0 = time.perf_counter()
        view = (camera.position, camera.yaw, camera.pitch, camera.fov_y, camera.aspect,
                camera.near, camera.far, tuple(viewport))
        self.last_select_ms = 0.0
        if view != self._view or self.selection is None:
            self.selection = select_tiles(self.pyramid, camera, viewport,
                                          tolerance=self.tolerance, max_tiles=self.max_tiles,
                                          exaggeration=self.exaggeration)
            self._view = view
            self.last_select_ms = (time.perf_counter() - t0) * 1000.0
        sel = self.selection
        keep = set(self.drawn) | {k for k in sel.visible if k in self.cache}
        keep.update(self.grid.roots())
        missing = [k for k in sel.visible if k not in self.cache]
        if missing and self.loader is not None:
            # the missing tiles' ancestors first, coarse to fine: a missing tile is then
            # drawn by its parent, not by a root over the whole map (a draw set never
            # overlaps, so one tile without a loaded parent sends its whole group up)
            order = {k: n for n, k in enumerate(missing)}
            parents: dict[TileKey, int] = {}
            for key in missing:
                p = self.grid.parent(key)
                while p is not None and p not in self.cache and p not in parents:
                    parents[p] = order[key]
                    p = self.grid.parent(p)
            first = sorted(parents, key=lambda k: (-k.level, parents[k]))
            room = self.cache.max_bytes // self.grid.max_tile_bytes() - len(self.cache)
            if len(first) + len(missing) <= room:
                # (a cache too small for both would evict the parents for the children
                # and reload them for the next child: the selection alone, then)
                missing = first + missing
        t_up, before, taken = time.perf_counter(), self.uploaded, 0
        if self.loader is None:
            for key in missing:
                if not self._upload(self._build(key), pinned=keep | {key}):
                    raise MemoryLimitError("the view's tiles do not fit the tile budget")
                keep.add(key)
        else:
            self.loader.request(missing)
            deadline = time.perf_counter() + self.upload_ms / 1000.0  # after the selection
            while True:
                got = self.loader.finished(1)
                if not got:
                    break
                # late arrivals of an earlier view are still kept while there is room
                if self._upload(got[0], pinned=keep):
                    keep.add(got[0].key)
                taken += got[0].nbytes
                if (time.perf_counter() > deadline
                        or taken + self.grid.max_tile_bytes() > self.upload_bytes):
                    break  # the rest waits in the loader for the next frame
        self.last_upload_ms = (time.perf_counter() - t_up) * 1000.0
        self.last_uploads = self.uploaded - before
        self.last_upload_bytes = taken
        drawn = draw_set(self.grid, sel.visible, self.cache.__contains__)
        eye = camera.eye
        boxes = {key: self.cache.get(key).box for key in drawn}  # and most recently used
        dist = {k: float(np.linalg.norm(np.clip(eye, boxes[k][:3], boxes[k][3:]) - eye))
                for k in drawn}
        if self.sort_tiles:
            # front to back (the draw set follows the quadtree): the nearer tiles' depth
            # hides the further ones' fragments before they are shaded
            drawn.sort(key=dist.__getitem__)
        if self._bintree:
            self._simplify(drawn, dist, camera.pixels_per_radian(int(viewport[1])))
        self.drawn = drawn
        self.last_update_ms = (time.perf_counter() - t0) * 1000.0
        return self.stats()

    def _simplify(self, drawn: list[TileKey], dist: dict[TileKey, float],
                  kpx: float) -> None:
        """Give each drawn tile the coarsest bintree mesh its share of the view's error
        allows: ``tolerance`` pixels at its nearest point (``dist`` away, ``kpx`` pixels per
        radian) less its own bound ``e_k`` against the bintree interpolant
        (:attr:`~terrascape.world.chunked_lod.TilePyramid.error_bintree`), rounded down to a
        step of :data:`SIMPLIFY_STEPS` per doubling. The mesh is within that budget of the
        interpolant, so ``|h_0 − mesh| ≤ e_k + budget``: within the tolerance, seen from no
        nearer than that point. A tile whose bound leaves no budget is drawn whole (its grid,
        within the selection's own bound). Tiles that left the draw set give their index
        buffers back."""
        keep = set(drawn)
        for key, tile in list(self._simplified_tiles.items()):
            if key not in keep or self.cache.peek(key) is not tile:
                tile.release_simplified()
                del self._simplified_tiles[key]
        if not self.simplify:  # switched off: drawn whole, the meshes kept while drawn
            return
        # (no mesh or one coarser than the budget allows, tile, step): those drawn whole
        # first, nearest first; then those that may be coarser
        todo = []
        for key in drawn:
            tile = self.cache.peek(key)
            if tile is None or tile.errors is None:
                continue
            budget = self.tolerance * dist[key] / kpx - tile.error_bintree
            if not budget > 0.0 or math.isinf(budget):
                tile.release_simplified()
                self._simplified_tiles.pop(key, None)
                continue
            step = math.floor(SIMPLIFY_STEPS * math.log2(budget))
            simple = tile.simplified
            if simple is not None:
                simple.usable = simple.step <= step
                if simple.step == step:
                    continue
            todo.append((simple is not None and simple.usable, dist[key], key, tile, step))
        todo.sort(key=lambda item: item[:2])
        for _, _, key, tile, step in todo[:SIMPLIFY_PER_FRAME]:
            simple = tile.simplified
            tris = simplified_tile_triangles(tile.errors, tile.shape[0],
                                             2.0 ** (step / SIMPLIFY_STEPS))
            skirts = self._skirt_indices(tile.shape)
            if simple is None:
                grid = 6 * (tile.shape[0] - 1) * (tile.shape[1] - 1)
                simple = tile.simplified = _Simplified(
                    self.ctx.buffer(reserve=4 * (skirts.size + grid)))
                self._simplified_tiles[key] = tile
            simple.ibo.write(skirts.tobytes() + tris.tobytes())  # both uint32
            simple.step = step
            simple.count = tris.size
            simple.usable = True

    def _skirt_indices(self, shape: tuple[int, int]) -> np.ndarray:
        """The skirt part of :func:`~terrascape.world.chunked_lod.tile_indices` (each edge's
        at its :func:`~terrascape.world.chunked_lod.skirt_edges` offset from 0)."""
        have = self._skirts.get(shape)
        if have is None:
            grid = 6 * (shape[0] - 1) * (shape[1] - 1)
            have = self._skirts[shape] = tile_indices(shape)[grid:].copy()
        return have

    def stats(self) -> dict[str, Any]:
        sel = self.selection
        waiting = 0 if self.loader is None else self.loader.pending()
        return {"tiles_selected": 0 if sel is None else len(sel.visible),
                "tiles_drawn": len(self.drawn), "tiles_loading": waiting,
                "tiles_resident": len(self.cache), "tile_bytes": self.cache.bytes,
                "tile_bytes_peak": self.cache.peak_bytes, "tiles_uploaded": self.uploaded,
                "max_pixels": 0.0 if sel is None else sel.max_pixels,
                "complete": sel is not None and len(self.drawn) == len(sel.visible)
                and set(self.drawn) == set(sel.visible)}

    def loading(self) -> bool:
        """Whether selected tiles are still on their way."""
        return not self.stats()["complete"]

    # --- drawing -----------------------------------------------------------------------
    def _draw_plan(self) -> tuple[list, np.ndarray, list]:
        """The drawn tiles, their boxes and, for each, the runs ``(first, count)`` of its
        skirt indices to draw: the skirts of the edges not shared with a drawn tile of the
        same level, neighbouring edges in one run."""
        if self._plan is not None:
            return self._plan
        neighbours = frozenset(self.drawn)
        tiles, boxes, runs = [], [], []
        for key in self.drawn:
            tile = self.cache.get(key)
            if tile is None:
                continue
            _, _, edges = self._ibo(tile.shape)
            own: list[tuple[int, int]] = []
            run_first = run_count = 0
            for (first, size), (di, dj) in zip(edges, EDGE_STEPS, strict=True):
                if (not self.every_skirt
                        and TileKey(key.level, key.row + di, key.col + dj) in neighbours):
                    if run_count:
                        own.append((run_first, run_count))
                    run_count = 0
                    continue
                if not run_count:
                    run_first = first
                run_count += size
            if run_count:
                own.append((run_first, run_count))
            tiles.append(tile)
            boxes.append(tile.box)
            runs.append(own)
        box_array = np.array(boxes, dtype=np.float64).reshape(-1, 6)
        self._plan = (tiles, box_array, runs)
        return self._plan

    def draw(self, program, camera: Camera, viewport) -> dict[str, int]:
        """Draw the frame's tiles with ``program`` (called by the terrain renderer for every
        geometry pass: forward, geometry buffer, wireframe)."""
        import moderngl

        tiles, boxes, runs = self._draw_plan()
        visible = _in_frustum(camera.frustum_planes(), boxes) if len(tiles) else []
        tris = drawn = 0
        part = -(-len(self.drawn) // max(1, self.submit_parts))
        for i, (tile, inside, own) in enumerate(zip(tiles, visible, runs, strict=True)):
            if i and i % part == 0:  # front to back
                flush_commands()
            if not inside:
                continue
            ibo, grid_count, _ = self._ibo(tile.shape)
            simple = tile.simplified if self.simplify else None
            if simple is not None and simple.usable:
                # its own buffer: the skirts from 0 (the shared one's after the grid),
                # then the bintree mesh
                vaos, ibo, shift = simple.vaos, simple.ibo, -grid_count
                first, count = self._skirt_indices(tile.shape).size, simple.count
            else:
                vaos, first, count, shift = tile.vaos, 0, grid_count, 0
            vao = vaos.get(program.glo)
            if vao is None:
                pos, nor, tan = tile.buffers
                vao = vaos[program.glo] = self.ctx.vertex_array(
                    program, [(pos, "3f", "in_position"), (nor, "3f", "in_normal"),
                              (tan, "4f", "in_tangent")], ibo, 4, skip_errors=True)
            vao.render(moderngl.TRIANGLES, vertices=count, first=first)
            n = count
            for run_first, size in own:
                vao.render(moderngl.TRIANGLES, vertices=size, first=run_first + shift)
                n += size
            tris += n // 3
            drawn += 1
        return {"triangles": tris, "triangles_drawn": tris, "chunks": drawn,
                "chunks_culled": len(self.drawn) - drawn, "chunks_small_cull": 0}

    def release(self) -> None:
        if self.loader is not None:
            self.loader.close()
            self.loader = None
        self._plan = None
        self.cache.clear()
        for ibo, _, _ in self._ibos.values():
            ibo.release()
        self._ibos.clear()


@dataclass(frozen=True)
class WorldBudget:
    """How a memory budget is shared by the overview (proxy) terrain and the tiles."""

    proxy_level: int
    proxy_bytes: float
    reader_bytes: int
    tile_bytes: int


def split_budget(path, budget: int, *, proxy_side: int = 1025) -> tuple[Any, WorldBudget]:
    """The overview window of the world (at most ``proxy_side`` samples a side and half the
    budget) and the bytes left for the tiles and the store reader's chunk cache."""
    from terrascape.world.window import overview_window

    win = overview_window(path, budget=budget // 2, max_side=proxy_side)
    rest = budget - win.estimate_bytes
    reader = int(min(64 << 20, max(rest // 4, 0)))
    tiles = int(rest - reader)
    return win, WorldBudget(win.level, win.estimate_bytes, reader, tiles)


def stream_world(ctx, path, *, budget_bytes: int, reader_bytes: int = 64 << 20,
                 tolerance: float = VIEW_TOLERANCE, exaggeration: float = 1.0,
                 background: bool = True, tile: int | None = None,
                 pyramid: TilePyramid | None = None,
                 simplify: bool | None = None) -> TiledGeometry:
    """:class:`TiledGeometry` over the world store at ``path`` (its tile table ``pyramid``,
    by default built or read from the store's cache). ``simplify`` (default: when
    streaming in the background, the viewer's case; a still render draws every tile
    whole): each tile drawn as the coarsest bintree mesh the view's error allows."""
    from terrascape.world.chunked_lod import DEFAULT_TILE

    if budget_bytes <= 0:
        raise MemoryLimitError("no memory is left for the world's tiles; raise --max-memory")
    # streaming, this process reads only the roots: the loader process has the chunk cache
    reader = StoreReader(path, cache_bytes=(8 << 20) if background else reader_bytes)
    if pyramid is None:
        pyramid = world_pyramid(path, tile=tile or DEFAULT_TILE, reader=reader)

    def build(key: TileKey) -> TileMesh:
        return tile_mesh(reader, pyramid, key, exaggeration=exaggeration)

    loader = None
    if background:
        # the loader process has its own chunk cache: this process's is only for the roots
        loader = ProcessTileLoader(path, tile=pyramid.grid.tile, exaggeration=exaggeration,
                                   reader_bytes=reader_bytes)
    try:
        return TiledGeometry(ctx, pyramid, build, budget_bytes=budget_bytes,
                             tolerance=tolerance, exaggeration=exaggeration,
                             background=background, loader=loader,
                             simplify=background if simplify is None else simplify)
    except BaseException:
        if loader is not None:
            loader.close()
        raise


def freeze_heap() -> None:
    """Collect once and move every object made so far (modules, programs, the tile table)
    out of the garbage collector's reach (:func:`gc.freeze`), before a streamed flight.

    Each frame's selection makes and drops thousands of small objects, so the collector
    runs often, and now and then a full collection walked every object of the process
    inside a frame: the worst frames of a flight. Frozen, a full collection walks only what
    the flight made."""
    gc.collect()
    gc.freeze()


def seeded_flight(heightmap, n_frames: int, *, seed: int = 0, size=(1280, 720),
                  fps: float = 30.0, crossing_s: float = 20.0,
                  height: float = 0.03) -> list[Camera]:
    """A reproducible low flight over a terrain (an overview heightmap of the world): from
    a random point, heading inward, turning smoothly, ``height`` × the extent above the
    ground, looking ahead and slightly down; crossing the terrain in ``crossing_s``.
    The same seed gives the same cameras."""
    from terrascape.viewer.session import ground_height

    rng = np.random.default_rng(seed)
    ex, ez = heightmap.extent
    diag = float(np.hypot(ex, ez))
    speed = diag / crossing_s / fps  # world units per frame
    x, z = ex * rng.uniform(0.15, 0.35), ez * rng.uniform(0.15, 0.35)
    yaw = float(np.degrees(np.arctan2(ex / 2 - x, -(ez / 2 - z))))  # toward the centre
    turn = rng.normal(0.0, 0.6, size=n_frames)  # degrees per frame, smoothed below
    turn = np.convolve(turn, np.ones(15) / 15.0, mode="same")
    cams = []
    lift = height * diag
    for k in range(n_frames):
        ground = ground_height(heightmap.heights, heightmap.spacing, x, z)
        cams.append(Camera(position=(x, ground + lift, z), yaw=yaw, pitch=-12.0, fov_y=60.0,
                           aspect=size[0] / size[1], near=diag * 2e-4, far=diag * 5.0))
        yaw += float(turn[k])
        f = np.radians(yaw)
        x += speed * float(np.sin(f))
        z -= speed * float(np.cos(f))
        if not (0.05 * ex < x < 0.95 * ex and 0.05 * ez < z < 0.95 * ez):
            yaw += 180.0  # at the edge: turn back
            x = float(np.clip(x, 0.05 * ex, 0.95 * ex))
            z = float(np.clip(z, 0.05 * ez, 0.95 * ez))
    return cams


__all__ = ["RENDER_TOLERANCE", "UPLOAD_BYTES", "VIEW_TOLERANCE", "TiledGeometry", "WorldBudget",
           "freeze_heap", "seeded_flight", "split_budget", "stream_world"]
