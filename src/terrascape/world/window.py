"""What a camera needs of a world: the visible tiles, at the pyramid level it can resolve.

A world is far bigger than memory, so a render never loads it whole. For one camera:

1. every chunk's box — its extent × its ``bounds`` (min/max height, stored per chunk by the
   build) × the vertical exaggeration — is tested against the view frustum (the p-vertex
   test of Assarsson & Möller on the six planes of Gribb & Hartmann); chunks outside are
   never read;
2. for each visible chunk the nearest point of its box gives the world size of one pixel
   there, ``distance · 2·tan(fov/2) / image height``; the coarsest pyramid level whose
   sample spacing ``spacing · 2**k`` is at most ``detail`` pixels is what that chunk needs;
   the window uses the finest level any visible chunk needs;
3. the window (the bounding rectangle of the visible chunks, in that level's samples) is
   read from the store (zarr reads only the chunks it overlaps) — and when its estimated
   render peak exceeds the memory budget, the next coarser level is taken until it fits.
   Levels beyond the coarsest stored one are made on demand by taking every other sample
   of the coarsest (it already fits a chunk).

The result is an ordinary :class:`~terrascape.heightmap.Heightmap` plus the world position of
its sample ``[0, 0]``: any renderer draws it with the camera moved by that offset.

One level for the whole window is a simplification of a chunked LOD (CDLOD, Strugar 2010),
which would give each chunk its own level: near the camera the window is as fine as the
nearest chunk needs, so a low camera looking to the horizon reads far chunks finer than
necessary (and the budget may then push the whole window coarser). Terrain outside the
window casts no shadow into it.

References
----------
.. [1] Gribb, G., Hartmann, K. (2001). Fast extraction of viewing frustum planes from the
   world-view-projection matrix.
.. [2] Assarsson, U., Möller, T. (2000). Optimized view frustum culling algorithms for
   bounding boxes. Journal of Graphics Tools 5(1).
.. [3] Strugar, F. (2010). Continuous distance-dependent level of detail for rendering
   heightmaps. Journal of Graphics, GPU, and Game Tools 14(4).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from terrascape.camera import Camera, frame_landscape
from terrascape.errors import InvalidParameterError, MemoryLimitError
from terrascape.heightmap import Heightmap
from terrascape.memory import PEAK_BYTES_PER_SAMPLE, format_bytes, memory_limit
from terrascape.world.store import chunk_grid, open_world

#: Screen pixels one sample may cover at most (1: a sample per pixel at the nearest point).
DEFAULT_DETAIL = 1.0


@dataclass(frozen=True)
class WorldWindow:
    """The part of a world a camera needs, at one pyramid level."""

    heightmap: Heightmap
    #: World ``(x, z)`` of the window's sample ``[0, 0]``.
    offset: tuple[float, float]
    #: Pyramid level (0 = full resolution; sample spacing × 2**level).
    level: int
    #: Full-resolution sample rows ``r0:r1`` and columns ``c0:c1`` the window spans.
    rows: tuple[int, int]
    cols: tuple[int, int]
    #: Chunks in the frustum, of all chunks.
    visible_chunks: int
    total_chunks: int
    #: Level each visible chunk would need on its own (finest is the window's before the
    #: budget), for reporting.
    needed_level: int
    estimate_bytes: float

    def camera(self, camera: Camera) -> Camera:
        """``camera`` in the window's coordinates (moved by ``-offset``)."""
        return camera.moved((-self.offset[0], 0.0, -self.offset[1]))


def _chunk_boxes(group, recipe, exaggeration: float) -> np.ndarray:
    """``(n, 6)`` boxes ``x0, y0, z0, x1, y1, z1`` of every chunk, in chunk-grid order."""
    gr, gc = chunk_grid(recipe.shape, recipe.chunk)
    bounds = np.asarray(group["bounds"][...], dtype=np.float64)  # (gr, gc, 2)
    done = np.asarray(group["done/bounds"][...]).astype(bool)
    if not done.all():
        raise InvalidParameterError(
            "the world is not finished (its chunk bounds are missing): run `terrascape world "
            "build` again to complete it")
    dx = dz = recipe.spacing
    i, j = np.meshgrid(np.arange(gr), np.arange(gc), indexing="ij")
    c = recipe.chunk
    # A chunk spans samples [r0, r1 - 1]; its mesh reaches the next chunk's first sample.
    r0, r1 = i * c, np.minimum((i + 1) * c, recipe.rows - 1)
    c0, c1 = j * c, np.minimum((j + 1) * c, recipe.cols - 1)
    return np.stack([c0 * dx, bounds[..., 0] * exaggeration, r0 * dz,
                     c1 * dx, bounds[..., 1] * exaggeration, r1 * dz], axis=-1).reshape(-1, 6)


def _in_frustum(boxes: np.ndarray, camera: Camera) -> np.ndarray:
    planes = camera.frustum_planes()  # (6, 4), inward normals
    inside = np.ones(len(boxes), bool)
    for a, b, c, d in planes:
        # p-vertex: the box corner farthest along the plane normal
        px = np.where(a >= 0, boxes[:, 3], boxes[:, 0])
        py = np.where(b >= 0, boxes[:, 4], boxes[:, 1])
        pz = np.where(c >= 0, boxes[:, 5], boxes[:, 2])
        inside &= a * px + b * py + c * pz + d >= 0
    return inside


def _nearest_distance(boxes: np.ndarray, eye: np.ndarray) -> np.ndarray:
    nearest = np.clip(eye, boxes[:, :3], boxes[:, 3:])
    return np.linalg.norm(nearest - eye, axis=1)


def level_shape(shape: tuple[int, int], level: int) -> tuple[int, int]:
    """Shape of pyramid level ``level`` (every other sample, ``level`` times)."""
    rows, cols = shape
    for _ in range(level):
        rows, cols = (rows + 1) // 2, (cols + 1) // 2
    return rows, cols


def read_level(group, level: int, a0: int, a1: int, b0: int, b1: int) -> np.ndarray:
    """Samples ``[a0:a1, b0:b1]`` of pyramid ``level`` (0 = ``height``); levels beyond the
    stored ones are taken on demand from the coarsest stored level, every ``2**n``-th sample."""
    stored = int(group.attrs.get("levels", 0))
    if level <= stored:
        name = "height" if level == 0 else f"levels/{level}"
        return np.asarray(group[name][a0:a1, b0:b1])
    step = 1 << (level - stored)
    name = "height" if stored == 0 else f"levels/{stored}"
    return np.asarray(group[name][a0 * step:(a1 - 1) * step + 1:step,
                                  b0 * step:(b1 - 1) * step + 1:step])


def world_camera(path, size: tuple[int, int], *, exaggeration: float = 1.0,
                 azimuth: float = 180.0) -> Camera:
    """The landscape view that frames the whole world (as ``render``'s default camera frames
    a heightmap), from the chunk bounds and the coarsest level only."""
    group, recipe = open_world(path)
    boxes = _chunk_boxes(group, recipe, exaggeration)
    lo, hi = float(boxes[:, 1].min()), float(boxes[:, 4].max())
    from terrascape.render.offscreen import _near_edge_height

    k = int(group.attrs.get("levels", 0))
    lrows, lcols = level_shape(recipe.shape, k)
    coarse = read_level(group, k, 0, lrows, 0, lcols)
    step = recipe.spacing * (1 << k)
    edge = _near_edge_height(Heightmap(coarse, (step, step)), azimuth) * exaggeration
    extent = ((recipe.cols - 1) * recipe.spacing, (recipe.rows - 1) * recipe.spacing)
    return frame_landscape(extent, (lo, hi), azimuth=azimuth, aspect=size[0] / size[1],
                           edge_height=edge)


def camera_window(path, camera: Camera, size: tuple[int, int], *, exaggeration: float = 1.0,
                  detail: float = DEFAULT_DETAIL, budget: int | None = None,
                  per_sample: float | None = None) -> WorldWindow:
    """Read the part of the world at ``path`` that ``camera`` sees, at the level it needs.

    Parameters
    ----------
    camera
        In world coordinates (sample ``[0, 0]`` at x = z = 0).
    size
        ``(width, height)`` of the image in pixels.
    detail
        Pixels one sample may cover at the nearest visible point (larger: coarser).
    budget
        Bytes the render of the window may take at its peak (default: the process's
        ``--max-memory`` limit, :func:`terrascape.memory.memory_limit`).
    per_sample
        Peak bytes per window sample (default: the renderer's measured figure).

    Raises
    ------
    MemoryLimitError
        When even the coarsest level's window exceeds the budget.
    """
    if not (math.isfinite(detail) and detail > 0):
        raise InvalidParameterError(f"detail must be > 0 pixels, got {detail!r}")
    group, recipe = open_world(path)
    budget = memory_limit() if budget is None else int(budget)
    per_sample = PEAK_BYTES_PER_SAMPLE["render"] if per_sample is None else float(per_sample)
    boxes = _chunk_boxes(group, recipe, exaggeration)
    visible = _in_frustum(boxes, camera)
    total = len(boxes)
    gc = chunk_grid(recipe.shape, recipe.chunk)[1]
    if not visible.any():
        raise InvalidParameterError("the camera sees none of the world: point it at the terrain")
    idx = np.flatnonzero(visible)
    pixel = 2.0 * math.tan(math.radians(camera.fov_y) / 2.0) / size[1]
    dist = _nearest_distance(boxes[idx], camera.eye)
    # Coarsest level whose spacing is ≤ detail pixels at the chunk's nearest point.
    with np.errstate(divide="ignore"):
        ratio = dist * pixel * detail / recipe.spacing
        need = np.where(ratio > 1.0, np.floor(np.log2(np.maximum(ratio, 1.0))), 0.0)
    needed = int(need.min())
    ci, cj = idx // gc, idx % gc
    c = recipe.chunk
    r0, r1 = int(ci.min()) * c, min(int(ci.max() + 1) * c + 1, recipe.rows)
    c0, c1 = int(cj.min()) * c, min(int(cj.max() + 1) * c + 1, recipe.cols)
    max_level = max(0, math.ceil(math.log2(max(recipe.shape))) - 1)
    level = min(needed, max_level)
    while True:
        step = 1 << level
        lrows, lcols = level_shape(recipe.shape, level)
        a0, b0 = r0 // step, c0 // step
        a1, b1 = min(-(-(r1 - 1) // step) + 1, lrows), min(-(-(c1 - 1) // step) + 1, lcols)
        estimate = float(a1 - a0) * float(b1 - b0) * per_sample
        if estimate <= budget:
            break
        if level >= max_level or min(a1 - a0, b1 - b0) <= 2:
            raise MemoryLimitError(
                f"the world's visible part needs about {format_bytes(estimate)} to render even "
                f"at level {level} ({b1 - b0}×{a1 - a0} samples), over the limit of "
                f"{format_bytes(budget)}; raise --max-memory or look at less of it")
        level += 1
    heights = read_level(group, level, a0, a1, b0, b1)
    sp = recipe.spacing * step
    return WorldWindow(
        heightmap=Heightmap(heights, (sp, sp)),
        offset=(b0 * step * recipe.spacing, a0 * step * recipe.spacing),
        level=level, rows=(a0 * step, min((a1 - 1) * step + 1, recipe.rows)),
        cols=(b0 * step, min((b1 - 1) * step + 1, recipe.cols)),
        visible_chunks=int(visible.sum()), total_chunks=total, needed_level=needed,
        estimate_bytes=estimate)


def overview_window(path, *, budget: int | None = None, per_sample: float | None = None,
                    max_side: int = 4097) -> WorldWindow:
    """The whole world at the finest pyramid level whose render fits ``budget`` and whose
    side is at most ``max_side`` samples (the interactive viewer's terrain)."""
    group, recipe = open_world(path)
    budget = memory_limit() if budget is None else int(budget)
    per_sample = PEAK_BYTES_PER_SAMPLE["render"] if per_sample is None else float(per_sample)
    level = 0
    while True:
        lrows, lcols = level_shape(recipe.shape, level)
        estimate = float(lrows) * float(lcols) * per_sample
        if estimate <= budget and max(lrows, lcols) <= max_side:
            break
        if min(lrows, lcols) <= 2:
            raise MemoryLimitError(
                f"even the world's coarsest level needs about {format_bytes(estimate)}, over "
                f"the limit of {format_bytes(budget)}")
        level += 1
    step = 1 << level
    sp = recipe.spacing * step
    total = int(np.prod(chunk_grid(recipe.shape, recipe.chunk)))
    return WorldWindow(
        heightmap=Heightmap(read_level(group, level, 0, lrows, 0, lcols), (sp, sp)),
        offset=(0.0, 0.0), level=level, rows=(0, recipe.rows), cols=(0, recipe.cols),
        visible_chunks=total, total_chunks=total, needed_level=level, estimate_bytes=estimate)


__all__ = ["DEFAULT_DETAIL", "WorldWindow", "camera_window", "level_shape", "overview_window",
           "read_level", "world_camera"]
