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
