from terrascape.cli.app import run_app


def test_help_exits_zero(capsys):
    assert run_app(["--help"]) == 0
    assert "terrascape" in capsys.readouterr().out


def test_unknown_option_is_usage_error():
    assert run_app(["--no-such-option"]) == 2


def test_unknown_benchmark_is_usage_error():
    assert run_app(["bench", "no-such-bench"]) == 2


def test_bench_prints_markdown_tables_in_full(capsys):
    assert run_app(["bench", "generate", "--quick", "--markdown"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("| "))
    assert lines[header + 1].startswith("|---")
    # A data row has as many cells as the header, none cut short by the terminal width.
    assert lines[header + 2].count("|") == lines[header].count("|")
    assert "━" not in out and "┃" not in out  # no rich box drawing


def test_plain_maps_need_no_world_extra(tmp_path, gl_ctx):
    # The demo's install has no zarr/dask (the `world` extra): rendering or exporting a plain
    # heightmap file must not go through the world-store module, which imports them.
    import subprocess
    import sys

    import numpy as np
    from PIL import Image

    from terrascape import Heightmap
    from terrascape.generate.registry import generate
    from terrascape.io import write_heightmap

    hm = generate("fbm", 65, seed=3, spacing=1.0)
    write_heightmap(Heightmap(hm.heights * 20.0), tmp_path / "map.png")
    script = (
        "import sys; sys.modules['zarr'] = None; sys.modules['dask'] = None\n"
        "from terrascape.cli import run_app\n"
        "code = run_app(sys.argv[1:])\n"
        "assert 'terrascape.world' not in sys.modules, 'the world module was imported'\n"
        "sys.exit(code)\n")
    for args in (["render", "map.png", "-o", "r.png", "--size", "64x36", "-q"],
                 ["export", "unity", "map.png", "-o", "unity", "-q"]):
        done = subprocess.run([sys.executable, "-c", script, *args], cwd=tmp_path,
                              capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr[-500:]
    picture = np.asarray(Image.open(tmp_path / "r.png").convert("RGB"), dtype=np.float32)
    assert picture.shape == (36, 64, 3) and picture.std() > 5.0
    assert any((tmp_path / "unity").glob("*.raw"))


def test_a_slow_stage_says_why_while_it_runs(monkeypatch, capsys):
    import importlib
    import time

    cli_app = importlib.import_module("terrascape.cli.app")  # the module, not its app

    monkeypatch.setattr(cli_app, "SLOW_NOTE_AFTER", 0.05)
    with cli_app.timed("meshing", slow_note="compiling once"):
        time.sleep(0.6)
    err = capsys.readouterr().err
    assert "meshing: still working after 0.05 s — compiling once" in err
    assert err.index("still working") < err.index("meshing… ")  # while it ran
    # "in time": well within the threshold even when a loaded machine stalls this thread (at
    # 0.05 s, a stall between starting the timer and leaving the block would show the note)
    monkeypatch.setattr(cli_app, "SLOW_NOTE_AFTER", 5.0)
    with cli_app.timed("fast", slow_note="not shown: done in time"):
        pass
    monkeypatch.setattr(cli_app, "SLOW_NOTE_AFTER", 0.05)
    with cli_app.timed("hushed", quiet=True, slow_note="not shown: quiet"):
        time.sleep(0.3)
    time.sleep(0.2)  # a timer that was not cancelled would print by now
    assert "not shown" not in capsys.readouterr().err
