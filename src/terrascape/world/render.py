"""Render a world straight from its store: only the window the camera needs
(:func:`terrascape.world.window.camera_window`), drawn by the ordinary offscreen renderer."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from terrascape.camera import Camera
from terrascape.world.store import open_world
from terrascape.world.window import DEFAULT_DETAIL, WorldWindow, camera_window, world_camera


def world_haze(path) -> float:
    """The renderer's automatic haze for the whole world (optical depth 0.2 over its
    diagonal), so a window is hazed as the world it belongs to, not as a small map."""
    group, recipe = open_world(path)
    bounds = np.asarray(group["bounds"][...])
    ex, ez = (recipe.cols - 1) * recipe.spacing, (recipe.rows - 1) * recipe.spacing
    relief = float(bounds[..., 1].max() - bounds[..., 0].min())
    return 0.2 / math.sqrt(ex * ex + ez * ez + relief * relief)


def render_world(path, camera: Camera | None = None, *, size: tuple[int, int] = (1280, 720),
                 technique: str = "material", params: dict[str, Any] | None = None,
                 exaggeration: float = 1.0, quality: str = "default",
                 detail: float = DEFAULT_DETAIL, budget: int | None = None,
                 ctx=None) -> tuple[np.ndarray, WorldWindow]:
    """One frame of the world at ``path`` as ``uint8 (h, w, 4)`` and the window it read.

    ``camera`` is in world coordinates (default :func:`world_camera`, the landscape view of
    the whole world); ``budget`` bounds the render's estimated peak memory (bytes).
    """
    from terrascape.render.offscreen import OffscreenRenderer, _context

    cam = world_camera(path, size, exaggeration=exaggeration) if camera is None else camera
    cam = replace(cam, aspect=size[0] / size[1])
    window = camera_window(path, cam, size, exaggeration=exaggeration, detail=detail,
                           budget=budget)
    p = dict(params or {})
    if p.get("haze") is None:
        p["haze"] = world_haze(path)
    with _context(ctx) as own:
        renderer = OffscreenRenderer(own, window.heightmap, size=size,
                                     exaggeration=exaggeration, quality=quality)
        try:
            image = renderer.render(window.camera(cam), technique, p)
        finally:
            renderer.release()
    return image, window


__all__ = ["render_world", "world_haze"]
