"""Render a world straight from its store, a pyramid level per tile: the chunked LOD
(:mod:`terrascape.world.chunked_lod`) picks every visible tile's level from its error bound
and the camera, within the memory budget, and the ordinary offscreen renderer draws the
tiles over an overview of the world (its textures, shadows, sky and water)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from terrascape.camera import Camera
from terrascape.memory import memory_limit
from terrascape.world.store import open_world
from terrascape.world.window import world_camera


def world_haze(path) -> float:
    """The renderer's automatic haze for the whole world (optical depth 0.2 over its
    diagonal), so a window is hazed as the world it belongs to, not as a small map."""
    group, recipe = open_world(path)
    bounds = np.asarray(group["bounds"][...])
    ex, ez = (recipe.cols - 1) * recipe.spacing, (recipe.rows - 1) * recipe.spacing
    relief = float(bounds[..., 1].max() - bounds[..., 0].min())
    return 0.2 / math.sqrt(ex * ex + ez * ez + relief * relief)


@dataclass(frozen=True)
class WorldFrame:
    """What a world render drew."""

    #: Pyramid level and shape of the overview the textures, shadows and sky come from.
    proxy_level: int
    proxy_shape: tuple[int, int]
    #: Visible tiles per pyramid level, and all tiles of the world's finest level.
    levels: dict[int, int]
    tiles: int
    #: Largest screen-space error of a drawn tile (pixels) and whether the memory budget,
    #: not the tolerance, set it.
    max_pixels: float
    budget_bound: bool
    #: Bytes of the tiles' buffers, the overview's estimated peak, and the budget.
    tile_bytes: int
    proxy_bytes: float
    budget: int

    def summary(self) -> str:
        per = ", ".join(f"{n} at level {k}" for k, n in self.levels.items())
        return (f"{self.tiles} tiles ({per}), largest error {self.max_pixels:.2f} px"
                + (" (memory bound)" if self.budget_bound else "")
                + f"; overview level {self.proxy_level} "
                f"({self.proxy_shape[1]}×{self.proxy_shape[0]})")


def render_world(path, camera: Camera | None = None, *, size: tuple[int, int] = (1280, 720),
                 technique: str = "material", params: dict[str, Any] | None = None,
                 exaggeration: float = 1.0, quality: str = "default",
                 tolerance: float | None = None, budget: int | None = None,
                 tile: int | None = None, ctx=None) -> tuple[np.ndarray, WorldFrame]:
    """One frame of the world at ``path`` as ``uint8 (h, w, 4)`` and what it drew.

    ``camera`` is in world coordinates (default :func:`world_camera`, the landscape view of
    the whole world); ``tolerance`` is the largest screen error of a tile in pixels
    (default :data:`~terrascape.render.tiled_terrain.RENDER_TOLERANCE`); ``budget`` bounds
    the overview's estimated peak plus the tiles' buffers (bytes; default ``--max-memory``).
    """
    from terrascape.render.context import current
    from terrascape.render.offscreen import OffscreenRenderer, _context
    from terrascape.render.tiled_terrain import RENDER_TOLERANCE, split_budget, stream_world

    budget = memory_limit() if budget is None else int(budget)
    tolerance = RENDER_TOLERANCE if tolerance is None else float(tolerance)
    cam = world_camera(path, size, exaggeration=exaggeration) if camera is None else camera
    cam = replace(cam, aspect=size[0] / size[1])
    proxy, share = split_budget(path, budget)
    p = dict(params or {})
    if p.get("haze") is None:
        p["haze"] = world_haze(path)
    with _context(ctx) as own, current(own):
        renderer = OffscreenRenderer(own, proxy.heightmap, size=size,
                                     exaggeration=exaggeration, quality=quality)
        geometry = None
        try:
            geometry = stream_world(own, path, budget_bytes=share.tile_bytes,
                                    reader_bytes=share.reader_bytes, tolerance=tolerance,
                                    exaggeration=exaggeration, background=False, tile=tile)
            renderer.terrain.geometry = geometry
            geometry.update(cam, renderer._draw_size)
            image = renderer.render(cam, technique, p)
            sel = geometry.selection
            frame = WorldFrame(
                proxy_level=proxy.level, proxy_shape=proxy.heightmap.shape,
                levels=sel.levels(), tiles=len(sel.visible), max_pixels=sel.max_pixels,
                budget_bound=sel.budget_bound, tile_bytes=geometry.cache.peak_bytes,
                proxy_bytes=share.proxy_bytes, budget=budget)
        finally:
            renderer.terrain.geometry = None
            if geometry is not None:
                geometry.release()
            renderer.release()
    return image, frame


__all__ = ["WorldFrame", "render_world", "world_haze"]
