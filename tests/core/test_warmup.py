"""``terrascape warm-up`` fills numba's cache so that a later process compiles nothing.

The check is numba's own: a fresh process runs the real command with a listener on numba's
``numba:compile`` event (sent only for a real compilation, not for a cache load) and reads
the dispatcher's cache statistics.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import terrascape
from terrascape.warmup import DEFAULT_TASKS, WARM_UP_TASKS, plan

SRC = str(Path(terrascape.__file__).resolve().parents[1])

# Runs a command line in-process and reports the terrascape functions numba compiled, and the
# cache hits of the noise kernel.
_PROBE = """
import json, sys
from numba.core import event
compiled = []
class Listener(event.Listener):
    def on_start(self, ev):
        f = ev.data["dispatcher"].py_func
        if f.__module__.startswith("terrascape."):
            compiled.append(f.__module__ + "." + f.__qualname__)
    def on_end(self, ev):
        pass
event.register("numba:compile", Listener())
from terrascape.cli import run_app
code = run_app(sys.argv[1:])
from terrascape.generate.noise import _noise_rows
hits = sum(_noise_rows.stats.cache_hits.values())
print("PROBE " + json.dumps({"code": code, "compiled": compiled, "hits": hits}))
"""


def _env(cache: Path) -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": SRC, "NUMBA_CACHE_DIR": str(cache), "COLUMNS": "200"}


def _probe(cache: Path, *argv: str) -> dict:
    result = subprocess.run([sys.executable, "-c", _PROBE, *argv], capture_output=True,
                            text=True, env=_env(cache), timeout=300, check=True)
    line = [x for x in result.stdout.splitlines() if x.startswith("PROBE ")][-1]
    return json.loads(line[6:])


def test_plan_shares_longest_first_without_empty_shares() -> None:
    names = list(WARM_UP_TASKS)
    shares = plan(names, 2)
    assert sorted(n for s in shares for n in s) == sorted(names)
    costs = [sum(WARM_UP_TASKS[n].cost for n in s) for s in shares]
    # greedy longest-first: the larger share exceeds the smaller by at most one task's cost
    assert max(costs) - min(costs) <= max(t.cost for t in WARM_UP_TASKS.values())
    assert plan(["noise"], 4) == [["noise"]]
    assert plan(names, 1) == [sorted(names, key=lambda n: -WARM_UP_TASKS[n].cost)]


def test_warm_up_fills_the_cache_a_second_process_loads(tmp_path: Path) -> None:
    cache = tmp_path / "numba-cache"
    result = subprocess.run(
        [sys.executable, "-m", "terrascape", "warm-up", "--only", "noise", "--processes", "1"],
        capture_output=True, text=True, env=_env(cache), timeout=300, check=False)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "1 processes" in result.stdout
    index = list(cache.rglob("noise._noise_rows-*.nbi"))
    assert len(index) == 1 and list(cache.rglob("noise._noise_rows-*.nbc"))
    # a bigger map than the warm-up's, both generators of the task: nothing compiles
    for name in ("fbm", "ridged"):
        probe = _probe(cache, "generate", name, "--size", "129", "-o",
                       str(tmp_path / f"{name}.npy"))
        assert probe["code"] == 0
        assert probe["compiled"] == []
        assert probe["hits"] == 1


def test_unknown_share_is_refused(tmp_path: Path) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "terrascape", "warm-up", "--only", "nosie"],
        capture_output=True, text=True, env=_env(tmp_path / "c"), timeout=120, check=False)
    assert result.returncode != 0
    assert "unknown nosie" in result.stdout + result.stderr
    assert not (tmp_path / "c").exists()


@pytest.mark.parametrize("name", list(WARM_UP_TASKS))
def test_every_task_has_commands_and_a_summary(name: str) -> None:
    task = WARM_UP_TASKS[name]
    assert task.summary and task.cost > 0
    assert task.commands or task.calls


def test_demo_lod_share_runs_without_the_world_extra(tmp_path: Path) -> None:
    """An installation without zarr (the demo's: no world extra) warms the LOD share up,
    the streaming viewer's kernels included: the world package's face loads its dask and
    zarr modules only when asked for them."""
    import subprocess
    import sys

    code = ("import sys; sys.modules['zarr'] = None\n"
            "from pathlib import Path\n"
            "from terrascape import warmup\n"
            f"warmup.demo_lod(Path({str(tmp_path)!r}))\n"
            "assert 'terrascape.world.build' not in sys.modules\n"
            "assert 'terrascape.world.chunked_lod' in sys.modules\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]


def test_greedy_is_warmed_up_only_when_named() -> None:
    assert "greedy" in WARM_UP_TASKS and "greedy" not in DEFAULT_TASKS
    assert set(DEFAULT_TASKS) == {"shade", "noise", "terrain", "lod"}


def test_greedy_warm_up_leaves_nothing_to_compile_for_the_greedy_mesher(tmp_path: Path) -> None:
    """After ``warm-up --only greedy``, meshing a bigger map in pieces, in one order and under
    a budget compiles none of the greedy mesher's kernels."""
    cache = tmp_path / "numba-cache"
    result = subprocess.run(
        [sys.executable, "-m", "terrascape", "warm-up", "--only", "greedy", "--processes", "1"],
        capture_output=True, text=True, env=_env(cache), timeout=600, check=False)
    assert result.returncode == 0, result.stdout + result.stderr
    assert list(cache.rglob("greedy_tin._mesh_piece-*.nbc"))
    import numpy as np

    rng = np.random.default_rng(3)
    path = tmp_path / "map.npy"
    np.save(path, np.cumsum(rng.standard_normal((530, 470)), 0).astype(np.float32))
    runs = (("--max-error", "1"), ("--max-error", "1", "--one-piece"), ("--triangles", "2000"))
    for k, extra in enumerate(runs):
        probe = _probe(cache, "mesh", str(path), "-o", str(tmp_path / f"tin{k}.obj"),
                       "--mesher", "greedy", *extra)
        assert probe["code"] == 0
        assert [f for f in probe["compiled"] if ".greedy_tin." in f] == []
