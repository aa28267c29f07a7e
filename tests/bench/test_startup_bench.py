"""``bench startup`` (also the last table of ``bench peers``): every command is run once per
round in a rotated order, and each ratio is taken within its round."""

from __future__ import annotations

import sys

import pytest

from terrascape.bench import available_cases
from terrascape.bench.startup import startup_commands, time_interleaved


def test_startup_is_a_bench_case() -> None:
    assert "startup" in available_cases()


def test_commands_have_the_terrascape_rows_and_say_why_a_peer_is_missing(monkeypatch) -> None:
    import terrascape.bench.startup as startup

    monkeypatch.setattr(startup.shutil, "which", lambda name: None)
    commands, skipped = startup_commands()
    assert list(commands)[:4] == ["python -c pass", "import numpy", "import terrascape",
                                  "terrascape --help"]
    assert commands["import terrascape"] == [sys.executable, "-c", "import terrascape"]
    assert "gdalinfo is not on PATH: its row is skipped" in skipped
    assert not any("gdalinfo" in name for name in commands)


def test_ratios_are_within_each_round() -> None:
    slow = [sys.executable, "-c", "import time; time.sleep(0.3)"]
    fast = [sys.executable, "-c", "pass"]
    measured = time_interleaved({"import numpy": fast, "slow": slow}, rounds=2)
    times, ratios = measured["slow"]
    assert len(times) == len(ratios) == 2
    assert all(t >= 0.3 for t in times)
    base = measured["import numpy"][0]
    assert ratios == pytest.approx([a / b for a, b in zip(times, base, strict=True)])
    assert measured["import numpy"][1] == [1.0, 1.0]


def test_a_baseline_tree_gets_its_own_rows(monkeypatch, tmp_path) -> None:
    monkeypatch.setenv("TERRASCAPE_STARTUP_BASELINE", str(tmp_path))
    commands, _ = startup_commands()
    assert commands["import terrascape (baseline)"][-1] == (
        f"import sys; sys.path.insert(0, {str(tmp_path)!r}); import terrascape")
    assert "terrascape --help (baseline)" in commands


def test_first_run_table_compiles_into_an_empty_cache_then_loads_it(tmp_path) -> None:
    """The compile table's first run writes numba's cache files into its own empty
    ``NUMBA_CACHE_DIR``; the second run finds them (it adds none)."""
    from terrascape.bench.startup import FIRST_COMMANDS, compile_table

    (tmp_path / "tiny_kernel.py").write_text(
        "import numba\n\n@numba.njit(cache=True)\ndef plus_one(x):\n    return x + 1\n\n"
        "assert plus_one(1) == 2\n")
    probe = (f"import sys; sys.path.insert(0, {str(tmp_path)!r}); import tiny_kernel; "
             "open(sys.argv[1] + '/ran', 'w').write('yes')")
    table = compile_table(1, {"tiny kernel": [sys.executable, "-c", probe, "{dir}"]})
    (name, first, cached, compile_s, cpu, files, kib), total = table.rows
    assert name == "tiny kernel" and first > 0 and cached > 0
    assert compile_s == pytest.approx(first - cached)
    assert cpu > 0
    assert files == 2 and kib > 0  # the kernel's .nbi index and .nbc code
    assert total[0] == "all 1 commands, first runs" and total[1] == pytest.approx(first)
    assert not list(tmp_path.rglob("*.nbc"))  # nothing went to the module's __pycache__
    assert [argv[:2] for _, argv in FIRST_COMMANDS][:2] == [
        ("generate", "fbm"), ("shade", "{dir}/height.npy")]
    # every later command reads the map the first one wrote
    assert all("{dir}/height.npy" in argv for _, argv in FIRST_COMMANDS[4:])
