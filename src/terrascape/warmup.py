"""Fill numba's cache ahead of a new user's first commands, several processes at a time.

Every kernel is compiled by numba the first time it runs and the machine code is cached
(``cache=True``; in ``__pycache__`` next to each module, or in ``$NUMBA_CACHE_DIR``), so a
new installation's first ``generate`` or ``shade`` spends most of its time compiling. The
compiler is single-threaded, but different kernels compile independently: the warm-up runs
the common commands on tiny maps in one process per CPU, each process taking a share of
them (longest first), so the cache fills in about ``1 / processes`` of the time the first
runs would spend one after another. Later processes load the kernels from the cache.

The tasks run the real command-line commands (in-process, on a 33² map written to a
temporary folder), so they compile exactly the specialisations — dtypes, layouts,
read-only flags — that the same commands on a user's files need; numba's cache is keyed by
the source file's contents, the function's bytecode, the argument types and the CPU, not by
the map's size. A shipped, pre-built cache would be keyed by the build machine's CPU, which
is why the cache is filled on the user's machine instead.
"""

from __future__ import annotations

import contextlib
import io
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

#: Side of the maps the tasks run on: compile time does not depend on the size, and 33 is
#: the smallest size every generator accepts (diamond-square needs 2**n + 1).
WARM_UP_SIZE = 33
#: Side of the greedy mesher's map: two pieces along each axis (a side of more than about
#: 336 samples is cut in two), so that the pieces' join compiles too.
_GREEDY_SIZE = 400
_TAG = "warm-up-task"  # marks the lines a worker reports its task times on
_SKIP_TAG = "warm-up-skipped"  # ... and an optional command it could not run


@dataclass(frozen=True)
class WarmUpTask:
    """One share of the warm-up: command lines (``{dir}`` = the work folder, ``{map}`` =
    a 33² float32 heightmap in it), then functions of this module called with the work
    folder (the demo's own steps), and a rough compile cost in seconds on an idle two-core
    machine, used to balance the processes (longest first). ``optional`` commands need
    OpenGL: where they fail, the task goes on without them and reports it. A task that is
    not ``default`` runs only when asked for by name."""

    summary: str
    commands: tuple[tuple[str, ...], ...]
    cost: float
    calls: tuple[str, ...] = ()
    optional: tuple[tuple[str, ...], ...] = ()
    default: bool = True


#: Task name → what it compiles. Kernels shared by two commands (the normals used by
#: ``shade`` and ``normalmap``; the noise kernel of ``fbm`` and ``ridged``) are in one
#: task, so no two processes compile the same kernel.
WARM_UP_TASKS: dict[str, WarmUpTask] = {
    "shade": WarmUpTask(
        "terrascape shade (daylight: normals, sky view, soft shadows), normalmap, render's "
        "shadows and textures, the demo's textures",
        (("shade", "{map}", "-o", "{dir}/light.png"),
         ("normalmap", "{map}", "-o", "{dir}/normal.png")),
        14.0,
        calls=("demo_textures",),
        optional=(("render", "{map}", "-o", "{dir}/render.png", "--size", "64x36"),)),
    "noise": WarmUpTask(
        "terrascape generate fbm and ridged",
        (("generate", "fbm", "--size", str(WARM_UP_SIZE), "-o", "{dir}/fbm.npy"),
         ("generate", "ridged", "--size", str(WARM_UP_SIZE), "-o", "{dir}/ridged.npy")),
        5.0),
    "terrain": WarmUpTask(
        "terrascape generate diamond-square, hills and fault; erode (river erosion); the "
        "renderer's region texture, cone map and object placement",
        (*(("generate", name, "--size", str(WARM_UP_SIZE), "-o", f"{{dir}}/{name}.npy")
           for name in ("diamond-square", "hills", "fault")),
         ("erode", "{map}", "{dir}/eroded.npy")),
        12.0,
        calls=("render_textures",)),
    "lod": WarmUpTask(
        "terrascape mesh --max-error (static mesh), the demo's ROAM and geomipmapping and "
        "the streaming viewer's simplified tiles",
        (("mesh", "{map}", "-o", "{dir}/mesh.obj", "--max-error", "0.5"),),
        20.0,
        calls=("demo_lod",)),
    # not by default: the demo does not use it, and it would lengthen every set-up
    "greedy": WarmUpTask(
        "terrascape mesh --mesher greedy (static meshes by greedy insertion: in pieces, in "
        "one order, under a triangle budget)",
        (),
        22.0,
        calls=("greedy_meshes",),
        default=False),
}

#: The tasks ``terrascape warm-up`` runs when none is named.
DEFAULT_TASKS: tuple[str, ...] = tuple(n for n, t in WARM_UP_TASKS.items() if t.default)


def check_tasks(names: list[str]) -> None:
    """Raise :class:`~terrascape.errors.InvalidParameterError` naming any of ``names`` that
    is not a task of :data:`WARM_UP_TASKS`."""
    from terrascape.errors import InvalidParameterError

    unknown = [n for n in names if n not in WARM_UP_TASKS]
    if unknown:
        raise InvalidParameterError(
            f"unknown {', '.join(unknown)}; choose from {', '.join(WARM_UP_TASKS)}")


def _map_heightmap(folder: Path):
    """The tasks' 33² map as a :class:`~terrascape.heightmap.Heightmap` with the demo's 4 m
    spacing (the kernels see the same types as for the demo's eroded terrain)."""
    import numpy as np

    from terrascape.heightmap import Heightmap

    return Heightmap(np.load(_write_map(folder)), (4.0, 4.0))


def demo_textures(folder: Path) -> None:
    """The demo's texture stage (lightmap, material, normal map, splat maps). Without the
    erosion masks: they only enter the material's numpy part, not its kernels."""
    from terrascape.cli.demo import DemoResult, texture_stage

    texture_stage(folder, DemoResult(), _map_heightmap(folder), force=True)


def demo_lod(folder: Path) -> None:
    """The demo's view-dependent meshes (ROAM, geomipmapping) for its close-up camera."""
    from terrascape.cli.demo import _close_up_camera
    from terrascape.lod import Geomipmap, Roam

    hm = _map_heightmap(folder)
    size = (64, 36)
    camera = _close_up_camera(hm, size[0] / size[1])
    roam = Roam(hm)
    roam.update(camera, size, max_triangles=100)
    roam.triangles()
    geo = Geomipmap(hm, patch_size=17)
    geo.update(camera, size, tolerance_px=2.0, cull=True)
    geo.triangles()
    # the streaming viewer's simplified tiles (a 33² tile is the default tile's grid)
    from terrascape.world.chunked_lod import simplified_tile_triangles, tile_bintree_errors

    simplified_tile_triangles(tile_bintree_errors(hm.heights), hm.rows, 0.5)


def greedy_meshes(folder: Path) -> None:
    """``terrascape mesh --mesher greedy`` on a map of two pieces by two (the pieces, their
    join and its seams), as one greedy order, and under a triangle budget."""
    big = _write_map(folder, _GREEDY_SIZE, "greedy_map.npy")
    runs = (("--max-error", "0.5"), ("--max-error", "0.5", "--one-piece"),
            ("--triangles", "500"))
    for k, extra in enumerate(runs):
        failure = _run_command(("mesh", "{map}", "-o", f"{{dir}}/greedy{k}.obj", "--mesher",
                                "greedy", *extra), folder, big)
        if failure is not None:
            raise RuntimeError(f"warm-up task greedy: {failure}")


def render_textures(folder: Path) -> None:
    """What the renderer builds on the CPU for its techniques and the demo's showcase: the
    height-region colour texture, the cone map of the relief field, the default objects."""
    from terrascape.objects import load_objects
    from terrascape.relief.cone_map import footprint_cone_map
    from terrascape.relief.fields import sampled_heights
    from terrascape.render.relief_techniques import TERRAIN_RELIEF_BITS
    from terrascape.texture import region_texture

    hm = _map_heightmap(folder)
    region_texture(hm, seed=7)
    footprint_cone_map(sampled_heights(hm.heights, TERRAIN_RELIEF_BITS))
    load_objects("default", hm, seed=1, sea_level=float(hm.heights.mean()))


def _write_map(folder: Path, size: int = WARM_UP_SIZE, name: str = "map.npy") -> Path:
    """A smooth float32 heightmap (.npy) of ``size``², the input of the tasks that read one."""
    import numpy as np

    z, x = np.mgrid[0:size, 0:size].astype(np.float64) / (size - 1)
    heights = 20.0 * (np.sin(3.1 * x + 0.4) * np.cos(2.3 * z) + 0.3 * np.sin(9.0 * x * z))
    path = folder / name
    np.save(path, heights.astype(np.float32))
    return path


def _run_command(argv: tuple[str, ...], folder: Path, map_path: Path) -> str | None:
    """Run one command line in-process; ``None``, or why it failed (its output)."""
    from terrascape.cli import run_app

    args = [a.replace("{dir}", str(folder)).replace("{map}", str(map_path)) for a in argv]
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf):
        code = run_app(args)
    if code == 0:
        return None
    return f"`terrascape {' '.join(argv)}` exited with {code}: {buf.getvalue().strip()}"


def run_tasks(names: list[str], folder: Path) -> tuple[dict[str, float], list[str]]:
    """Run the tasks ``names`` in this process (in order) in ``folder``: seconds per task,
    and the optional commands that failed (with why).

    A required command that fails raises :class:`RuntimeError` with its output."""
    check_tasks(names)
    map_path = _write_map(folder)
    seconds = {}
    skipped = []
    for name in names:
        task = WARM_UP_TASKS[name]
        t0 = time.perf_counter()
        for argv in task.commands:
            failure = _run_command(argv, folder, map_path)
            if failure is not None:
                raise RuntimeError(f"warm-up task {name}: {failure}")
        for argv in task.optional:
            failure = _run_command(argv, folder, map_path)
            if failure is not None:
                skipped.append(failure.splitlines()[0][:300])
        for call in task.calls:
            globals()[call](folder)
        seconds[name] = time.perf_counter() - t0
    return seconds, skipped


def plan(names: list[str], processes: int) -> list[list[str]]:
    """Share the tasks out: longest first, each to the process with the least work so far
    (no empty shares)."""
    shares: list[list[str]] = [[] for _ in range(max(1, min(processes, len(names))))]
    load = [0.0] * len(shares)
    for name in sorted(names, key=lambda n: -WARM_UP_TASKS[n].cost):
        k = load.index(min(load))
        shares[k].append(name)
        load[k] += WARM_UP_TASKS[name].cost
    return shares


@dataclass(frozen=True)
class WarmUpResult:
    """What :func:`warm_up` did: per task its seconds, the processes' shares, the wall time."""

    seconds: dict[str, float]
    shares: list[list[str]]
    wall: float
    skipped: list[str]


def warm_up(tasks: list[str] | None = None, processes: int | None = None) -> WarmUpResult:
    """Compile (or load) the kernels of ``tasks`` (default: :data:`DEFAULT_TASKS`) in
    ``processes`` fresh Python processes at once (default: one per CPU).

    The cache is the one the processes see: ``$NUMBA_CACHE_DIR`` when set, else
    ``__pycache__`` next to the modules. Raises :class:`RuntimeError` when a task fails.
    """
    names = list(DEFAULT_TASKS) if tasks is None else list(tasks)
    check_tasks(names)
    if processes is None:
        processes = os.cpu_count() or 1
    if processes < 1:
        raise ValueError(f"processes must be >= 1, got {processes}")
    shares = plan(names, processes)
    t0 = time.perf_counter()
    seconds: dict[str, float] = {}
    skipped: list[str] = []
    with tempfile.TemporaryDirectory(prefix="terrascape-warm-up-") as tmp:
        running = []
        for k, share in enumerate(shares):
            folder = Path(tmp) / str(k)
            folder.mkdir()
            running.append(subprocess.Popen(
                [sys.executable, "-m", "terrascape.warmup", str(folder), *share],
                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True))
        failures = []
        for proc in running:
            out, err = proc.communicate()
            if proc.returncode != 0:
                failures.append(err.strip() or out.strip())
                continue
            for line in out.splitlines():
                tag, _, rest = line.partition(" ")
                if tag == _TAG:
                    name, value = rest.split()
                    seconds[name] = float(value)
                elif tag == _SKIP_TAG:
                    skipped.append(rest)
    if failures:
        raise RuntimeError("warm-up failed:\n" + "\n".join(failures))
    return WarmUpResult(seconds, shares, time.perf_counter() - t0, skipped)


def _main(argv: list[str]) -> int:
    """``python -m terrascape.warmup FOLDER TASK…``: one process's share; prints
    ``warm-up-task TASK SECONDS`` lines."""
    folder, *names = argv
    seconds, skipped = run_tasks(names, Path(folder))
    for reason in skipped:
        print(f"{_SKIP_TAG} {' '.join(reason.split())}")
    for name, s in seconds.items():
        print(f"{_TAG} {name} {s:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(_main(sys.argv[1:]))


__all__ = ["DEFAULT_TASKS", "WARM_UP_SIZE", "WARM_UP_TASKS", "WarmUpResult", "WarmUpTask",
           "check_tasks", "plan", "run_tasks", "warm_up"]
