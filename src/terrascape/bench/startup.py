"""``terrascape bench startup``: how long a fresh interpreter takes to import terrascape and to
print ``terrascape --help``, next to the libraries and tools a user starts instead.

Every round starts each command once in a fresh process (bytecode cached), in an order
rotated from round to round, so all of them see the same machine load; the table gives each
command's median time and the median of its within-round ratio to ``import numpy`` (the one
import every terrascape user pays anyway) with the spread of that ratio. Peers that are not
installed (rasterio, pyvista) or not on ``PATH`` (``gdalinfo``) are skipped rows with the
reason. The same table is part of ``terrascape bench peers``. With
``TERRASCAPE_STARTUP_BASELINE=/path/to/old/src`` the same two commands of another source
tree are timed in the same rounds (before/after a change).

A second table times a new user's first commands (``generate``, ``shade``, ``erode``,
``normalmap``, ``mesh``), one after another, twice each in fresh processes: first with an
empty numba cache, so every kernel they use compiles, then again with the cache those runs
wrote. The difference is the one-time compile cost. With ``TERRASCAPE_STARTUP_BASELINE``
the other tree's commands are timed in the same rounds (alternating order, each tree in its
own empty cache); a last row times ``terrascape warm-up`` (the kernels compiled in one
process per CPU) followed by the same commands. The
kernels are declared ``cache=True``: numba writes the machine code to ``__pycache__`` next to
each module (``.nbi`` index, ``.nbc`` code) and later processes load it instead of compiling.
``NUMBA_CACHE_DIR=DIR`` moves that cache to ``DIR`` — for an installation whose package
folder is read-only, or, as here, to start from an empty cache without touching the real one.
"""

from __future__ import annotations

import importlib.util
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from terrascape.bench import BenchTable

#: Environment variable naming a second ``src`` folder whose start-up is timed in the same
#: rounds ("baseline" rows): the before/after comparison of a change.
BASELINE_VAR = "TERRASCAPE_STARTUP_BASELINE"

#: Targets on this machine kind (two cores), bytecode cached.
IMPORT_TARGET_S = 0.10
HELP_TARGET_S = 0.25


def _python(code: str) -> list[str]:
    return [sys.executable, "-c", code]


def startup_commands() -> tuple[dict[str, list[str]], list[str]]:
    """The commands timed (label → argv) and the reasons for those skipped."""
    commands = {
        "python -c pass": _python("pass"),
        "import numpy": _python("import numpy"),
        "import terrascape": _python("import terrascape"),
        "terrascape --help": _python("from terrascape.cli import main; main(['--help'])"),
    }
    skipped = []
    baseline = os.environ.get(BASELINE_VAR)
    if baseline:  # another source tree (e.g. `git archive OLD src`) timed in the same rounds
        for label, code in (("import terrascape", "import terrascape"),
                            ("terrascape --help",
                             "from terrascape.cli import main; main(['--help'])")):
            commands[f"{label} (baseline)"] = [
                sys.executable, "-c",
                f"import sys; sys.path.insert(0, {baseline!r}); {code}"]
    if importlib.util.find_spec("rasterio") is not None:
        commands["import rasterio (peer)"] = _python("import rasterio")
    else:
        skipped.append("rasterio is not installed: its row is skipped")
    gdalinfo = shutil.which("gdalinfo")
    if gdalinfo is not None:
        commands["gdalinfo --version (peer)"] = [gdalinfo, "--version"]
    else:
        skipped.append("gdalinfo is not on PATH: its row is skipped")
    if importlib.util.find_spec("pyvista") is not None:
        commands["import pyvista (peer)"] = _python("import pyvista")
    else:
        skipped.append("pyvista is not installed: its row is skipped")
    return commands, skipped


def time_interleaved(commands: dict[str, list[str]], rounds: int
                     ) -> dict[str, tuple[list[float], list[float]]]:
    """Per command: its wall times and its within-round ratios to ``import numpy``."""
    env = {**os.environ, "COLUMNS": "100"}
    names = list(commands)
    for name in names:  # warm-up: bytecode written, files in the page cache
        subprocess.run(commands[name], check=True, capture_output=True, env=env)
    times: dict[str, list[float]] = {name: [] for name in names}
    for r in range(rounds):
        order = names[r % len(names):] + names[:r % len(names)]
        for name in order:
            t0 = time.perf_counter()
            subprocess.run(commands[name], check=True, capture_output=True, env=env)
            times[name].append(time.perf_counter() - t0)
    numpy_times = times["import numpy"]
    return {name: (t, [a / b for a, b in zip(t, numpy_times, strict=True)])
            for name, t in times.items()}


def startup_table(rounds: int) -> BenchTable:
    """The start-up table, with the two targets checked on the median times."""
    commands, skipped = startup_commands()
    table = BenchTable(
        "Start-up in a fresh interpreter (bytecode cached), interleaved rounds",
        ["command", "median s", "÷ import numpy", "spread"],
    )
    measured = time_interleaved(commands, rounds)
    for name, (times, ratios) in measured.items():
        table.rows.append([name, statistics.median(times), statistics.median(ratios),
                           f"{min(ratios):.2f}–{max(ratios):.2f}"])
    table.check_target("import terrascape", statistics.median(measured["import terrascape"][0]),
                       at_most=IMPORT_TARGET_S, unit=" s")
    table.check_target("terrascape --help",
                       statistics.median(measured["terrascape --help"][0]),
                       at_most=HELP_TARGET_S, unit=" s")
    table.notes += [
        f"medians of {rounds} rounds, each command once per round in a rotated order; "
        "÷ import numpy: median of the within-round ratios (min–max)",
        f"targets: import terrascape ≤ {IMPORT_TARGET_S:g} s, terrascape --help ≤ "
        f"{HELP_TARGET_S:g} s; on a loaded machine the ratios are the figures to compare",
        f"CPUs: {os.cpu_count()}, load average at the end: {os.getloadavg()[0]:.2f}",
        *skipped,
    ]
    return table


#: A new user's first commands, run one after another in a work folder (``{dir}``); each
#: compiles the numba kernels it needs on its very first run (a kernel an earlier command
#: compiled is loaded from the cache).
FIRST_COMMANDS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("terrascape generate fbm --size 129",
     ("generate", "fbm", "--size", "129", "-o", "{dir}/height.npy")),
    ("terrascape shade (daylight) 129²",
     ("shade", "{dir}/height.npy", "-o", "{dir}/light.png")),
    ("terrascape generate ridged --size 129",
     ("generate", "ridged", "--size", "129", "-o", "{dir}/ridged.npy")),
    ("terrascape generate diamond-square --size 129",
     ("generate", "diamond-square", "--size", "129", "-o", "{dir}/ds.npy")),
    ("terrascape erode 129² (river erosion)",
     ("erode", "{dir}/height.npy", "{dir}/eroded.npy")),
    ("terrascape normalmap 129²",
     ("normalmap", "{dir}/height.npy", "-o", "{dir}/normal.png")),
    ("terrascape mesh --max-error 0.5 129²",
     ("mesh", "{dir}/height.npy", "-o", "{dir}/mesh.obj", "--max-error", "0.5")),
)

#: The label of the rows that run ``terrascape warm-up`` first (same cache), then the commands.
WARM_UP_ROW = "terrascape warm-up, then all the commands"


def _cache_bytes(folder: Path) -> tuple[int, int]:
    files = [p for p in folder.rglob("*") if p.suffix in (".nbi", ".nbc")]
    return len(files), sum(p.stat().st_size for p in files)


def _cli_argv(argv: tuple[str, ...], src: str | None = None) -> list[str]:
    """A command line of this tree (``src=None``) or of the ``src`` folder of another."""
    cli = "import sys; from terrascape.cli import main; main(sys.argv[1:])"
    if src is not None:
        cli = f"import sys; sys.path.insert(0, {src!r}); {cli}"
    return [sys.executable, "-c", cli, *argv]


def _first_command_argv(src: str | None = None) -> dict[str, list[str]]:
    return {name: _cli_argv(argv, src) for name, argv in FIRST_COMMANDS}


def _run_timed(args: list[str], env: dict[str, str]) -> tuple[float, float]:
    """Wall and CPU seconds (user + system, the child's) of one command."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(args, check=True, capture_output=True, env=env)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _cold_then_cached(commands: dict[str, list[str]], tmp: Path, warm_up: list[str] | None
                      ) -> tuple[dict[str, tuple[float, float]], dict[str, tuple[float, float]],
                                 dict[str, tuple[int, int]], tuple[float, float] | None]:
    """One round for one tree in a fresh, empty numba cache: (``warm_up`` first, when given)
    the commands in order, then again with the cache they wrote."""
    cache = tmp / "numba-cache"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "COLUMNS": "100"}
    warm = _run_timed(warm_up, env) if warm_up is not None else None
    runs: list[dict[str, tuple[float, float]]] = [{}, {}]
    files: dict[str, tuple[int, int]] = {}
    for times in runs:  # the same commands again, now with the cache filled
        work = Path(tempfile.mkdtemp(dir=tmp))
        for name, argv in commands.items():
            args = [a.replace("{dir}", str(work)) for a in argv]
            before = _cache_bytes(cache) if cache.exists() else (0, 0)
            times[name] = _run_timed(args, env)
            if times is runs[0]:
                after = _cache_bytes(cache)
                files[name] = (after[0] - before[0], after[1] - before[1])
    return runs[0], runs[1], files, warm


def compile_table(rounds: int, commands: dict[str, list[str]] | None = None, *,
                  baseline: str | None = None, warm_up: bool = False) -> BenchTable:
    """The first-ever run of ``commands`` (label → argv, ``{dir}`` standing for a fresh work
    folder; default :data:`FIRST_COMMANDS`) with an empty numba cache against a run with the
    cache it wrote, ``rounds`` times each in fresh processes.

    ``baseline`` (default commands only): the ``src`` folder of another tree (default
    ``$TERRASCAPE_STARTUP_BASELINE``), timed in the same rounds — each round runs this tree and the
    baseline in alternating order (A B, B A, …), each in its own empty cache. ``warm_up``:
    also time ``terrascape warm-up`` into an empty cache followed by the commands (cached).
    """
    default = commands is None
    commands = _first_command_argv() if default else commands
    if baseline is None and default:
        baseline = os.environ.get(BASELINE_VAR) or None
    trees: dict[str, dict[str, list[str]]] = {"": commands}
    if baseline is not None and default:
        trees[" (baseline)"] = _first_command_argv(baseline)
    table = BenchTable(
        "First run: numba compiling the kernels (empty cache) vs loading them (cache written)",
        ["command", "first run s", "cached run s", "compile s", "first run CPU s",
         "cache files", "cache KiB"],
    )
    cold: dict[str, list[tuple[float, float]]] = {}
    warm: dict[str, list[tuple[float, float]]] = {}
    files: dict[str, tuple[int, int]] = {}
    warm_up_then: list[float] = []
    warm_up_argv = _cli_argv(("warm-up",))
    for r in range(rounds):
        order = list(trees) if r % 2 == 0 else list(reversed(trees))
        for tag in order:
            with tempfile.TemporaryDirectory(prefix="terrascape-numba-") as tmp:
                first, cached, added, _ = _cold_then_cached(trees[tag], Path(tmp), None)
            for name in trees[tag]:
                cold.setdefault(name + tag, []).append(first[name])
                warm.setdefault(name + tag, []).append(cached[name])
                files[name + tag] = added[name]
            total = (sum(t[0] for t in first.values()), sum(t[1] for t in first.values()))
            cold.setdefault(f"all {len(commands)} commands, first runs{tag}", []).append(total)
        if warm_up:
            with tempfile.TemporaryDirectory(prefix="terrascape-numba-") as tmp:
                _, cached, _, w = _cold_then_cached(commands, Path(tmp), warm_up_argv)
            assert w is not None
            warm_up_then.append(w[0] + sum(t[0] for t in cached.values()))
            cold.setdefault("terrascape warm-up", []).append(w)
    med = statistics.median
    for name, runs in cold.items():
        first_s = med(t[0] for t in runs)
        cpu_s = med(t[1] for t in runs)
        if name in warm:
            cached_s = med(t[0] for t in warm[name])
            n_files, size = files[name]
            table.rows.append([name, first_s, cached_s, first_s - cached_s, cpu_s, n_files,
                               size / 1024])
        else:
            table.rows.append([name, first_s, "", "", cpu_s, "", ""])
    if warm_up_then:
        table.rows.append([WARM_UP_ROW, med(warm_up_then), "", "", "", "", ""])
    table.notes += [
        f"medians of {rounds} rounds; each round: the commands one after another with an "
        "empty NUMBA_CACHE_DIR (everything compiles), then again with the cache they wrote"
        + ("; this tree and the baseline alternate (A B, B A, …)" if baseline else ""),
        "compile s = first run − cached run: what a new installation pays once; the cache "
        "is written to __pycache__ next to each module (or to $NUMBA_CACHE_DIR)",
        "first run CPU s: the process's user + system time (compiling is single-threaded; "
        "less sensitive to other load than wall time)",
        "cache files: .nbi/.nbc files the command added (kernels shared with an earlier "
        "command are already there)",
        f"CPUs: {os.cpu_count()}, load average at the end: {os.getloadavg()[0]:.2f}",
    ]
    if warm_up:
        table.notes.append(f"{WARM_UP_ROW}: the warm-up (one process per CPU) into an empty "
                           "cache, then every command above once, wall seconds in all")
    return table


def run(quick: bool = False) -> list[BenchTable]:
    return [startup_table(5 if quick else 15), compile_table(1 if quick else 3, warm_up=True)]


__all__ = ["FIRST_COMMANDS", "WARM_UP_ROW", "compile_table", "run", "startup_commands",
           "startup_table", "time_interleaved"]
