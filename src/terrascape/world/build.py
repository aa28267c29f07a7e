"""Build a world chunk by chunk on a dask.distributed cluster, resumably, into zarr.

Each array of the store is built by one task per chunk (:func:`~terrascape.world.stages.
make_chunk`) submitted to a :class:`distributed.Client`: a :class:`distributed.LocalCluster`
by default, or any running scheduler (``scheduler="tcp://host:8786"``, e.g. one started by
dask-jobqueue or dask-kubernetes). Arrays are built in dependency order (raw heights,
eroded heights, then normals, shadow and the pyramid levels); within one array every chunk
is independent. A chunk's ``done`` marker is written after its data, so a build that is
killed and run again skips the finished chunks and gives the same bytes.
"""

from __future__ import annotations

import contextlib
import logging
import os
import shutil
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from terrascape.errors import EnvironmentFailure, InvalidParameterError
from terrascape.world.droplets import PHASES, phase
from terrascape.world.recipe import Recipe
from terrascape.world.stages import make_chunk, shadow_halo
from terrascape.world.store import array_specs, create_or_resume, task_grid

#: Seconds to wait for a scheduler given by address before giving up.
CONNECT_TIMEOUT = 5.0


@dataclass
class BuildResult:
    """What one :func:`build_world` call did."""

    path: Path
    written: int = 0
    skipped: int = 0
    complete: bool = False
    seconds: float = 0.0
    stage_seconds: dict[str, float] = field(default_factory=dict)
    #: ``name -> (start, stop)`` of each stage, ``time.time()`` seconds (to match a dask
    #: task stream's times to the stages).
    stage_times: dict[str, tuple[float, float]] = field(default_factory=dict)
    height_range: tuple[float, float] | None = None


def _any_chunk_done(group, recipe: Recipe) -> bool:
    """True when a chunk of any array is done, or when the store cannot tell (then it is
    kept)."""
    try:
        return any(np.asarray(group[f"done/{name}"][...]).any() for name in array_specs(recipe))
    except Exception:
        return True


@contextlib.contextmanager
def connect(scheduler: str = "local", *, workers: int = 2, memory_limit: str | None = "2GB",
            processes: bool = True, timeout: float = CONNECT_TIMEOUT) -> Iterator[object]:
    """A :class:`distributed.Client`: a new LocalCluster (``"local"``) or the scheduler at
    ``scheduler`` (``tcp://host:port``); an address that does not answer within ``timeout``
    seconds is an :class:`~terrascape.errors.EnvironmentFailure`, not a hang.

    ``memory_limit`` bounds each worker *process*. Workers that are threads of this process
    (``processes=False``) get none: dask would measure the whole process against each
    thread's limit and, once the process holds 80 % of it for any reason (a notebook's
    arrays, a viewer), pause every worker, and the build would wait for ever."""
    from distributed import Client, LocalCluster

    if scheduler == "local":
        if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
            raise InvalidParameterError(f"--workers must be a whole number ≥ 1, got {workers!r}")
        if memory_limit is not None:
            from dask.utils import parse_bytes

            try:
                parse_bytes(memory_limit)
            except (ValueError, TypeError):
                raise InvalidParameterError(
                    f"--memory-limit must be a size like 2GB or 512MiB, got {memory_limit!r}"
                ) from None
        import dask

        # The workers' statistical profiler samples the running task every 10 ms: a few
        # per cent of a core per worker that a build does not need.
        with dask.config.set({"distributed.worker.profile.enabled": False}):
            # silence_logs: the workers' warnings (a task cancelled while the cluster
            # closes after Ctrl-C, memory use) are not the user's to read; errors reach the
            # caller as exceptions
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1,
                                   processes=processes, silence_logs=logging.ERROR,
                                   memory_limit=memory_limit if processes else None,
                                   dashboard_address=":0")
        try:
            with Client(cluster) as client:
                yield client
        finally:
            cluster.close()
        return
    try:
        client = Client(scheduler, timeout=timeout)
    except (OSError, TimeoutError, ValueError) as exc:
        raise EnvironmentFailure(
            f"no dask scheduler answers at {scheduler} within {timeout:g} s ({exc})") from None
    with client:
        yield client


def _height_range(path: str) -> tuple[float, float]:
    """The world's lowest and highest height, from the per-chunk bounds."""
    import zarr

    bounds = np.asarray(zarr.open_group(path, mode="r")["bounds"][...])
    return float(bounds[..., 0].min()), float(bounds[..., 1].max())


def build_world(
    recipe: Recipe,
    path: str | Path,
    *,
    client=None,
    scheduler: str = "local",
    workers: int = 2,
    memory_limit: str | None = "2GB",
    processes: bool = True,
    force: bool = False,
    quiet: bool = True,
    max_chunks: int | None = None,
) -> BuildResult:
    """Build (or continue building) the world of ``recipe`` at ``path``.

    Parameters
    ----------
    client
        A :class:`distributed.Client` to use; otherwise one is made from ``scheduler``,
        ``workers``, ``memory_limit`` and ``processes`` (:func:`connect`).
    force
        Replace a store made by another recipe (or anything else at ``path``).
    quiet
        No progress bar.
    max_chunks
        Stop after writing this many chunks (the build is then incomplete and a later call
        continues it) — for tests of resumption and for building in slices.

    Returns
    -------
    BuildResult
    """
    path = Path(path)
    new_store = not os.path.lexists(path)
    group = create_or_resume(path, recipe, force=force)
    if client is None:
        try:
            with connect(scheduler, workers=workers, memory_limit=memory_limit,
                         processes=processes) as own:
                return build_world(recipe, path, client=own, quiet=quiet,
                                   max_chunks=max_chunks)
        except BaseException:
            # a store this call made and no chunk reached (the scheduler did not answer, a
            # signal while the cluster started) is not kept: there is nothing to resume
            if new_store and not _any_chunk_done(group, recipe):
                shutil.rmtree(path, ignore_errors=True)
            raise
    from distributed import progress

    result = BuildResult(path)
    start = time.perf_counter()
    budget = max_chunks
    url = str(path)
    for name in array_specs(recipe):
        done = np.asarray(group[f"done/{name}"][...])
        grid = task_grid(name, recipe)
        pending = [(i, j) for i in range(grid[0]) for j in range(grid[1]) if not done[i, j]]
        result.skipped += len(done.nonzero()[0])
        if not pending:
            continue
        extra: dict = {}
        if name == "shadow":
            result.height_range = _height_range(url)
            extra["shadow_halo"] = shadow_halo(recipe, *result.height_range)
        if name == "droplet_window":  # phase order: a stopped build has finished the earlier phases
            pending.sort(key=lambda c: phase(*c))
        if budget is not None:
            pending = pending[:budget]
        t0, wall0 = time.perf_counter(), time.time()
        # Droplet chunks run in four phases (each needs the earlier ones finished); every
        # other stage is one batch of independent chunks.
        batches = ([[c for c in pending if phase(*c) == p] for p in range(PHASES)]
                   if name == "droplet_window" else [pending])
        for batch in batches:
            futures = client.map(make_chunk, [url] * len(batch), [recipe] * len(batch),
                                 [name] * len(batch), [i for i, _ in batch],
                                 [j for _, j in batch], [extra] * len(batch), pure=False)
            if not quiet:
                print(f"{name}: {len(batch)} chunks")
                progress(futures)
                print()
            result.written += sum(client.gather(futures))
        result.stage_seconds[name] = time.perf_counter() - t0
        result.stage_times[name] = (wall0, time.time())
        if budget is not None:
            budget -= len(pending)
            if budget <= 0 and name != list(array_specs(recipe))[-1]:
                break
    complete = all(np.asarray(group[f"done/{n}"][...]).all() for n in array_specs(recipe))
    group.attrs["complete"] = complete
    result.complete = complete
    result.seconds = time.perf_counter() - start
    return result


__all__ = ["CONNECT_TIMEOUT", "BuildResult", "build_world", "connect"]
