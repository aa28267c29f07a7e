"""A fast start: ``import terrascape`` and ``terrascape --help`` load none of the heavy
libraries (numpy, scipy, numba, OpenGL), and the lazy package faces still offer every name.

These are result tests (which modules a fresh interpreter holds afterwards), not timings:
the times are measured by ``terrascape bench peers`` (its start-up table).
"""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import terrascape

SRC = str(Path(terrascape.__file__).resolve().parents[1])
HEAVY = ("numpy", "scipy", "numba", "moderngl", "rasterio", "matplotlib", "PIL")


def _modules_after(code: str, *argv: str) -> tuple[set[str], str]:
    """The modules a fresh interpreter has loaded after running ``code`` (its stdout too)."""
    probe = (f"import sys\nsys.argv = {['terrascape', *argv]!r}\n{code}\n"
             "import json; sys.__stderr__.write('\\nMODULES ' + json.dumps(sorted(sys.modules)))")
    env = {**os.environ, "PYTHONPATH": SRC, "COLUMNS": "200"}
    result = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                            env=env, timeout=120, check=False)
    marker = result.stderr.rfind("MODULES ")
    assert marker >= 0, result.stderr
    return set(json.loads(result.stderr[marker + 8:])), result.stdout


def _heavy(modules: set[str]) -> list[str]:
    return sorted(m for m in modules if m.split(".")[0] in HEAVY)


def test_import_terrascape_loads_no_heavy_library() -> None:
    modules, _ = _modules_after("import terrascape\nassert terrascape.TerrascapeError")
    assert "terrascape" in modules
    assert _heavy(modules) == []
    assert "terrascape.heightmap" not in modules


def test_help_loads_no_heavy_library_and_no_command_module() -> None:
    modules, out = _modules_after(
        "from terrascape.cli import run_app\nrc = run_app(['--help'])\nassert rc == 0, rc",
        "--help")
    assert _heavy(modules) == []
    # the top-level help is drawn from the command table: typer and rich are not loaded
    assert sorted(m for m in modules if m.split(".")[0] in ("typer", "rich", "click")) == []
    assert not [m for m in modules if m.startswith("terrascape.cli.cmd_")]
    from terrascape.cli.commands import COMMANDS

    listed = [line.split()[1] for line in out.splitlines()
              if line.startswith("│ ") and len(line.split()) > 2]
    assert [name for name in listed if name in COMMANDS] == list(COMMANDS)


def test_a_command_loads_only_its_own_module() -> None:
    modules, out = _modules_after(
        "from terrascape.cli import run_app\nrc = run_app(['info', '--help'])\nassert rc == 0",
        "info", "--help")
    assert "Describe a heightmap file" in out and "Reads: .png" in out
    assert sorted(m for m in modules if m.startswith("terrascape.cli.cmd_")) == [
        "terrascape.cli.cmd_files"]


def test_heightmap_is_still_offered_by_the_package() -> None:
    from terrascape import Heightmap
    from terrascape.heightmap import Heightmap as Direct

    assert Heightmap is Direct is terrascape.Heightmap
    assert "Heightmap" in dir(terrascape)
    with pytest.raises(AttributeError, match="no attribute 'nonexistent'"):
        terrascape.nonexistent  # noqa: B018


@pytest.mark.parametrize("package", ["terrascape", "terrascape.io", "terrascape.generate"])
def test_every_exported_name_resolves(package: str) -> None:
    module = importlib.import_module(package)
    for name in module.__all__:
        value = getattr(module, name)
        assert value is not None, name
        assert name in dir(module)
    probe = f"from {package} import *\nimport sys\nprint(len(dir()))"
    result = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                            env={**os.environ, "PYTHONPATH": SRC}, timeout=120, check=True)
    assert int(result.stdout) >= len(module.__all__)


def test_lazy_generators_give_the_same_terrain() -> None:
    import numpy as np

    from terrascape.generate import fbm, generate

    assert np.array_equal(fbm(33, seed=3).heights, fbm(33, seed=3).heights)
    assert generate("fbm", 33, seed=3).shape == (33, 33)


def test_typo_suggests_a_command_from_the_table(capsys) -> None:
    from terrascape.cli import run_app

    assert run_app(["rendr"]) == 2
    assert "Did you mean 'render'" in capsys.readouterr().err


def test_the_probe_sees_heavy_modules_once_loaded() -> None:  # it cannot pass vacuously
    modules, _ = _modules_after("import numpy")
    assert "numpy" in modules and _heavy(modules)
    assert json.dumps(sorted(modules))


def test_lazy_package_keeps_functions_over_same_named_submodules():
    """``from terrascape.generate import diamond_square`` is the function, whatever was
    imported before (the submodule of the same name sets the package attribute)."""
    code = (
        "import importlib, types\n"
        "importlib.import_module('terrascape.generate.diamond_square')\n"
        "importlib.import_module('terrascape.io.image')\n"
        "from terrascape.generate import diamond_square\n"
        "from terrascape.io import luminance\n"
        "assert not isinstance(diamond_square, types.ModuleType), diamond_square\n"
        "assert callable(diamond_square) and callable(luminance)\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True,
                   env={**os.environ, "PYTHONPATH": SRC}, timeout=120)
def test_a_name_shared_with_its_module_stays_the_function() -> None:
    """generate.hills is the function even after the module hills was imported (the import
    system sets the package attribute to the submodule)."""
    code = ("import terrascape.generate.hills, terrascape.generate.diamond_square, "
            "terrascape.generate.square_square\nimport terrascape.generate as g\n"
            "assert callable(g.hills) and callable(g.diamond_square), (g.hills,)\n"
            "assert callable(g.square_square)\n"
            "from terrascape.generate import hills\nassert hills(9, seed=1).shape == (9, 9)")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=300,
                   env={**os.environ, "PYTHONPATH": SRC})


def _typer_help(width: int) -> str:
    """typer's own top-level help at ``width`` columns (the reference the quick help copies)."""
    code = "from terrascape.cli.app import run_app\nrun_app(['--help'])"
    env = {**os.environ, "PYTHONPATH": SRC, "COLUMNS": str(width)}
    for variable in ("FORCE_COLOR", "NO_COLOR", "TERMINAL_WIDTH", "PY_COLORS"):
        env.pop(variable, None)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=env, timeout=120, check=True).stdout


@pytest.mark.parametrize("width", [50, 80, 100, 200])
def test_quick_help_is_typers_help_line_for_line(width: int) -> None:
    from terrascape.cli.quick_help import top_level_help

    assert top_level_help(width) == _typer_help(width)


def test_quick_help_in_colour_is_the_same_text() -> None:
    import re

    from terrascape.cli.quick_help import top_level_help

    styled = top_level_help(100, styled=True)
    assert "\x1b[1;36mrender" in styled and "\x1b[2m╭─" in styled
    assert re.sub("\x1b\\[[0-9;]*m", "", styled) == top_level_help(100)


def test_python_m_terrascape_help_loads_only_the_standard_library() -> None:
    """``python -X importtime -m terrascape --help``: every module it imports, by name."""
    env = {**os.environ, "PYTHONPATH": SRC, "COLUMNS": "120"}
    env.pop("FORCE_COLOR", None)
    result = subprocess.run([sys.executable, "-X", "importtime", "-m", "terrascape", "--help"],
                            capture_output=True, text=True, env=env, timeout=120, check=True)
    imported = {line.split("|")[-1].strip() for line in result.stderr.splitlines()
                if line.startswith("import time:") and "|" in line}
    assert "terrascape.cli.quick_help" in imported  # the probe sees our own modules
    top = {name.split(".")[0] for name in imported}
    assert not top & {"typer", "rich", "click", "numpy", "numba", "scipy", "markdown_it"}
    from terrascape.cli.commands import COMMANDS

    assert all(f"│ {name} " in result.stdout for name in COMMANDS)


def test_no_arguments_prints_the_help_once_and_exits_with_the_usage_code() -> None:
    env = {**os.environ, "PYTHONPATH": SRC, "COLUMNS": "100"}
    result = subprocess.run([sys.executable, "-m", "terrascape"], capture_output=True,
                            text=True, env=env, timeout=120, check=False)
    assert result.returncode == 2
    assert result.stdout.count("Usage: terrascape") == 1
    assert "│ world " in result.stdout


def test_narrow_or_forced_colour_terminals_get_typers_help() -> None:
    from terrascape.cli.quick_help import MIN_WIDTH, print_quick_help

    code = ("import sys\nfrom terrascape.cli import run_app\nrc = run_app(['--help'])\n"
            "sys.stderr.write('TYPER ' + str('typer' in sys.modules))")
    for extra in ({"COLUMNS": str(MIN_WIDTH - 1)}, {"COLUMNS": "100", "FORCE_COLOR": "1"}):
        env = {**os.environ, "PYTHONPATH": SRC, **extra}
        result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                env=env, timeout=120, check=True)
        assert "TYPER True" in result.stderr and "Usage:" in result.stdout
    assert print_quick_help(["info", "--help"]) is None  # a command's help is typer's
