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

A second table times a new user's first commands (``generate``, ``shade``) twice each in
fresh processes: first with an empty numba cache, so every kernel they use compiles, then
again with the cache those runs wrote. The difference is the one-time compile cost. The
kernels are declared ``cache=True``: numba writes the machine code to ``__pycache__`` next to
each module (``.nbi`` index, ``.nbc`` code) and later processes load it instead of compiling.
``NUMBA_CACHE_DIR=DIR`` moves that cache to ``DIR`` — for an installation whose package
folder is read-only, or, as here, to start from an empty cache without touching the real one.
"""

from __future__ import annotations

import importlib.util
import os
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


#: A new user's first commands, run in a work folder (``{dir}``); each compiles the numba
#: kernels it needs on its very first run.
FIRST_COMMANDS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("terrascape generate fbm --size 129",
     ("generate", "fbm", "--size", "129", "-o", "{dir}/height.npy")),
    ("terrascape shade (daylight) 129²",
     ("shade", "{dir}/height.npy", "-o", "{dir}/light.png")),
)


def _cache_bytes(folder: Path) -> tuple[int, int]:
    files = [p for p in folder.rglob("*") if p.suffix in (".nbi", ".nbc")]
    return len(files), sum(p.stat().st_size for p in files)


def _first_command_argv() -> dict[str, list[str]]:
    cli = "import sys; from terrascape.cli import main; main(sys.argv[1:])"
    return {name: [sys.executable, "-c", cli, *argv] for name, argv in FIRST_COMMANDS}


def compile_table(rounds: int, commands: dict[str, list[str]] | None = None) -> BenchTable:
    """The first-ever run of ``commands`` (label → argv, ``{dir}`` standing for a fresh work
    folder; default :data:`FIRST_COMMANDS`) with an empty numba cache against a run with the
    cache it wrote, ``rounds`` times each in fresh processes."""
    commands = _first_command_argv() if commands is None else commands
    table = BenchTable(
        "First run: numba compiling the kernels (empty cache) vs loading them (cache written)",
        ["command", "first run s", "cached run s", "compile s", "cache files", "cache KiB"],
    )
    cold: dict[str, list[float]] = {name: [] for name in commands}
    warm: dict[str, list[float]] = {name: [] for name in commands}
    cache_files = {name: (0, 0) for name in commands}
    for _ in range(rounds):
        with tempfile.TemporaryDirectory(prefix="terrascape-numba-") as tmp:
            cache = Path(tmp) / "numba-cache"
            env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "COLUMNS": "100"}
            for times in (cold, warm):  # the same commands again, now with the cache filled
                work = Path(tempfile.mkdtemp(dir=tmp))
                for name, argv in commands.items():
                    args = [a.replace("{dir}", str(work)) for a in argv]
                    before = _cache_bytes(cache) if cache.exists() else (0, 0)
                    t0 = time.perf_counter()
                    subprocess.run(args, check=True, capture_output=True, env=env)
                    times[name].append(time.perf_counter() - t0)
                    if times is cold:
                        after = _cache_bytes(cache)
                        cache_files[name] = (after[0] - before[0], after[1] - before[1])
    for name in commands:
        first = statistics.median(cold[name])
        cached = statistics.median(warm[name])
        files, size = cache_files[name]
        table.rows.append([name, first, cached, first - cached, files, size / 1024])
    table.notes += [
        f"medians of {rounds} rounds; each round: the commands with an empty "
        "NUMBA_CACHE_DIR (everything compiles), then again with the cache they wrote",
        "compile s = first run − cached run: what a new installation pays once; the cache "
        "is written to __pycache__ next to each module (or to $NUMBA_CACHE_DIR)",
        "cache files: .nbi/.nbc files the command added (kernels shared with an earlier "
        "command are already there)",
    ]
    return table


def run(quick: bool = False) -> list[BenchTable]:
    return [startup_table(5 if quick else 15), compile_table(1 if quick else 3)]


__all__ = ["FIRST_COMMANDS", "compile_table", "run", "startup_commands", "startup_table",
           "time_interleaved"]
