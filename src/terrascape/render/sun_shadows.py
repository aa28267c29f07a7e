"""Terrain shadows that follow a moving sun without stalling the frames.

The exact soft shadow of a 1025² terrain (:func:`~terrascape.lighting.shadows.soft_shadow`,
6 sweeps over the sun's disc) takes about a second on two cores — one frozen frame each
time the sun moves. :class:`MovingSunShadows` splits the work:

* **While the sun moves** each new sun position gets a *coarse* shadow map right away: the
  same sweep on the terrain subsampled to at most ``coarse_side`` samples a side (a 16th of
  the work for 1025² → 257²) with 2 slices of the disc, drawn bilinearly — soft, but where
  the shadows are.
* **Once the sun holds still** the exact map is computed in a separate worker process (its
  own numba thread pool, so the frames keep running on the main one) and replaces the
  coarse map as soon as it is ready, if the sun is still there. Starting that process
  takes seconds (a new interpreter importing numba), so a thread starts it when the sun
  first moves; until it is up, the coarse maps are all there is. The first map (the first
  frame) is the exact one, computed at once.

Each frame therefore costs at most one coarse sweep; the exact map arrives without a stall.
"""

from __future__ import annotations

import math
import multiprocessing
import threading
from concurrent.futures import Future, ProcessPoolExecutor

import numpy as np

from terrascape.heightmap import Heightmap
from terrascape.lighting.shadows import soft_shadow

_WORKER_MAP: Heightmap | None = None


def _init_worker(heights: np.ndarray, spacing: tuple[float, float]) -> None:
    global _WORKER_MAP
    _WORKER_MAP = Heightmap(heights, spacing)


def _exact_job(az: float, el: float, radius: float, samples: int) -> np.ndarray:
    vis = soft_shadow(_WORKER_MAP, az, el, sun_radius_deg=radius, samples=samples)
    # the visibility takes samples + 1 values: exact as bytes, a quarter of the transfer
    return np.rint(vis * samples).astype(np.uint8)


def coarse_soft_shadow(world: Heightmap, az: float, el: float, *, max_side: int = 257,
                       sun_radius_deg: float = 0.5, samples: int = 2) -> np.ndarray:
    """:func:`soft_shadow` on the terrain subsampled to at most ``max_side`` samples a side
    (every ``step``-th sample, the spacing ``step`` times larger): float32 at that size."""
    step = max(1, math.ceil((max(world.shape) - 1) / (max_side - 1)))
    if step == 1:
        small = world
    else:
        dx, dz = world.spacing
        small = Heightmap(np.ascontiguousarray(world.heights[::step, ::step]),
                          (dx * step, dz * step))
    return soft_shadow(small, az, el, sun_radius_deg=sun_radius_deg, samples=samples)


class MovingSunShadows:
    """Sun visibility maps for a sun that moves (module docstring).

    Parameters
    ----------
    world
        The terrain as drawn (heights × exaggeration).
    sun_radius_deg, samples
        Of the exact map (as :func:`~terrascape.lighting.shadows.soft_shadow`).
    coarse_side, coarse_samples
        Of the maps drawn while the sun moves.
    background
        Compute the exact map in a worker process (False: in this process, blocking — the
        old behaviour, for comparisons).
    """

    def __init__(self, world: Heightmap, *, sun_radius_deg: float = 0.5, samples: int = 6,
                 coarse_side: int = 257, coarse_samples: int = 2,
                 background: bool = True) -> None:
        self.world = world
        self.radius = float(sun_radius_deg)
        self.samples = int(samples)
        self.coarse_side = int(coarse_side)
        self.coarse_samples = int(coarse_samples)
        self.background = bool(background)
        self._pool: ProcessPoolExecutor | None = None
        self._job: tuple[tuple[float, float], Future] | None = None
        self._exact: tuple[tuple[float, float], np.ndarray] | None = None
        self._coarse: tuple[tuple[float, float], np.ndarray] | None = None
        self._last: tuple[float, float] | None = None
        self.exact_updates = 0
        self.coarse_updates = 0
        self._ready = threading.Event()
        self._closed = False
        self._starting = False

    def start_worker(self) -> None:
        """Start the worker process (in a thread; :meth:`visibility` does it when the sun
        first moves, so a viewer that never moves the sun never starts one)."""
        if self.background and not self._starting:
            self._starting = True
            threading.Thread(target=self._start_pool, daemon=True,
                             name="terrascape-shadow-pool").start()

    def _start_pool(self) -> None:
        try:
            ctx = multiprocessing.get_context("spawn")  # no forked numba thread pools
            pool = ProcessPoolExecutor(
                1, mp_context=ctx, initializer=_init_worker,
                initargs=(np.ascontiguousarray(self.world.heights), self.world.spacing))
            # the first job starts the process and loads the compiled kernels there
            pool.submit(_exact_job, 0.0, 45.0, self.radius, 1).result()
        except Exception:  # no worker process: shadows computed here when the sun stops
            self.background = False
            return
        if self._closed:  # closed while the process was starting
            pool.shutdown(wait=False, cancel_futures=True)
            return
        self._pool = pool
        self._ready.set()

    def _submit(self, key: tuple[float, float]) -> None:
        self._job = (key, self._pool.submit(_exact_job, *key, self.radius, self.samples))

    def visibility(self, azimuth: float, elevation: float) -> tuple[tuple, np.ndarray]:
        """``(key, float32 map)`` for the sun at (azimuth, elevation): the exact map if it is
        ready for this sun, else a coarse one (computed now, kept while the sun stays). The
        key changes exactly when the map does."""
        key = (round(float(azimuth), 5), round(float(elevation), 5))
        if self._exact is not None and self._exact[0] == key:
            return ("exact", key), self._exact[1]
        if self._job is not None and self._job[1].done():
            job_key, fut = self._job
            self._job = None
            try:
                vis = fut.result().astype(np.float32) / np.float32(self.samples)
            except Exception:  # a broken worker: fall back to computing here
                self.background = False
            else:
                self._exact = (job_key, vis)
                self.exact_updates += 1
                if job_key == key:
                    return ("exact", key), vis
        first = self._last is None
        still = key == self._last
        self._last = key
        if first:
            # the first frame waits for the exact map, as a renderer without this would
            vis = soft_shadow(self.world, *key, sun_radius_deg=self.radius,
                              samples=self.samples)
            self._exact = (key, vis)
            self.exact_updates += 1
            return ("exact", key), vis
        self.start_worker()
        if not self.background and still:
            vis = soft_shadow(self.world, *key, sun_radius_deg=self.radius,
                              samples=self.samples)
            self._exact = (key, vis)
            self.exact_updates += 1
            return ("exact", key), vis
        if self.background and still and self._job is None and self._ready.is_set():
            self._submit(key)
        if self._coarse is None or self._coarse[0] != key:
            self._coarse = (key, coarse_soft_shadow(
                self.world, *key, max_side=self.coarse_side, sun_radius_deg=self.radius,
                samples=self.coarse_samples))
            self.coarse_updates += 1
        return ("coarse", key), self._coarse[1]

    def wait_ready(self, timeout: float | None = None) -> bool:
        """Start the worker and wait until it is up (tests, benchmarks); False on timeout."""
        self.start_worker()
        return self._ready.wait(timeout)

    def close(self) -> None:
        self._closed = True
        if self._pool is not None:
            self._pool.shutdown(wait=False, cancel_futures=True)
            self._pool = None


__all__ = ["MovingSunShadows", "coarse_soft_shadow"]
