"""Benchmark: world builds on a dask cluster (``terrascape bench world``).

Builds one world recipe (fBm, 4 thermal iterations, normals, shadow, pyramid) into a zarr
store on LocalClusters of 1, 2, 2 and 1 single-threaded worker processes (interleaved, so a
changing machine load weighs on both sides; two such rounds in ``--quick``, the median
ratio counts) (each worker also limits numba and zarr's codecs to one thread: one worker =
one core). Besides the measured speed-up it prints the speed-up the build's own task times
allow on two free cores (:func:`schedule_speedup`), which the machine's load does not
change. Reports wall time per stage, samples/s
per worker, the speed-up of 2 workers over 1 (target ≥ 1.7×), the peak resident memory per
worker (target ≤ 1.5 GB, the worker's ``ru_maxrss``), and checks every stored array against
the whole-map in-memory function bit for bit. A small warm-up world on the same cluster
loads the numba kernels first, so compile/cache time is not counted.

Sizes: 8193² in chunks of 1024 (full); 2049² in chunks of 512 (quick).
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from terrascape.bench import BenchTable

SPEEDUP_TARGET = 1.7
#: Workers of the builds, in run order (interleaved, A B B A per round).
ORDER = (1, 2, 2, 1)
#: Rounds of ORDER (full, quick): the speed-up is the median over rounds.
ROUNDS = (1, 2)
MEMORY_TARGET_GB = 1.5


def bench_recipe(side: int, chunk: int) -> dict:
    return {"size": [side, side], "spacing": 2.0, "seed": 11, "chunk": chunk,
            "generator": {"name": "fbm", "relief": 0.05 * (side - 1) * 2.0,
                          "scale": (side - 1) / 8},
            "thermal": {"iterations": 4, "talus": 30.0},
            "normals": {"height_scale": 1.0},
            "shadow": {"azimuth": 100.0, "elevation": 35.0}}


def _peak_rss() -> int:
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def _cpu_seconds() -> float:
    import resource

    use = resource.getrusage(resource.RUSAGE_SELF)
    return use.ru_utime + use.ru_stime


def _build(recipe, workers: int, folder: Path):
    """Build on a new cluster; returns the result, the peak RSS of the largest worker, the
    CPU seconds the workers spent on the build (all workers) and the seconds each task
    computed, per stage, in the order they started."""
    from distributed import get_task_stream

    from terrascape.world import build_world, connect, recipe_from_dict

    with connect("local", workers=workers, processes=True, memory_limit="2GB") as client:
        warm = recipe_from_dict({**recipe.to_dict(), "size": [300, 300], "chunk": 128})
        build_world(warm, folder / f"warm{workers}.zarr", client=client)
        before = client.run(_cpu_seconds)
        with get_task_stream(client) as stream:
            result = build_world(recipe, folder / f"world{workers}.zarr", client=client)
        after = client.run(_cpu_seconds)
        peaks = client.run(_peak_rss)
    cpu = sum(after[w] - before[w] for w in after)
    return result, max(peaks.values()), cpu, _task_seconds(stream.data, result.stage_times)


def _task_seconds(stream: list[dict], stage_times: dict) -> dict[str, list[float]]:
    """``stage -> [compute seconds of each task]`` from a dask task stream."""
    tasks = []
    for record in stream:
        for ss in record.get("startstops", ()):
            if ss.get("action") == "compute":
                tasks.append((ss["start"], ss["stop"] - ss["start"]))
    out: dict[str, list[float]] = {name: [] for name in stage_times}
    for start, seconds in sorted(tasks):
        for name, (t0, t1) in stage_times.items():
            if t0 - 0.5 <= start <= t1:
                out[name].append(seconds)
                break
    return out


def schedule_speedup(task_seconds: dict[str, list[float]], serial_overhead: float,
                     workers: int = 2) -> float:
    """The speed-up ``workers`` workers give over one for these tasks, if every task took
    as long as it did on one worker: each stage's tasks go in order to the first free worker
    (as dask hands them out) and a stage starts when the one before it has finished; the
    time outside the tasks (scheduling, the client's work between stages) stays serial.

    The load of a shared machine stretches every task of a build about alike, so this ratio
    — of one build's own task times — is what the structure of the build (task sizes, their
    number per stage, the barriers) allows on free cores, whatever that load."""
    import heapq

    one = serial_overhead + sum(sum(t) for t in task_seconds.values())
    many = serial_overhead
    for seconds in task_seconds.values():
        free = [0.0] * workers
        for t in seconds:
            heapq.heappush(free, heapq.heappop(free) + t)
        many += max(free)
    return one / many


def _equality(recipe, path: Path) -> list[list]:
    import zarr

    from terrascape.filters.thermal_erosion import thermal_erosion
    from terrascape.generate.noise import fbm
    from terrascape.heightmap import Heightmap
    from terrascape.lighting.normals import normal_map
    from terrascape.lighting.shadows import shadow_mask

    group = zarr.open_group(str(path), mode="r")
    sp = (recipe.spacing, recipe.spacing)
    rows = []
    raw = fbm(recipe.shape, amplitude=recipe.relief, seed=recipe.seed, spacing=sp,
              **recipe.params)
    t = recipe.thermal
    eroded = thermal_erosion(raw, iterations=t["iterations"], talus_angle=t["talus"],
                             rate=t["rate"])
    hm = Heightmap(eroded.heights, sp)
    whole = {"height_raw": raw.heights, "height": eroded.heights,
             "normals": normal_map(hm, height_scale=recipe.normals["height_scale"])}
    del raw
    whole["shadow"] = shadow_mask(hm, recipe.shadow["azimuth"],
                                  recipe.shadow["elevation"]).astype(np.uint8)
    for name, expected in whole.items():
        got = np.asarray(group[name][...])
        differ = int(np.count_nonzero(got != expected))
        rows.append([name, "yes" if differ == 0 else "NO", differ])
    return rows


def stream_power_seams(side: int = 513, chunk: int = 128, halos=(32, 128)) -> BenchTable:
    """Why stream power is not a world stage: the same map eroded whole and in halo tiles
    (each tile's window eroded alone, its core kept), and how far the tiles are off."""
    from terrascape.filters.stream_power_erosion import stream_power_erosion
    from terrascape.generate.noise import fbm

    raw = fbm((side, side), amplitude=0.1 * side, seed=3, scale=side / 4)
    whole = stream_power_erosion(raw).heightmap.heights.astype(np.float64)
    cut = np.abs(whole - raw.heights).mean()
    rows, cols = np.indices(raw.shape)
    seam = np.minimum(np.minimum(rows % chunk, chunk - 1 - rows % chunk),
                      np.minimum(cols % chunk, chunk - 1 - cols % chunk)) < 8
    table = BenchTable(
        f"stream power {side}², whole map vs tiles of {chunk} with halos (not a world stage)",
        ["halo", "mean |error|", "max |error|", "mean |error| ≤ 8 from a seam",
         "mean |error| elsewhere", "mean incision (whole map)"])
    for halo in halos:
        tiled = np.empty_like(whole)
        for r0 in range(0, side, chunk):
            for c0 in range(0, side, chunk):
                r1, c1 = min(side, r0 + chunk), min(side, c0 + chunk)
                a0, b0 = max(0, r0 - halo), max(0, c0 - halo)
                a1, b1 = min(side, r1 + halo), min(side, c1 + halo)
                win = raw.with_heights(raw.heights[a0:a1, b0:b1])
                out = stream_power_erosion(win).heightmap.heights
                tiled[r0:r1, c0:c1] = out[r0 - a0:r1 - a0, c0 - b0:c1 - b0]
        err = np.abs(tiled - whole)
        table.rows.append([halo, round(float(err.mean()), 3), round(float(err.max()), 2),
                           round(float(err[seam].mean()), 3), round(float(err[~seam].mean()), 3),
                           round(float(cut), 3)])
    table.notes.append(
        "a wider halo lowers the mean error but not the largest one (a main river whose "
        "basin is cut by the window): drainage area is counted over the whole basin, a "
        "window's edge is a base level its rivers cut down to, and the solver's strength is "
        "per map width — an exact tiled stream power needs a global pass over the tiles' "
        "outlets (not done)")
    return table


def run(quick: bool = False) -> list[BenchTable]:
    side, chunk = (2049, 512) if quick else (8193, 1024)
    rounds = ROUNDS[1] if quick else ROUNDS[0]
    return [*speedup(side, chunk, rounds),
            stream_power_seams(257 if quick else 513, 64 if quick else 128)]


def speedup(side: int, chunk: int, rounds: int = 1) -> list[BenchTable]:
    """Builds of the benchmark recipe at ``side``² in chunks of ``chunk`` on 1, 2, 2, 1
    workers, ``rounds`` times, and the check of one store against the whole-map functions:
    ``python -m terrascape.bench.world speedup 4097 1024 3``."""
    from terrascape.world import recipe_from_dict

    recipe = recipe_from_dict(bench_recipe(side, chunk))
    samples = recipe.rows * recipe.cols
    table = BenchTable(
        f"world build {side}² (chunk {chunk}; fBm, thermal ×4, normals, shadow, pyramid)",
        ["workers", "wall s", "height_raw s", "height s", "normals s", "shadow s",
         "levels s", "samples/s per worker", "samples per CPU-s", "speed-up",
         "workers busy", "cores used", "peak GB per worker", "load avg"])
    check = BenchTable(f"world {side}² stored arrays vs whole-map functions",
                       ["array", "bit-for-bit equal", "samples differing"])
    runs = []
    order = ORDER * rounds
    keep = order.index(2)
    with tempfile.TemporaryDirectory(prefix="bench-world-") as tmp:
        folder = Path(tmp)
        # Interleaved A B B A (1, 2, 2, 1 workers) per round: a load that rises or falls
        # steadily during a round weighs on both sides alike, so each round's ratio of sums
        # is fair; the median over rounds drops a round a burst of load fell on.
        for k, workers in enumerate(order):
            load = os.getloadavg()[0]
            run_dir = folder / f"run{k}"
            run_dir.mkdir()
            result, peak, cpu, tasks = _build(recipe, workers, run_dir)
            runs.append((workers, result, peak, cpu, load, tasks))
            if k != keep:  # keep one 2-worker store for the check below
                shutil.rmtree(run_dir)
        per_round = []
        for r in range(rounds):
            part = runs[r * len(ORDER):(r + 1) * len(ORDER)]
            total = {w: sum(x[1].seconds for x in part if x[0] == w) for w in (1, 2)}
            per_round.append(total[1] / total[2])
        speedup = float(np.median(per_round))
        base = float(np.mean([x[1].seconds for x in runs if x[0] == 1]))
        bounds = []
        for workers, result, peak, cpu, load, tasks in runs:
            st = result.stage_seconds
            levels = sum(v for k, v in st.items() if k.startswith("levels/"))
            busy = sum(sum(t) for t in tasks.values())
            if workers == 1:
                bounds.append(schedule_speedup(tasks, max(0.0, result.seconds - busy)))
            table.rows.append([
                workers, round(result.seconds, 2), round(st.get("height_raw", 0.0), 2),
                round(st.get("height", 0.0), 2), round(st.get("normals", 0.0), 2),
                round(st.get("shadow", 0.0), 2), round(levels, 2),
                round(samples / result.seconds / workers), round(samples / cpu),
                round(base / result.seconds, 2),
                round(busy / (result.seconds * workers), 3), round(cpu / result.seconds, 2),
                round(peak / 1e9, 3), round(load, 1)])
        store = folder / f"run{keep}" / "world2.zarr"
        check.rows = _equality(recipe, store)
        store_bytes = sum(p.stat().st_size for p in store.rglob("*") if p.is_file())
    table.check_target("speed-up 2 workers vs 1", speedup, at_least=SPEEDUP_TARGET, unit="×")
    table.check_target("peak memory per worker",
                       max(r[2] for r in runs) / 1e9, at_most=MEMORY_TARGET_GB,
                       unit=" GB")
    table.notes.append(f"store: {store_bytes / 1e6:.1f} MB on disk for {samples / 1e6:.1f} M "
                       f"samples ({store_bytes / samples:.2f} bytes/sample, all arrays, zstd)")
    table.notes.append("LocalCluster of single-threaded worker processes, numba limited to 1 "
                       "thread per task; on a shared, loaded 2-core machine the speed-up is "
                       "bounded by the cores other jobs leave free. 'samples per CPU-s' "
                       "divides by the CPU time the workers used (their getrusage), which "
                       "the load does not inflate: it is the per-core throughput to plan with.")
    table.notes.append(f"speed-up = median over {rounds} round(s) of (total time of the "
                       f"round's 1-worker builds / total of its 2-worker builds), each round "
                       f"in the order {', '.join(map(str, ORDER))} workers: "
                       f"{', '.join(f'{r:.2f}×' for r in per_round)}; the per-row speed-up "
                       "divides the mean 1-worker time by that row; 'load avg' is the "
                       "machine's 1-minute load when the row's build started")
    table.notes.append(
        "what the build's structure allows on 2 free cores (schedule_speedup: the 1-worker "
        "builds' own task times handed to 2 workers in order, stage barriers and the "
        "time outside tasks kept): "
        f"{', '.join(f'{b:.2f}×' for b in bounds)}; 'workers busy' = task time / "
        "(wall × workers); 'cores used' = the workers' CPU seconds / wall seconds")
    table.notes.append(
        "Linux's autogroup scheduler (/proc/sys/kernel/sched_autogroup_enabled) shares the "
        "CPU fairly between sessions, not processes: when other sessions keep the cores "
        "busy, this session's builds get the same share whether they run 1 or 2 workers "
        "('cores used' about equal), and the measured speed-up tends to 1 — the 2-worker "
        "figure needs a machine the benchmark has to itself")
    table.check_target("speed-up the build's tasks allow on 2 free cores",
                       float(np.median(bounds)), at_least=SPEEDUP_TARGET, unit="×")
    table.notes.append(f"run {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    return [table, check]


def build_large(side: int, *, workers: int = 2, chunk: int = 1024, folder: str | Path | None = None
                ) -> BenchTable:
    """One build of the benchmark recipe at ``side``² on ``workers`` workers: wall time per
    stage, peak memory per worker and of this (client) process, store size. No whole-map
    check (the point is a map that does not fit in memory):
    ``python -m terrascape.bench.world 16385``."""
    import resource

    from terrascape.world import recipe_from_dict

    recipe = recipe_from_dict(bench_recipe(side, chunk))
    samples = recipe.rows * recipe.cols
    own = tempfile.mkdtemp(prefix="bench-world-large-", dir=folder)
    try:
        result, peak, cpu, _ = _build(recipe, workers, Path(own))
        store = Path(own) / f"world{workers}.zarr"
        store_bytes = sum(p.stat().st_size for p in store.rglob("*") if p.is_file())
    finally:
        shutil.rmtree(own, ignore_errors=True)
    client_peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    table = BenchTable(
        f"world build {side}² (chunk {chunk}; fBm, thermal ×4, normals, shadow, pyramid), "
        f"{workers} workers",
        ["stage", "seconds"])
    for name, sec in result.stage_seconds.items():
        table.rows.append([name, round(sec, 1)])
    table.rows.append(["total (wall)", round(result.seconds, 1)])
    table.notes += [
        f"{samples / 1e6:.0f} M samples, {samples / result.seconds / workers:,.0f} samples/s "
        f"per worker, {samples / cpu:,.0f} samples per CPU-second",
        f"peak RSS per worker {peak / 1e9:.3f} GB; client process {client_peak / 1e9:.3f} GB; "
        f"the float32 map alone would be {samples * 4 / 1e9:.2f} GB",
        f"store {store_bytes / 1e9:.2f} GB ({store_bytes / samples:.2f} bytes/sample)",
        f"run {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}",
    ]
    return table


if __name__ == "__main__":  # pragma: no cover - manual large runs
    import sys

    if sys.argv[1] == "speedup":  # speedup SIDE CHUNK ROUNDS
        tables = speedup(*(int(a) for a in sys.argv[2:5]))
    else:  # SIDE [WORKERS]
        tables = [build_large(int(sys.argv[1]),
                              workers=int(sys.argv[2]) if len(sys.argv) > 2 else 2)]
    for t in tables:
        print(t.title)
        for row in t.rows:
            print("  ", *row)
        for note in t.notes:
            print("  ", note)
