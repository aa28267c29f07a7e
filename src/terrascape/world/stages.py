"""The per-chunk work of a world build: each function makes one chunk of one array.

Every stage reads what it needs from the store (the chunk plus a halo from the previous
stage), runs the ordinary in-memory terrascape function on that window and crops the chunk.
The halos make every chunk equal, bit for bit, to the same window of the whole-map result:

* generator — no halo: the tileable noise takes the absolute ``origin`` of the chunk.
* grid erosion (virtual pipes) — ``3 · iterations``: one step reads three samples each
  side (flux, water/velocity, transport): exact, as for thermal erosion.
* droplet erosion — a droplet's reach (steps + brush + 1), with core-only starts, run in
  four phases of non-overlapping windows: exact against the untiled run of the same
  droplets in phase order (:mod:`terrascape.world.droplets`).
* thermal erosion — ``2 · iterations``: one Jacobi iteration reads the neighbours' outflow
  factors, which read *their* neighbours, so information travels two samples per iteration;
  samples beyond that reach cannot change the chunk. At the map border the window ends where
  the map ends, so the closed boundary is the same.
* normals — two samples: central differences reach one, and the second-order one-sided
  stencils of the map border reach two inward (a 1-sample last chunk needs both).
* shadow — toward the sun, the number of ray steps after which a ray starting at the lowest
  sample has climbed above the highest one (``(h_max - h_min) / rise``), plus two samples
  across the ray lines: nothing farther can occlude.
* bounds — the min and max of the chunk's heights: no halo.
* pyramid levels — every other sample of the previous level: no halo.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import zarr

from terrascape.heightmap import Heightmap
from terrascape.world.recipe import erosion_halo

#: Samples on every side of a shadow window beyond the sun-side reach (interpolation lines).
SHADOW_MARGIN = 2


def chunk_bounds(shape: tuple[int, int], chunk: int, i: int, j: int) -> tuple[int, int, int, int]:
    """Rows ``r0:r1`` and columns ``c0:c1`` of chunk ``(i, j)``."""
    r0, c0 = i * chunk, j * chunk
    return r0, min(shape[0], r0 + chunk), c0, min(shape[1], c0 + chunk)


def _window(shape, bounds, halo):
    """The padded window ``(a0, a1, b0, b1)`` for halos ``(up, down, left, right)``."""
    r0, r1, c0, c1 = bounds
    up, down, left, right = halo
    return (max(0, r0 - up), min(shape[0], r1 + down), max(0, c0 - left),
            min(shape[1], c1 + right))


def shadow_halo(recipe, h_min: float, h_max: float) -> tuple[int, int, int, int]:
    """``(up, down, left, right)`` samples of terrain that can shade a chunk."""
    from terrascape.lighting._common import sun_above_horizon
    from terrascape.lighting.shadows import _NEAR, _sweep_geometry

    light = sun_above_horizon(recipe.shadow["azimuth"], recipe.shadow["elevation"])
    geo = _sweep_geometry(Heightmap(np.zeros((2, 2), np.float32),
                                    (recipe.spacing, recipe.spacing)), light)
    m = SHADOW_MARGIN
    if geo is None:
        return (m, m, m, m)
    transpose, da, db, rise = geo
    # After `steps` steps a ray from the lowest sample is above the highest one; the window
    # also holds each sample's first _NEAR steps (walked exactly by the sweep).
    steps = max(math.ceil((h_max - h_min) / rise) + 1, _NEAR) if rise > 0 else 1 << 40
    major = [m, m]  # (toward -axis, toward +axis) of the sweep's axis 0
    minor = [m, m]
    major[1 if da > 0 else 0] += steps
    if db != 0.0:
        minor[1 if db > 0 else 0] += math.ceil(steps * abs(db))
    if transpose:
        return (minor[0], minor[1], major[0], major[1])
    return (major[0], major[1], minor[0], minor[1])


def _height_window(group, name, shape, bounds, halo):
    a0, a1, b0, b1 = _window(shape, bounds, halo)
    return np.asarray(group[name][a0:a1, b0:b1]), (bounds[0] - a0, bounds[2] - b0)


def _eroded_chunk(group, recipe, shape, bounds) -> np.ndarray:
    """Chunk ``bounds`` of the heights after ``[erosion]``."""
    r0, r1, c0, c1 = bounds
    e = recipe.erosion
    halo = erosion_halo(e)
    if e["model"] == "grid":
        from terrascape.filters.virtual_pipe_erosion import virtual_pipe_erosion

        win, (oz, ox) = _height_window(group, "height_raw", shape, bounds, (halo,) * 4)
        out = virtual_pipe_erosion(
            Heightmap(win, (recipe.spacing, recipe.spacing)), iterations=e["iterations"],
            rain=e["rain"], capacity=e["capacity"], min_tilt=e["min_tilt"],
            max_depth=e["max_depth"], dissolving=e["dissolving"], deposition=e["deposition"],
            evaporation=e["evaporation"])
        return out.heightmap.heights[oz:oz + r1 - r0, ox:ox + c1 - c0]
    from terrascape.world.droplets import eroded_chunk

    return eroded_chunk(group, recipe, r0, r1, c0, c1)


def _one_codec_thread() -> None:
    # zarr makes its thread pool on first use, with the size configured then; in a worker
    # process the first use is a task's, so this sets it before it exists. (Not in the
    # user's own process, when the workers are its threads.)
    import multiprocessing

    if (multiprocessing.parent_process() is not None
            and zarr.config.get("threading.max_workers") != 1):
        zarr.config.set({"threading.max_workers": 1})


def make_chunk(path: str, recipe, stage: str, i: int, j: int, extra: dict) -> int:
    """Compute chunk ``(i, j)`` of ``stage``, write it, then mark it done; returns 1.

    The done marker is written after the data, so a build killed in between redoes the
    chunk. One worker thread is one core: numba's own threads are limited to one, and so is
    zarr's pool of codec threads (else one worker decodes a window's chunks on every core,
    and a node's workers oversubscribe it).
    """
    numba.set_num_threads(1)
    _one_codec_thread()
    group = zarr.open_group(path, mode="r+")
    shape = recipe.shape
    sp = (recipe.spacing, recipe.spacing)
    if stage.startswith("levels/"):
        level = int(stage.split("/")[1])
        src = "height" if level == 1 else f"levels/{level - 1}"
        lshape = group[stage].shape
        r0, r1, c0, c1 = chunk_bounds(lshape, recipe.chunk, i, j)
        data = np.asarray(group[src][2 * r0:2 * r1:2, 2 * c0:2 * c1:2])
        group[stage][r0:r1, c0:c1] = data
        group[f"done/{stage}"][i, j] = 1
        return 1
    bounds = chunk_bounds(shape, recipe.chunk, i, j)
    r0, r1, c0, c1 = bounds
    if stage == "bounds":
        heights = np.asarray(group["height"][r0:r1, c0:c1])
        group[stage][i, j, :] = np.array([heights.min(), heights.max()], np.float32)
        group[f"done/{stage}"][i, j] = 1
        return 1
    erosion_output = ("height_eroded" if recipe.thermal is not None else "height")
    if stage == "droplet_window":
        from terrascape.world.droplets import run_chunk

        run_chunk(group, recipe, i, j)
        group[f"done/{stage}"][i, j] = 1
        return 1
    if stage == erosion_output and recipe.erosion is not None:
        data = _eroded_chunk(group, recipe, shape, bounds)
    elif stage in ("height_raw", "height") and (stage == "height_raw" or (
            recipe.thermal is None and recipe.erosion is None)):
        from terrascape.generate import noise

        fn = noise.fbm if recipe.generator == "fbm" else noise.ridged
        # The generators need 2 samples per side; a last chunk of 1 sample takes the first
        # of 2 (the noise depends only on the absolute position, so it is the same value).
        hm = fn((max(2, r1 - r0), max(2, c1 - c0)), amplitude=recipe.relief, seed=recipe.seed,
                spacing=sp, origin=(c0, r0), **recipe.params)
        data = hm.heights[:r1 - r0, :c1 - c0]
    elif stage == "height":
        from terrascape.filters.thermal_erosion import thermal_erosion

        reach = 2 * recipe.thermal["iterations"]
        source = "height_raw" if recipe.erosion is None else "height_eroded"
        win, (oz, ox) = _height_window(group, source, shape, bounds, (reach,) * 4)
        out = thermal_erosion(Heightmap(win, sp), iterations=recipe.thermal["iterations"],
                              talus_angle=recipe.thermal["talus"], rate=recipe.thermal["rate"])
        data = out.heights[oz:oz + r1 - r0, ox:ox + c1 - c0]
    elif stage == "normals":
        from terrascape.lighting.normals import normal_map

        win, (oz, ox) = _height_window(group, "height", shape, bounds, (2, 2, 2, 2))
        n = normal_map(Heightmap(win, sp), height_scale=recipe.normals["height_scale"])
        group[stage][r0:r1, c0:c1, :] = n[oz:oz + r1 - r0, ox:ox + c1 - c0]
        group[f"done/{stage}"][i, j] = 1
        return 1
    elif stage == "shadow":
        from terrascape.lighting.shadows import shadow_mask

        win, (oz, ox) = _height_window(group, "height", shape, bounds, extra["shadow_halo"])
        # origin: the window's ray lines are the whole map's, so decisions match it exactly.
        mask = shadow_mask(Heightmap(win, sp), recipe.shadow["azimuth"],
                           recipe.shadow["elevation"], origin=(c0 - ox, r0 - oz))
        data = mask[oz:oz + r1 - r0, ox:ox + c1 - c0].astype(np.uint8)
    else:  # pragma: no cover - stages come from build.py
        raise ValueError(stage)
    group[stage][r0:r1, c0:c1] = data
    group[f"done/{stage}"][i, j] = 1
    return 1


__all__ = ["chunk_bounds", "make_chunk", "shadow_halo"]
